//! Undercuts of a two-half mould, and the automatic choice of the demolding direction.
//!
//! # The undercut rule, for a direction D
//!
//! A two-half mould opens along D: one half moves towards +D, the other towards -D.
//!
//! - A facet **facing +D** (n · D > [`PARALLEL_TOLERANCE`]) is moulded by the +D half, so
//!   the space along +D from its surface must be free: from each sample point (the centroid,
//!   or a lattice, see [`Sampling`]) a ray goes along +D, skipping the facet itself and any
//!   hit nearer than 1e-6 of the box diagonal. A sample whose ray hits any triangle is
//!   **blocked**.
//! - A facet **facing -D** is tested the same way along -D.
//! - A facet **parallel to D** (|n · D| <= the tolerance: walls without draft) is never an
//!   undercut: it slides along the mould. Facets without area count for nothing.
//!
//! The undercut area is the sum over facets of area x (blocked samples / samples). D and -D
//! give the same area (the same facets are tested along the same rays), so each line is
//! evaluated once.
//!
//! The rays of a line are all parallel, so [`undercut`] answers them the way the gate's
//! projection answers its lattice (drawing each triangle into the rays it covers, exact in
//! f64, a ray through an edge shared by two triangles meeting exactly one of them), not by
//! tracing each ray through a tree of boxes; [`undercut_by_rays`] traces them (f32, a
//! tolerance at edges) and is kept as the independent check. The two agree but at rays that
//! graze an edge or a vertex.
//!
//! # The automatic direction
//!
//! [`auto_direction`] tries the three axis lines and the three principal axes of the surface
//! (the eigenvectors of the area-weighted covariance of its points, Eq. 3-5's weights; a
//! principal axis within 1e-6 rad of an axis or of another candidate is dropped). It picks the
//! line with the least undercut area, where lines whose undercut areas differ by at most
//! [`TIE_SHARE`] (1 %) of the part's surface area are a **tie**: the areas of a ray test on
//! a tessellated part move by that much with the tessellation, so a flat tile with 61.5 mm^2
//! along x and 61.7 mm^2 along its thickness z does not open sideways. Among the tied lines:
//!
//! 1. the smallest extent of the part along the line wins (the shallowest draw: a plate opens
//!    along its thickness), extents within [`TIE_SHARE`] of each other being equal;
//! 2. then a line on which a gate qualifies, when the caller can tell
//!    ([`auto_direction_checked`] takes a closure, e.g. one that runs [`crate::locate`]; it is
//!    asked only about lines still tied, at most once each);
//! 3. then the order tried (x, y, z, then principal axes by decreasing spread).
//!
//! **Lines that cannot win are not drawn ray by ray.** Each line first gets a lower bound of
//! its undercut: the rays of the largest facets only (one in 16 by area, at least 4096),
//! drawn against those facets only; a ray they block is blocked by the whole part too. Then
//! the line of least bound gets a tighter bound (one facet in 8), and then every ray, until
//! the least bound left exceeds the least undercut drawn by more than the tie. A line left
//! out has an undercut above its bound, so it is neither the least nor tied: the choice,
//! and the undercut of every line drawn, are those of drawing every line, bit for bit. The
//! lines left out report their bound ([`Candidate::evaluated`] is false: "at least").
//! The principal axes get their first bound only after the first line drawn ray by ray, and
//! it stops once it exceeds that line's undercut by more than the tie (so it is looser than
//! the whole first bound, but still a lower bound): the axes are the likely choices of a
//! designed part, and a principal axis near an axis is the dearest line to bound.
//! On the 352k-triangle housing, five of its six lines stop at a bound.
//!
//! **Work beside the rays.** The first line drawn ray by ray is the one of least bound, the
//! one chosen unless another ties with it: [`auto_direction_beside`] runs a caller's work
//! (the study's `locate`) at the same time as its rays and the rest of the choice after
//! them (the principal axes' bounds, tighter bounds), along it or along a shallower line
//! whose bound may tie with it, so that the gate of the chosen line is found while the
//! rays are drawn, not after.
//!
//! **Sign.** D and -D mould alike, so the sign follows the project's convention (the shared
//! parts' `SOURCES.md`): D points to the open or core side, which is the side away from the
//! bulk of the material. It is the sign for which the box centre lies ahead of the volume
//! centroid along D (the surface centroid for a mesh that encloses no volume): a cover
//! whose top is at +z and opening at -z gets -z. When the two are within [`TIE_SHARE`]
//! (1 %) of the part's extent along the line of each other, the bulk sits at the middle and
//! does not tell: the side the surface centroid lies on from the volume centroid is taken
//! (ribs and bosses put more surface than volume on the core side; the LCD knob's rib side,
//! +z). When that does not tell either (within 1e-6 of the diagonal, or no volume), the
//! sign of the box centre's offset, and without one the sign with a positive largest
//! component.
//!
//! A part with some undercut is normal (a thread, a snap hook), so the choice is made and
//! the caller warns with its area; only a mesh with no facet of area cannot be evaluated.

use std::cmp::Ordering;

use rayon::prelude::*;
use serde::Serialize;
use thiserror::Error;

use crate::centre::Centres;
use crate::frame::{Direction, Frame};
use crate::gate::projection::{self, BlockedRay, PointRay, RaySink};
use crate::math::DVec3;
use crate::mesh::{LoadedMesh, Mesh};
pub use crate::raycast::Sampling;
use crate::raycast::{Bvh, Ray};

/// Undercut areas (and extents) within this share of the part's surface area (extent) of
/// each other are a tie in [`auto_direction`].
pub const TIE_SHARE: f64 = 0.01;

/// |n · D| at or below which a facet is parallel to D (about 0.06 degrees of draft).
pub const PARALLEL_TOLERANCE: f64 = 1e-3;

/// Why no direction could be evaluated.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum DemoldError {
    /// The mesh has no facet with area (or no finite one).
    #[error("no facet with area: no demolding direction can be evaluated")]
    NothingToEvaluate,
    /// The lines' rays would cost more than [`AUTO_RAY_TEST_BUDGET`]: the triangles overlap
    /// deeply along the lines tried (random, repeated or needle-like triangles), which the
    /// surface of a moulded part does not.
    #[error(
        "the lines' rays passed the budget of {budget:.1e} ray-triangle tests and were stopped; the surface of a moulded part is crossed a few times by each ray, so this mesh holds overlapping, random or needle-like triangles; give the demolding direction instead"
    )]
    TooManyTests {
        /// The budget of tests.
        budget: f64,
    },
    /// The study was stopped (its time limit, or a cancel) while the lines were drawn.
    #[error("the choice of the demolding direction was stopped")]
    Cancelled,
}

/// The most ray-triangle tests the choice of a line may make, over every line it draws (a
/// triangle counted for the rays of every cell its projected box covers, see
/// [`projection::TestBudget`]). The shared parts' choices make 5.6e4 to 5.4e6 (the most,
/// the 352k-triangle housing); 50,000 needle-like triangles spanning a 100 mm box, whose
/// whole choice took 23 s on two threads, pass the budget after about 4 s and are refused.
pub const AUTO_RAY_TEST_BUDGET: f64 = 1e9;

/// The undercut of one demolding line.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Undercut {
    /// Undercut area, mm^2.
    pub area_mm2: f64,
    /// Undercut area over the whole surface area (0 to 1).
    pub share: f64,
}

/// Undercut area of the part for a mould opening along `d` (and -`d`, which is the same).
///
/// Every ray of one line is parallel to it, so they are answered all at once by drawing the
/// triangles into them ([`crate::gate::projection::blocked`], the gate's rasteriser at the
/// rays' scattered start points) instead of tracing each through a tree.
///
/// Its drawing has no budget of tests (the choice of a line, [`auto_direction`], has).
pub fn undercut(mesh: &Mesh, d: Direction, sampling: Sampling) -> Undercut {
    Surface::new(mesh, sampling, &projection::TestBudget::unlimited()).undercut(d)
}

/// What every line tried shares: the total area and the largest facets of each bound level.
/// A facet's normal and sample points are made again where a line needs them (from its
/// corners, by the same arithmetic, so to the same bits): on a large part a pass over the
/// corners costs less than the memory that would hold them.
struct Surface<'a> {
    mesh: &'a Mesh,
    sampling: Sampling,
    /// Area of the facets with one, summed like [`sum_blocks`] sums.
    area: f64,
    /// Per level of [`BOUND_LEVELS`], the largest facets, in index order, and their
    /// triangles: what [`Surface::lower_bound`] draws.
    largest: Vec<Largest>,
    min_hit: f64,
    /// The tests every drawing of the choice shares.
    budget: &'a projection::TestBudget,
}

/// A facet's area and unit normal, `None` without a finite area.
#[inline]
fn facet([a, b, c]: [DVec3; 3]) -> Option<(f64, DVec3)> {
    let cross = (b - a).cross(c - a);
    let area = 0.5 * cross.length();
    (area.is_finite() && area > 0.0).then(|| (area, cross / (2.0 * area)))
}

/// How a facet of area and normal `facet` sits against `line`.
#[inline]
fn facing_of(facet: Option<(f64, DVec3)>, line: DVec3) -> Facing {
    match facet {
        None => Facing::Nothing,
        Some((area, normal)) => {
            let along = normal.dot(line);
            if along.abs() <= PARALLEL_TOLERANCE {
                Facing::Parallel { area }
            } else {
                Facing::Side {
                    area,
                    up: along > 0.0,
                }
            }
        }
    }
}

/// `Some(up)` when the facet with these corners faces a side of `line` (its rays go along
/// +line when `up`), `None` when it is parallel or has no area: what
/// `facing_of(facet(corners), line)` says, to the bit, mostly without the normal's
/// divisions. The normal's component along the line is `cross . line / |cross|`; taken so,
/// it is within 2e-15 of the normal's own (each rounding is within 2^-53 of terms at most
/// 1), so one further than 1e-12 from the tolerance is on the same side of it; the few
/// nearer are decided by the normal itself.
#[inline]
fn faces_side(corners: [DVec3; 3], line: DVec3) -> Option<bool> {
    let [a, b, c] = corners;
    let cross = (b - a).cross(c - a);
    // Twice the area, as `facet` has it (0.5 and 2 scale exactly).
    let double = cross.length();
    if !(double.is_finite() && double > 0.0) {
        return None;
    }
    let along = cross.dot(line);
    let margin = 1e-12 * double;
    let tolerance = PARALLEL_TOLERANCE * double;
    if along.abs() > tolerance + margin {
        Some(along > 0.0)
    } else if along.abs() < tolerance - margin {
        None
    } else {
        match facing_of(facet(corners), line) {
            Facing::Side { up, .. } => Some(up),
            _ => None,
        }
    }
}

/// Facets per block of rays handed to [`projection::blocked_in_blocks`].
const RAY_BLOCK: usize = 1024;

impl<'a> Surface<'a> {
    /// What every line shares; its drawings charge their tests to `budget`.
    fn new(mesh: &'a Mesh, sampling: Sampling, budget: &'a projection::TestBudget) -> Surface<'a> {
        let n = mesh.triangles.len();
        let areas: Vec<f64> = (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .map(|t| facet(mesh.corners(t)).map_or(0.0, |(a, _)| a))
            .collect();
        let area = sum_blocks(n, |t| (areas[t], areas[t])).area_mm2;
        // The k-th largest area of each level, the levels' k growing: one copy of the
        // areas, each selection within what the one before left below its own.
        let ks: Vec<usize> = BOUND_LEVELS
            .iter()
            .map(|&share| (n / share).max(LARGEST_AT_LEAST.min(n)))
            .collect();
        debug_assert!(ks.windows(2).all(|k| k[0] <= k[1]));
        let mut sorted = Vec::new();
        // The k and the k-th largest area of the selection before.
        let mut before = (0, 0.0);
        let thresholds: Vec<f64> = ks
            .iter()
            .map(|&k| {
                if k == 0 || k >= n {
                    return 0.0;
                }
                if k > before.0 {
                    if sorted.is_empty() {
                        sorted = areas.clone();
                    }
                    // The first `before.0` are the largest: the k-th largest is the
                    // (k - before.0)-th of the rest.
                    let value = *sorted[before.0..]
                        .select_nth_unstable_by(k - 1 - before.0, |a, b| b.total_cmp(a))
                        .1;
                    before = (k, value);
                }
                before.1
            })
            .collect();
        drop(sorted);
        let largest = ks
            .par_iter()
            .zip(&thresholds)
            .map(|(&k, &threshold)| {
                // Those above it, then those equal to it in index order up to k in all (so
                // that a mesh of equal facets does not put all of them in the bound). The
                // ones at least the threshold are found in parallel, in index order; the few
                // among them equal to it are then taken in that order.
                let at_least: Vec<u32> = (0..n as u32)
                    .into_par_iter()
                    .with_min_len(4096)
                    .filter(|&t| areas[t as usize] > 0.0 && areas[t as usize] >= threshold)
                    .collect();
                let area = |t: u32| areas[t as usize];
                let above = at_least.iter().filter(|&&t| area(t) > threshold).count();
                let mut equal = k.saturating_sub(above);
                let facets: Vec<u32> = at_least
                    .into_iter()
                    .filter(|&t| {
                        area(t) > threshold || {
                            let take = equal > 0;
                            equal = equal.saturating_sub(1);
                            take
                        }
                    })
                    .collect();
                let triangles = facets
                    .par_iter()
                    .with_min_len(4096)
                    .map(|&t| mesh.triangles[t as usize])
                    .collect();
                Largest {
                    every: k >= n,
                    facets,
                    triangles,
                }
            })
            .collect();
        Surface {
            mesh,
            sampling,
            area,
            largest,
            min_hit: min_hit(mesh),
            budget,
        }
    }

    /// Pushes into `sink` the rays along `line` of facet `t`, each naming `k` as its
    /// triangle: one from each sample point when the facet faces a side, none otherwise.
    #[inline]
    fn rays_of(&self, k: usize, t: usize, line: DVec3, sink: &mut RaySink) {
        let corners = self.mesh.corners(t);
        if let Some(up) = faces_side(corners, line) {
            self.sampling.for_each(corners, |p| {
                sink.push(PointRay {
                    origin: p,
                    triangle: k as u32,
                    up,
                })
            });
        }
    }

    /// The rays of `count` facets along `d`, the k-th being facet `facet(k)` (each ray names
    /// k), drawn against `triangles`; the blocked area of the facets, summed by `sum` from
    /// (k, blocked area) in increasing k (facets with no ray blocked left out). When
    /// `stop_above` is finite, the triangles are drawn in [`STOP_ROUNDS`] runs and the drawing
    /// stops after the first run that takes the blocked area above it: that area is the
    /// answer (a lower bound of the whole drawing's).
    fn draw(
        &self,
        d: Direction,
        (count, facet_of): (usize, impl Fn(usize) -> usize + Sync),
        triangles: &[[u32; 3]],
        sum: impl Fn(&mut dyn Iterator<Item = (usize, f64)>) -> f64,
        stop_above: f64,
    ) -> Undercut {
        let line = d.vector();
        // The blocked rays in the order of their numbers, so of their facets: one run per
        // facet with a ray blocked.
        let area_of = |found: &[BlockedRay]| {
            let mut runs = found.chunk_by(|a, b| a.triangle == b.triangle).map(|run| {
                let k = run[0].triangle as usize;
                let corners = self.mesh.corners(facet_of(k));
                let mut samples = 0;
                self.sampling.for_each(corners, |_| samples += 1);
                let (_, a) = facing_of(facet(corners), line).blocked(run.len(), samples);
                (k, a)
            });
            sum(&mut runs)
        };
        let found = projection::blocked_until(
            &self.mesh.vertices,
            &Frame::new(d),
            (
                triangles,
                if stop_above.is_finite() {
                    STOP_ROUNDS
                } else {
                    1
                },
            ),
            count.div_ceil(RAY_BLOCK),
            |b, sink| {
                for k in b * RAY_BLOCK..((b + 1) * RAY_BLOCK).min(count) {
                    self.rays_of(k, facet_of(k), line, sink);
                }
            },
            self.min_hit,
            |found| area_of(found) > stop_above,
            self.budget,
        );
        let area = area_of(&found);
        Undercut {
            area_mm2: area,
            share: if self.area > 0.0 {
                area / self.area
            } else {
                0.0
            },
        }
    }

    /// A lower bound of the undercut area along `d`: the rays of the largest facets only
    /// (those of `level`), drawn against those facets only. A ray that one of them
    /// blocks is blocked when every triangle is drawn (the same arithmetic, the ray's own
    /// facet skipped in both), so the bound never exceeds [`Surface::undercut`]. With every
    /// facet among the largest (a small mesh) it is [`Surface::undercut`].
    fn lower_bound(&self, d: Direction, level: usize, stop_above: f64) -> Undercut {
        let largest = &self.largest[level];
        if largest.every {
            return self.undercut(d);
        }
        // Ray k's triangle is the k-th of the largest facets, its index in `largest.triangles`.
        // The facets in index order, each adding its blocked area (those with none would add
        // zero, which changes no bit of the sum).
        self.draw(
            d,
            (largest.facets.len(), |k| largest.facets[k] as usize),
            &largest.triangles,
            |runs| runs.fold(0.0, |sum, (_, a)| sum + a),
            stop_above,
        )
    }

    /// The undercut along `d`, every ray drawn.
    fn undercut(&self, d: Direction) -> Undercut {
        // Summed as [`sum_blocks`] sums: in blocks of facets, each in order, then the blocks
        // in order; a facet or a block with nothing blocked would add zero.
        self.draw(
            d,
            (self.mesh.triangles.len(), |t| t),
            &self.mesh.triangles,
            |runs| {
                let (mut total, mut block, mut in_block) = (0.0, None, 0.0);
                for (t, a) in runs {
                    if block != Some(t / SUM_BLOCK) {
                        total += in_block;
                        in_block = 0.0;
                        block = Some(t / SUM_BLOCK);
                    }
                    in_block += a;
                }
                total + in_block
            },
            f64::INFINITY,
        )
    }
}

/// [`undercut`] by tracing every ray through a tree: the same rule, slower; kept as the
/// independent check of the drawn rays.
pub fn undercut_by_rays(mesh: &Mesh, bvh: &Bvh, d: Direction, sampling: Sampling) -> Undercut {
    let line = d.vector();
    let min_hit = min_hit(mesh);
    sum_blocks(mesh.triangles.len(), |t| {
        let f = facing(mesh, t, line);
        let Facing::Side { up, .. } = f else {
            return f.blocked(0, 1);
        };
        let dir = if up { line } else { -line };
        let (mut samples, mut hits) = (0usize, 0usize);
        sampling.for_each(mesh.corners(t), |p| {
            samples += 1;
            let ray = Ray::new(p, dir)
                .within(min_hit, f64::INFINITY)
                .skipping(t as u32);
            if bvh.any_hit(&ray) {
                hits += 1;
            }
        });
        f.blocked(hits, samples)
    })
}

/// Runs the triangles of a bound are drawn in when the bound need only exceed a value
/// ([`Surface::draw`]).
const STOP_ROUNDS: usize = 16;

/// The levels of the lower bound of a line's undercut ([`Surface::lower_bound`]): one facet
/// in this many, the largest, then one in that many.
const BOUND_LEVELS: [usize; 2] = [16, 8];

/// The largest facets of a level of [`BOUND_LEVELS`].
struct Largest {
    facets: Vec<u32>,
    triangles: Vec<[u32; 3]>,
    /// Whether they are every facet (a small mesh): the bound is the undercut.
    every: bool,
}

/// ... but at least this many facets (all of a smaller mesh: its bound is its undercut).
const LARGEST_AT_LEAST: usize = 4096;

/// Hits nearer than this along a ray are ignored: 1e-6 of the box diagonal.
fn min_hit(mesh: &Mesh) -> f64 {
    let diagonal = mesh.bounds().diagonal();
    if diagonal.is_finite() {
        1e-6 * diagonal
    } else {
        0.0
    }
}

/// Sums (area, blocked area) over the facets in fixed blocks of triangles, each summed in
/// order, then the blocks in order: the total does not depend on the number of threads or
/// on scheduling.
fn sum_blocks(n: usize, facet: impl Fn(usize) -> (f64, f64) + Sync) -> Undercut {
    let blocks: Vec<(f64, f64)> = (0..n.div_ceil(SUM_BLOCK))
        .into_par_iter()
        .map(|b| {
            (b * SUM_BLOCK..((b + 1) * SUM_BLOCK).min(n))
                .map(&facet)
                .fold((0.0, 0.0), |x, y| (x.0 + y.0, x.1 + y.1))
        })
        .collect();
    let (total, blocked) = blocks
        .iter()
        .fold((0.0, 0.0), |x, y| (x.0 + y.0, x.1 + y.1));
    Undercut {
        area_mm2: blocked,
        share: if total > 0.0 { blocked / total } else { 0.0 },
    }
}

/// Triangles per block of the undercut sum (the blocks are fixed, so is the sum).
const SUM_BLOCK: usize = 1024;

/// How a facet sits against a line.
#[derive(Debug, Clone, Copy)]
enum Facing {
    /// No area (or not a finite one): counts for nothing.
    Nothing,
    /// Parallel to the line: never an undercut.
    Parallel { area: f64 },
    /// Facing +line (`up`) or -line: tested along it.
    Side { area: f64, up: bool },
}

impl Facing {
    /// (area, blocked area) when `hits` of its `samples` rays are blocked.
    fn blocked(self, hits: usize, samples: usize) -> (f64, f64) {
        match self {
            Facing::Nothing => (0.0, 0.0),
            Facing::Parallel { area } => (area, 0.0),
            Facing::Side { area, .. } => (area, area * hits as f64 / samples.max(1) as f64),
        }
    }
}

fn facing(mesh: &Mesh, t: usize, line: DVec3) -> Facing {
    facing_of(facet(mesh.corners(t)), line)
}

/// Where a candidate line came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CandidateKind {
    /// A world axis.
    Axis,
    /// A principal axis of the surface.
    Principal,
}

/// One direction tried by [`auto_direction`]. Its JSON has its [`Candidate::label`] too.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The direction, signed by the module's rule.
    pub direction: [f64; 3],
    /// Axis or principal axis.
    pub kind: CandidateKind,
    /// Its undercut; a lower bound of it when `evaluated` is false.
    pub undercut: Undercut,
    /// Whether every ray of the line was drawn. A line whose lower bound (the rays of its
    /// largest facets) already exceeds the least undercut by more than the tie is not: it
    /// cannot be chosen, and `undercut` holds that bound (the undercut is at least that).
    pub evaluated: bool,
    /// Extent of the part along it, mm (the first tie-break).
    pub extent_mm: f64,
    /// Whether a gate qualifies on it, when the tie-break asked (the second tie-break);
    /// `None` when it was not asked.
    pub gate_qualifies: Option<bool>,
}

impl Serialize for Candidate {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        /// The fields in their order, with the label after the kind.
        #[derive(Serialize)]
        struct Fields<'a> {
            direction: [f64; 3],
            kind: CandidateKind,
            label: String,
            #[serde(flatten)]
            undercut: &'a Undercut,
            evaluated: bool,
            extent_mm: f64,
            gate_qualifies: Option<bool>,
        }
        Fields {
            direction: self.direction,
            kind: self.kind,
            label: self.label(),
            undercut: &self.undercut,
            evaluated: self.evaluated,
            extent_mm: self.extent_mm,
            gate_qualifies: self.gate_qualifies,
        }
        .serialize(serializer)
    }
}

impl Candidate {
    /// What the line is, for a reader of the list of lines tried: "x axis", or for a
    /// principal axis its angle to the nearest world axis ("principal axis 0.027 deg from
    /// z"), so that a principal axis that prints as an axis at three decimals is told from
    /// that axis. Angles are printed to 0.001 degree; below that, "within 0.001 deg of z".
    pub fn label(&self) -> String {
        let d = DVec3::from_array(self.direction);
        let a = d.abs();
        // The nearest axis, and the length of the components across it.
        let (axis, across) = if a.x >= a.y && a.x >= a.z {
            ("x", a.y.hypot(a.z))
        } else if a.y >= a.z {
            ("y", a.x.hypot(a.z))
        } else {
            ("z", a.x.hypot(a.y))
        };
        match self.kind {
            CandidateKind::Axis => format!("{axis} axis"),
            CandidateKind::Principal => {
                // asin of the components across the axis keeps its precision near 0 (acos
                // of a cosine near 1 does not).
                let deg = across.min(1.0).asin().to_degrees();
                if deg < 0.0005 {
                    format!("principal axis within 0.001 deg of {axis}")
                } else {
                    format!("principal axis {deg:.3} deg from {axis}")
                }
            }
        }
    }
}

/// The result of [`auto_direction`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AutoDemold {
    /// Index of the chosen candidate in `tried`.
    pub chosen: usize,
    /// Every candidate, in the order tried.
    pub tried: Vec<Candidate>,
    /// Undercut areas within this many mm^2 of the least were a tie ([`TIE_SHARE`] of the
    /// surface area).
    pub tie_mm2: f64,
}

impl AutoDemold {
    /// The chosen candidate.
    pub fn candidate(&self) -> &Candidate {
        &self.tried[self.chosen]
    }

    /// The chosen direction.
    pub fn direction(&self) -> Direction {
        Direction::new(DVec3::from_array(self.candidate().direction))
            .expect("candidates are unit vectors")
    }
}

/// Tries the axis lines and the principal axes and picks the one with the least undercut
/// area (see the module for the rule, the tie-break and the sign).
pub fn auto_direction(mesh: &Mesh, sampling: Sampling) -> Result<AutoDemold, DemoldError> {
    auto_direction_checked(mesh, sampling, |_| true)
}

/// [`auto_direction`] whose second tie-break asks `gate_qualifies` whether a gate
/// qualifies on a direction (e.g. by running [`crate::locate`] along it).
pub fn auto_direction_checked(
    mesh: &Mesh,
    sampling: Sampling,
    mut gate_qualifies: impl FnMut(Direction) -> bool,
) -> Result<AutoDemold, DemoldError> {
    auto_direction_beside(mesh, sampling, |_| (), |d, _| gate_qualifies(d)).map(|(auto, _)| auto)
}

/// [`auto_direction_checked`] that also runs `beside` once, along the likeliest choice,
/// at the same time as the rays of the first line it draws ray by ray and the rest of the
/// choice after them, and hands back that line with what `beside` gave.
///
/// The first line drawn ray by ray is the one of least lower bound, which is the one
/// chosen unless another line ties with it; the likeliest choice is that line, or among
/// the lines whose bounds are within the tie of its bound the one the tie-break would take
/// (the shallowest draw). A caller that needs the work of `beside` along the chosen line
/// (the study's `locate`) starts it early, and its sequential steps and the choice's fill
/// the time each other leaves a thread idle. When the tie-break asks about that line, `gate_qualifies` gets what
/// `beside` gave for it (`Some`), else `None`. The choice and every undercut are those of
/// [`auto_direction_checked`]: `beside` reads nothing of the rays.
pub fn auto_direction_beside<T: Send>(
    mesh: &Mesh,
    sampling: Sampling,
    beside: impl Fn(Direction) -> T + Sync,
    gate_qualifies: impl FnMut(Direction, Option<&T>) -> bool,
) -> Result<(AutoDemold, Option<(Direction, T)>), DemoldError> {
    choose(
        mesh,
        None,
        sampling,
        beside,
        gate_qualifies,
        &projection::TestBudget::new(AUTO_RAY_TEST_BUDGET),
    )
}

/// [`auto_direction_beside`] of a loaded part: its centres, summed at load, are not summed
/// again ([`Centres::of`] the mesh gives the same bits).
pub fn auto_direction_beside_loaded<T: Send>(
    part: &LoadedMesh,
    sampling: Sampling,
    beside: impl Fn(Direction) -> T + Sync,
    gate_qualifies: impl FnMut(Direction, Option<&T>) -> bool,
) -> Result<(AutoDemold, Option<(Direction, T)>), DemoldError> {
    auto_direction_beside_loaded_until(part, sampling, beside, gate_qualifies, None)
}

/// [`auto_direction_beside_loaded`] that a set `cancel` token stops at the lines' next
/// batch of ray tests ([`DemoldError::Cancelled`]).
pub fn auto_direction_beside_loaded_until<T: Send>(
    part: &LoadedMesh,
    sampling: Sampling,
    beside: impl Fn(Direction) -> T + Sync,
    gate_qualifies: impl FnMut(Direction, Option<&T>) -> bool,
    cancel: Option<&crate::cancel::Cancel>,
) -> Result<(AutoDemold, Option<(Direction, T)>), DemoldError> {
    choose(
        &part.mesh,
        Some(part.centres),
        sampling,
        beside,
        gate_qualifies,
        &projection::TestBudget::new(AUTO_RAY_TEST_BUDGET).with_cancel(cancel),
    )
}

/// [`auto_direction_beside`], with the mesh's centres when they are known, its drawings
/// charged to `budget` (refused when they pass it).
fn choose<T: Send>(
    mesh: &Mesh,
    centres: Option<Centres>,
    sampling: Sampling,
    beside: impl Fn(Direction) -> T + Sync,
    mut gate_qualifies: impl FnMut(Direction, Option<&T>) -> bool,
    budget: &projection::TestBudget,
) -> Result<(AutoDemold, Option<(Direction, T)>), DemoldError> {
    // The principal axes are summed in order on one thread (their bits depend on it); the
    // centres (unless known) and what every line shares are made on the others meanwhile.
    let (axes, (centres, surface)) = rayon::join(
        || principal_axes(mesh),
        || {
            (
                centres.unwrap_or_else(|| Centres::of(mesh)),
                Surface::new(mesh, sampling, budget),
            )
        },
    );
    if !(centres.area_mm2.is_finite() && centres.area_mm2 > 0.0) {
        return Err(DemoldError::NothingToEvaluate);
    }
    let tried = candidates(mesh, &surface, &centres, axes);
    let tie = TIE_SHARE * centres.area_mm2;
    // The principal axes get their first bound only once a line has been drawn ray by ray,
    // and that bound stops as soon as it exceeds the least undercut by more than the tie.
    // On a designed part they are rarely chosen, and they are the dearest lines to bound: a
    // principal axis a few milliradians off an axis puts the rays and the triangles of every
    // wall facing a side in thin strips. A line whose bound stopped so reports it (it is
    // lower than the whole first bound, still a lower bound of its undercut). Which lines
    // are drawn ray by ray, and so the choice, is unchanged by the order: every line whose
    // undercut is within the tie of the least is drawn whatever the order of the bounds.
    let mut settling = Settling::new(&surface, tried, tie);
    // The line `beside` worked along, beside the first line drawn ray by ray, and what it
    // gave. The rest of the choice (the principal axes' bounds, tighter bounds, any other
    // line drawn ray by ray) needs nothing of `beside` either, so it runs on the same side
    // of the join as those rays, and fills the time `beside`'s sequential steps leave a
    // thread idle; it reads nothing `beside` gives, so it is the same choice.
    let early = match settling.settle(Stop::BeforeEveryRay) {
        None => None,
        Some(i) => {
            let likeliest = likeliest_choice(&settling.tried, i, tie);
            let along = Direction::new(DVec3::from_array(settling.tried[likeliest].direction))
                .expect("unit line");
            let d =
                Direction::new(DVec3::from_array(settling.tried[i].direction)).expect("unit line");
            let ((), done) = rayon::join(
                || {
                    settling.tried[i].undercut = settling.surface.undercut(d);
                    settling.tried[i].evaluated = true;
                    let none = settling.settle(Stop::Never);
                    debug_assert!(none.is_none());
                },
                || beside(along),
            );
            Some((along, done))
        }
    };
    let mut tried = settling.tried;
    // Stopped, or past the budget, the drawings stopped part way: no line's undercut is
    // known.
    if budget.cancelled() {
        return Err(DemoldError::Cancelled);
    }
    if budget.exceeded() {
        return Err(DemoldError::TooManyTests {
            budget: budget.limit(),
        });
    }
    let least = tried
        .iter()
        .filter(|c| c.evaluated)
        .map(|c| c.undercut.area_mm2)
        .fold(f64::INFINITY, f64::min);
    let mut tied: Vec<usize> = (0..tried.len())
        .filter(|&i| tried[i].evaluated && tried[i].undercut.area_mm2 <= least + tie)
        .collect();
    let shallowest = tied
        .iter()
        .map(|&i| tried[i].extent_mm)
        .fold(f64::INFINITY, f64::min);
    tied.retain(|&i| tried[i].extent_mm <= shallowest * (1.0 + TIE_SHARE));
    let mut chosen = tied[0];
    if tied.len() > 1 {
        for &i in &tied {
            let d = Direction::new(DVec3::from_array(tried[i].direction)).expect("unit line");
            let done = early.as_ref().filter(|(e, _)| *e == d).map(|(_, t)| t);
            let ok = gate_qualifies(d, done);
            tried[i].gate_qualifies = Some(ok);
            if ok {
                chosen = i;
                break;
            }
        }
    }
    Ok((
        AutoDemold {
            chosen,
            tried,
            tie_mm2: tie,
        },
        early,
    ))
}

/// The sign (+1 or -1) of `line` that points to the part's open side (the module's
/// *Sign*): the side the box centre lies on from the bulk (`ahead`, the box centre less
/// the volume centroid, or less the surface centroid when the mesh encloses no volume).
/// When the two are within [`TIE_SHARE`] of the part's `extent` along the line of each
/// other (a tie, as for the lines' extents: a part whose bulk sits at its middle; on the
/// shared parts, the LCD knob along its natural line, 0.8 %, where every other part with a
/// volume is 8 % or more off along its own), the side with more surface than
/// volume wins: the surface centroid lies on the side of the ribs and bosses, which the
/// core forms. Within 1e-6 of the `diagonal`, the sign of the line's largest component.
fn open_side(line: DVec3, ahead: DVec3, centres: &Centres, extent: f64, diagonal: f64) -> f64 {
    let largest = || {
        if line.x.abs() >= line.y.abs() && line.x.abs() >= line.z.abs() {
            line.x
        } else if line.y.abs() >= line.z.abs() {
            line.y
        } else {
            line.z
        }
        .signum()
    };
    let tiny = 1e-6 * diagonal;
    let along = ahead.dot(line);
    if along.abs() > TIE_SHARE * extent {
        return along.signum();
    }
    let surface_side = centres
        .volume
        .map_or(0.0, |v| (centres.surface - v).dot(line));
    if surface_side.abs() > tiny {
        surface_side.signum()
    } else if along.abs() > tiny {
        along.signum()
    } else {
        largest()
    }
}

/// The lines [`auto_direction`] tries (the axes, then the principal axes `axes` not equal
/// to one of them), each signed, with its extent and, for an axis, its first lower bound; a
/// principal axis's bound is infinite until [`Settling::settle`] bounds it.
fn candidates(
    mesh: &Mesh,
    surface: &Surface,
    centres: &Centres,
    axes: Vec<DVec3>,
) -> Vec<Candidate> {
    let bounds = mesh.bounds();
    let bulk = centres.volume.unwrap_or(centres.surface);
    let ahead = bounds.centre() - bulk;
    let mut lines: Vec<(DVec3, CandidateKind)> = vec![
        (DVec3::X, CandidateKind::Axis),
        (DVec3::Y, CandidateKind::Axis),
        (DVec3::Z, CandidateKind::Axis),
    ];
    for axis in axes {
        if lines.iter().all(|(l, _)| l.dot(axis).abs() < 1.0 - 1e-12) {
            lines.push((axis, CandidateKind::Principal));
        }
    }
    lines
        .into_par_iter()
        .map(|(line, kind)| {
            let (lo, hi) =
                mesh.vertices
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        let h = v.dot(line);
                        (lo.min(h), hi.max(h))
                    });
            let sign = open_side(line, ahead, centres, hi - lo, bounds.diagonal());
            // Adding 0 turns the -0 components of a negated axis into +0.
            let dir = line * sign + DVec3::ZERO;
            let (lo, hi) = if sign < 0.0 { (-hi, -lo) } else { (lo, hi) };
            let direction = Direction::new(dir).expect("unit line");
            // A principal axis is bounded later (see `choose`): until then its bound
            // is infinite, so no line is taken before it for it.
            let bound = match kind {
                CandidateKind::Axis => surface.lower_bound(direction, 0, f64::INFINITY),
                CandidateKind::Principal => Undercut {
                    area_mm2: f64::INFINITY,
                    share: f64::INFINITY,
                },
            };
            Candidate {
                direction: direction.vector().to_array(),
                kind,
                undercut: bound,
                extent_mm: hi - lo,
                gate_qualifies: None,
                evaluated: surface.largest[0].every && kind == CandidateKind::Axis,
            }
        })
        .collect()
}

/// When [`Settling::settle`] hands a line back instead of drawing it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stop {
    /// Before the first line drawn ray by ray: it is handed back, its level set.
    BeforeEveryRay,
    /// Never: every line that can still be chosen is drawn.
    Never,
}

/// Where [`auto_direction`]'s choice stands between its steps: the lines and what is known
/// of their undercuts, the principal axes still waiting for their first bound, and each
/// line's bound level.
struct Settling<'s, 'a> {
    surface: &'s Surface<'a>,
    tried: Vec<Candidate>,
    pending: Vec<bool>,
    level: Vec<usize>,
    tie: f64,
}

impl<'s, 'a> Settling<'s, 'a> {
    /// The choice before its first step: the principal axes wait for their first bound.
    fn new(surface: &'s Surface<'a>, tried: Vec<Candidate>, tie: f64) -> Settling<'s, 'a> {
        Settling {
            surface,
            pending: tried
                .iter()
                .map(|c| c.kind == CandidateKind::Principal)
                .collect(),
            level: vec![0; tried.len()],
            tried,
            tie,
        }
    }

    /// Bounds lines and draws them ray by ray until no line left out can be chosen (see
    /// the module). With [`Stop::BeforeEveryRay`], hands back the first line to be drawn
    /// ray by ray, undrawn, when no line has been drawn yet; else `None`.
    fn settle(&mut self, stop: Stop) -> Option<usize> {
        let Settling {
            surface,
            tried,
            pending,
            level,
            tie,
        } = self;
        let (surface, tie) = (*surface, *tie);
        // Every ray is drawn only for the lines that can still be chosen. The line of least
        // bound not drawn yet gets the next, tighter bound (more of the largest facets), and
        // at the last level every ray; until the least bound left exceeds the least undercut
        // found by more than the tie. A line left out has an undercut at least its bound, so
        // it is neither the least nor tied with it: the choice is the one every line drawn
        // would give.
        loop {
            let least = tried
                .iter()
                .filter(|c| c.evaluated)
                .map(|c| c.undercut.area_mm2)
                .fold(f64::INFINITY, f64::min);
            // The principal axes get their first bound only once a line has been drawn ray
            // by ray, and that bound stops as soon as it exceeds the least undercut by more
            // than the tie (see `choose`).
            if least.is_finite() && pending.contains(&true) {
                let bounds: Vec<(usize, Undercut)> = (0..tried.len())
                    .filter(|&i| pending[i])
                    .collect::<Vec<_>>()
                    .into_par_iter()
                    .map(|i| {
                        let d = Direction::new(DVec3::from_array(tried[i].direction))
                            .expect("unit line");
                        (i, surface.lower_bound(d, 0, least + tie))
                    })
                    .collect();
                for (i, bound) in bounds {
                    tried[i].undercut = bound;
                    tried[i].evaluated = surface.largest[0].every;
                    pending[i] = false;
                }
                continue;
            }
            let next = (0..tried.len())
                .filter(|&i| !tried[i].evaluated && !pending[i])
                .min_by(|&i, &j| {
                    tried[i]
                        .undercut
                        .area_mm2
                        .total_cmp(&tried[j].undercut.area_mm2)
                });
            let i = next.filter(|&i| tried[i].undercut.area_mm2 <= least + tie)?;
            let d = Direction::new(DVec3::from_array(tried[i].direction)).expect("unit line");
            // The first line drawn goes to every ray at once: its tighter bound would only
            // put off the drawing of the line that is, nearly always, the one chosen. A later
            // line's tighter bound need only exceed the least undercut by more than the tie,
            // and stops drawing once it does.
            level[i] = match least.is_finite() {
                true => level[i] + 1,
                false => BOUND_LEVELS.len(),
            };
            if level[i] < BOUND_LEVELS.len() {
                let bound = surface.lower_bound(d, level[i], least + tie);
                tried[i].evaluated = surface.largest[level[i]].every;
                if bound.area_mm2 > tried[i].undercut.area_mm2 || tried[i].evaluated {
                    tried[i].undercut = bound;
                }
            } else if stop == Stop::BeforeEveryRay && !least.is_finite() {
                return Some(i);
            } else {
                tried[i].undercut = surface.undercut(d);
                tried[i].evaluated = true;
            }
        }
    }
}

/// The line [`auto_direction_beside`] works along while line `first`, the line of least
/// bound, is drawn ray by ray: the one the tie-break would take if every line whose bound
/// is within the tie of `first`'s tied with it (the shallowest draw, extents within
/// [`TIE_SHARE`] equal, then the order tried). It is `first` but where a shallower line's
/// bound is as low, as on a flat tile whose thickness and length tie in undercut.
fn likeliest_choice(tried: &[Candidate], first: usize, tie: f64) -> usize {
    let bound = tried[first].undercut.area_mm2;
    let may_tie: Vec<usize> = (0..tried.len())
        .filter(|&j| tried[j].undercut.area_mm2 <= bound + tie)
        .collect();
    let shallowest = may_tie
        .iter()
        .map(|&j| tried[j].extent_mm)
        .fold(f64::INFINITY, f64::min);
    may_tie
        .into_iter()
        .find(|&j| tried[j].extent_mm <= shallowest * (1.0 + TIE_SHARE))
        .unwrap_or(first)
}

/// Principal axes of the surface: unit eigenvectors of the area-weighted covariance of its
/// points, by decreasing spread, each with its largest component positive.
#[allow(clippy::needless_range_loop)] // Matrix code reads best with indices.
pub fn principal_axes(mesh: &Mesh) -> Vec<DVec3> {
    let mut area = 0.0;
    let mut first = DVec3::ZERO;
    let mut second = [[0.0f64; 3]; 3];
    let origin = mesh.bounds().centre();
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(t).map(|v| v - origin);
        let w = 0.5 * (b - a).cross(c - a).length();
        if !w.is_finite() || w == 0.0 {
            continue;
        }
        let s = a + b + c;
        area += w;
        first += s * (w / 3.0);
        // The second moment of a uniform triangle: (a a' + b b' + c c' + s s') / 12. It is
        // symmetric to the bit (each product is the same either way round), so only the
        // upper triangle is summed.
        for i in 0..3 {
            for j in i..3 {
                second[i][j] += w / 12.0 * (a[i] * a[j] + b[i] * b[j] + c[i] * c[j] + s[i] * s[j]);
            }
        }
    }
    if area.partial_cmp(&0.0) != Some(Ordering::Greater) {
        return Vec::new();
    }
    for i in 1..3 {
        for j in 0..i {
            second[i][j] = second[j][i];
        }
    }
    let mean = first / area;
    let mut cov = [[0.0f64; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            cov[i][j] = second[i][j] / area - mean[i] * mean[j];
        }
    }
    let (values, vectors) = jacobi_eigen(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| values[j].total_cmp(&values[i]));
    order
        .iter()
        .map(|&k| {
            let v = DVec3::new(vectors[0][k], vectors[1][k], vectors[2][k]).normalize_or_zero();
            let a = v.abs();
            let largest = if a.x >= a.y && a.x >= a.z {
                v.x
            } else if a.y >= a.z {
                v.y
            } else {
                v.z
            };
            if largest < 0.0 {
                -v
            } else {
                v
            }
        })
        .filter(|v| v.is_finite() && *v != DVec3::ZERO)
        .collect()
}

#[allow(clippy::needless_range_loop)] // Matrix code reads best with indices.
/// Eigenvalues and eigenvectors (columns) of a symmetric 3 x 3 matrix by cyclic Jacobi
/// rotations.
fn jacobi_eigen(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..50 {
        let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
        let scale = a[0][0].powi(2) + a[1][1].powi(2) + a[2][2].powi(2);
        if off.partial_cmp(&(1e-30 * scale)) != Some(Ordering::Greater) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A <- J' A J with the rotation J in the (p, q) plane.
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - s * akq;
                a[k][q] = s * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in v.iter_mut() {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

#[cfg(test)]
mod tests {

    #[test]
    fn a_principal_axis_near_a_world_axis_is_labelled_with_its_angle() {
        // deskhop_case_bottom's third principal axis prints as (0.000, 0.000, 1.000) beside
        // the z axis: the label tells the two lines apart.
        let candidate = |direction: [f64; 3], kind| Candidate {
            direction,
            kind,
            undercut: Undercut {
                area_mm2: 0.0,
                share: 0.0,
            },
            evaluated: true,
            extent_mm: 1.0,
            gate_qualifies: None,
        };
        assert_eq!(
            candidate([0.0, 0.0, 1.0], CandidateKind::Axis).label(),
            "z axis"
        );
        assert_eq!(
            candidate([0.0, -1.0, 0.0], CandidateKind::Axis).label(),
            "y axis"
        );
        let tilt = 0.027f64.to_radians();
        let near_z = [tilt.sin(), 0.0, tilt.cos()];
        assert_eq!(
            candidate(near_z, CandidateKind::Principal).label(),
            "principal axis 0.027 deg from z"
        );
        assert_eq!(
            candidate([0.0, 1.0, 0.0], CandidateKind::Principal).label(),
            "principal axis within 0.001 deg of y"
        );
        let diagonal = [0.5f64.sqrt(), -(0.5f64.sqrt()), 0.0];
        assert_eq!(
            candidate(diagonal, CandidateKind::Principal).label(),
            "principal axis 45.000 deg from x"
        );
        // The JSON has the label after the kind, the undercut's fields flattened.
        let json = serde_json::to_string(&candidate(near_z, CandidateKind::Principal)).unwrap();
        assert!(
            json.contains(r#""kind":"principal","label":"principal axis 0.027 deg from z","area_mm2":0.0,"share":0.0,"evaluated":true"#),
            "{json}"
        );
    }
    use super::*;

    /// The open side: the box centre's side of the bulk, and within the tie (1 % of the
    /// extent) the surface centroid's side of the volume centroid, as on the LCD knob (box
    /// centre 0.06 mm below the volume centroid over 8 mm, surface centroid 0.07 mm above
    /// it: its rib side, +z).
    #[test]
    fn the_open_side_is_the_box_centre_s_and_in_a_tie_the_surface_s() {
        let centres = |surface: f64, volume: Option<f64>| Centres {
            surface: DVec3::new(0.0, 0.0, surface),
            area_mm2: 1.0,
            volume: volume.map(|z| DVec3::new(0.0, 0.0, z)),
            volume_mm3: 1.0,
        };
        let knob = centres(5.135, Some(5.065));
        let ahead = |bulk: f64| DVec3::new(0.0, 0.0, 5.0 - bulk);
        let side = |ahead: DVec3, c: &Centres| open_side(DVec3::Z, ahead, c, 8.0, 50.0);
        assert_eq!(side(ahead(5.065), &knob), 1.0);
        // Beyond the tie the box centre decides, whatever the surface.
        let cover = centres(5.135, Some(5.2));
        assert_eq!(side(ahead(5.2), &cover), -1.0);
        assert_eq!(side(ahead(4.8), &centres(4.7, Some(4.8))), 1.0);
        // A tie without a volume: the box centre's side if it has one, else +.
        assert_eq!(side(ahead(5.05), &centres(5.05, None)), -1.0);
        assert_eq!(side(DVec3::ZERO, &centres(5.0, None)), 1.0);
        assert_eq!(
            open_side(-DVec3::Z, DVec3::ZERO, &centres(5.0, None), 8.0, 50.0),
            -1.0
        );
    }

    /// A grid of `side` x `side` unit squares, two triangles each, at height `height(i, j)`.
    fn grid(side: u32, height: impl Fn(u32, u32) -> f64) -> Mesh {
        let mut vertices = Vec::new();
        for j in 0..=side {
            for i in 0..=side {
                vertices.push(DVec3::new(i as f64, j as f64, height(i, j)));
            }
        }
        let at = |i: u32, j: u32| j * (side + 1) + i;
        let mut triangles = Vec::new();
        for j in 0..side {
            for i in 0..side {
                triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                // Every seventh square folded the other way round: some facets face down.
                match (i + j) % 7 {
                    0 => triangles.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]),
                    _ => triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]),
                }
            }
        }
        Mesh {
            vertices,
            triangles,
        }
    }

    /// `n` needle-like triangles across a 100 mm box, each from one corner to the far corner
    /// of its floor and up to a point of the box: triangles that overlap along every line.
    fn needles(n: u32) -> Mesh {
        let mut vertices = vec![DVec3::ZERO, DVec3::new(100.0, 100.0, 0.0)];
        let mut triangles = Vec::new();
        for k in 0..n {
            let x = (k as f64 * 0.618_034).fract() * 100.0;
            let z = (k as f64 * 0.414_214).fract() * 100.0;
            vertices.push(DVec3::new(x, x + 1e-3, z));
            triangles.push([0, 1, k + 2]);
        }
        Mesh {
            vertices,
            triangles,
        }
    }

    #[test]
    fn the_choice_stops_at_its_budget_of_tests_whatever_the_threads() {
        let mesh = needles(1500);
        let choose_within = |budget: &projection::TestBudget| {
            choose(&mesh, None, Sampling::Centroid, |_| (), |_, _| true, budget)
                .map(|(auto, _)| auto.candidate().direction)
        };
        let free = projection::TestBudget::unlimited();
        let answer = choose_within(&free).expect("no budget: a line");
        let used = free.used();
        assert!(used > 1_000_000, "{used}");
        for threads in [1, 3] {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    // The tests of the whole choice are the same on any number of threads:
                    // a budget of exactly them holds, one test fewer is passed.
                    let exact = projection::TestBudget::new(used as f64);
                    assert_eq!(choose_within(&exact), Ok(answer), "{threads} threads");
                    assert_eq!(exact.used(), used, "{threads} threads");
                    let short = projection::TestBudget::new(used as f64 - 1.0);
                    assert_eq!(
                        choose_within(&short),
                        Err(DemoldError::TooManyTests {
                            budget: used as f64 - 1.0
                        }),
                        "{threads} threads"
                    );
                });
        }
        // A tenth of the tests: the drawings stop soon after the budget is passed.
        let tenth = projection::TestBudget::new(used as f64 / 10.0);
        assert!(choose_within(&tenth).is_err());
        assert!(tenth.used() < used / 5, "{} of {used}", tenth.used());
        // A designed part is far within the budget of the command line.
        let cap = crate::mesh::from_generated(crate::samples::sample("cap").unwrap());
        let budget = projection::TestBudget::new(AUTO_RAY_TEST_BUDGET);
        assert!(choose(
            &cap.mesh,
            None,
            Sampling::Centroid,
            |_| (),
            |_, _| true,
            &budget
        )
        .is_ok());
        assert!(
            (budget.used() as f64) < 1e-3 * AUTO_RAY_TEST_BUDGET,
            "{}",
            budget.used()
        );
    }

    /// The earlier code's rays of `count` facets along `line` (the k-th being facet
    /// `facet(k)`): every facet's normal and sample points made first and kept, the rays of
    /// those facing a side in one array, with the offsets of each facet's run.
    fn kept_rays(
        mesh: &Mesh,
        sampling: Sampling,
        count: usize,
        facet_of: impl Fn(usize) -> usize,
        line: DVec3,
    ) -> (Vec<PointRay>, Vec<usize>) {
        let (mut rays, mut first) = (Vec::new(), vec![0]);
        for k in 0..count {
            let t = facet_of(k);
            if let Facing::Side { up, .. } = facing(mesh, t, line) {
                sampling.for_each(mesh.corners(t), |p| {
                    rays.push(PointRay {
                        origin: p,
                        triangle: k as u32,
                        up,
                    })
                });
            }
            first.push(rays.len());
        }
        (rays, first)
    }

    #[test]
    fn sparse_sums_of_rays_made_on_the_fly_are_the_earlier_sums_to_the_bit() {
        // The undercut and both bounds against the earlier code: the rays kept in an array
        // (`projection::blocked`), every facet summed, zeros and all (`sum_blocks` for the
        // undercut, in index order for a bound). More facets than a sum block, several
        // samples on the larger ones, facets facing either side, parallel ones (the flat
        // squares of a stepped grid along z), and a small bound level.
        let mesh = grid(70, |i, j| {
            if (i / 5 + j / 7) % 3 == 0 {
                1.0
            } else {
                0.5 * (i as f64 * 0.7).sin() * (j as f64 * 0.3).cos()
            }
        });
        let n = mesh.triangles.len();
        assert!(n > 4 * SUM_BLOCK && n / BOUND_LEVELS[0] < LARGEST_AT_LEAST);
        let mut partial = 0;
        for sampling in [Sampling::Centroid, Sampling::Spacing(0.6)] {
            let free = projection::TestBudget::unlimited();
            let surface = Surface::new(&mesh, sampling, &free);
            for d in [
                DVec3::Z,
                DVec3::new(0.8, -0.2, 0.5),
                DVec3::new(1.0, 0.0, 1e-4),
                DVec3::X,
            ] {
                let d = Direction::new(d).unwrap();
                let line = d.vector();
                let (rays, first) = kept_rays(&mesh, sampling, n, |t| t, line);
                let hit = projection::blocked(
                    &mesh.vertices,
                    &Frame::new(d),
                    &mesh.triangles,
                    &rays,
                    surface.min_hit,
                );
                let earlier = sum_blocks(n, |t| {
                    let (from, to) = (first[t], first[t + 1]);
                    let hits = hit[from..to].iter().filter(|&&b| b).count();
                    facing(&mesh, t, line).blocked(hits, to - from)
                });
                let now = surface.undercut(d);
                partial += usize::from(earlier.share > 0.0 && earlier.share < 1.0);
                assert_eq!(now.area_mm2.to_bits(), earlier.area_mm2.to_bits(), "{d:?}");
                assert_eq!(now.share.to_bits(), earlier.share.to_bits(), "{d:?}");
                for (level, largest) in surface.largest.iter().enumerate() {
                    let count = largest.facets.len();
                    let facet_of = |k: usize| largest.facets[k] as usize;
                    let (rays, first) = kept_rays(&mesh, sampling, count, facet_of, line);
                    let hit = projection::blocked(
                        &mesh.vertices,
                        &Frame::new(d),
                        &largest.triangles,
                        &rays,
                        surface.min_hit,
                    );
                    let mut area = 0.0;
                    for k in 0..count {
                        let (from, to) = (first[k], first[k + 1]);
                        let hits = hit[from..to].iter().filter(|&&b| b).count();
                        area += facing(&mesh, facet_of(k), line).blocked(hits, to - from).1;
                    }
                    let bound = surface.lower_bound(d, level, f64::INFINITY);
                    assert_eq!(bound.area_mm2.to_bits(), area.to_bits(), "{d:?} {level}");
                    assert!(bound.area_mm2 <= now.area_mm2);
                }
            }
        }
        assert!(
            partial >= 4,
            "{partial} lines with some but not all blocked"
        );
    }

    #[test]
    fn facets_of_equal_area_enter_the_bound_in_index_order() {
        // Every facet has area 1/2: the threshold is that area, and the bound takes the
        // first LARGEST_AT_LEAST of them (more than one in 16 or one in 8 here).
        let mesh = grid(50, |_, _| 0.0);
        let n = mesh.triangles.len();
        assert!(n / BOUND_LEVELS[1] < LARGEST_AT_LEAST && LARGEST_AT_LEAST < n);
        let free = projection::TestBudget::unlimited();
        let surface = Surface::new(&mesh, Sampling::Centroid, &free);
        for largest in &surface.largest {
            assert!(!largest.every);
            assert_eq!(
                largest.facets,
                (0..LARGEST_AT_LEAST as u32).collect::<Vec<_>>()
            );
            assert_eq!(largest.triangles, mesh.triangles[..LARGEST_AT_LEAST]);
        }
        // One facet made larger comes first in index order among the rest.
        let mut mesh = mesh;
        let last = mesh.vertices.len() - 1;
        mesh.vertices[last].x += 0.5;
        let free = projection::TestBudget::unlimited();
        let surface = Surface::new(&mesh, Sampling::Centroid, &free);
        let bigger: Vec<u32> = (0..n as u32)
            .filter(|&t| facet(mesh.corners(t as usize)).is_some_and(|(a, _)| a > 0.5))
            .collect();
        assert!(!bigger.is_empty());
        let mut expected: Vec<u32> = (0..n as u32)
            .filter(|&t| facet(mesh.corners(t as usize)).is_some_and(|(a, _)| a >= 0.5))
            .collect();
        let mut equal = LARGEST_AT_LEAST - bigger.len();
        expected.retain(|&t| {
            bigger.contains(&t) || {
                let take = equal > 0;
                equal = equal.saturating_sub(1);
                take
            }
        });
        assert_eq!(surface.largest[0].facets, expected);
        assert!(surface.largest[0].facets.contains(&bigger[0]));
    }

    #[test]
    fn the_largest_facets_of_each_level_are_those_of_a_full_sort() {
        // Areas of many values, some repeated, and more facets than 16 times the least
        // count: each level takes its own share, the selections one after the other.
        let mesh = grid(190, |i, j| {
            ((i * 7 + j * 13) % 11) as f64 * 0.05 * (i % 3) as f64
        });
        let n = mesh.triangles.len();
        assert!(n / BOUND_LEVELS[0] > LARGEST_AT_LEAST);
        let free = projection::TestBudget::unlimited();
        let surface = Surface::new(&mesh, Sampling::Centroid, &free);
        let areas: Vec<f64> = (0..n)
            .map(|t| facet(mesh.corners(t)).map_or(0.0, |(a, _)| a))
            .collect();
        let mut sorted = areas.clone();
        sorted.sort_by(|a, b| b.total_cmp(a));
        for (largest, share) in surface.largest.iter().zip(BOUND_LEVELS) {
            let k = n / share;
            let threshold = sorted[k - 1];
            let mut equal = k - sorted.iter().filter(|&&a| a > threshold).count();
            let expected: Vec<u32> = (0..n as u32)
                .filter(|&t| {
                    let a = areas[t as usize];
                    a > threshold
                        || (a == threshold && equal > 0 && {
                            equal -= 1;
                            true
                        })
                })
                .collect();
            assert_eq!(expected.len(), k);
            assert_eq!(largest.facets, expected, "one in {share}");
        }
    }

    #[test]
    fn faces_side_is_the_normals_answer_also_at_the_tolerance() {
        // Triangles of many shapes and sizes, each against lines whose angle to its plane
        // has a sine of the tolerance plus or minus 0 to 1e-9 (both sides of the margin, and
        // inside it), and against random lines; also facets without area.
        let mut state = 0x853C_49E6_748F_EA9Bu64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut near = 0;
        for k in 0..2000 {
            let scale = 10f64.powi(k % 7 - 3);
            let a = DVec3::new(next(), next(), next()) * scale * 100.0;
            let b = a + DVec3::new(next(), next(), next()) * scale;
            let c = a + DVec3::new(next(), next(), next()) * scale;
            let corners = [a, b, c];
            let Some((_, normal)) = facet(corners) else {
                continue;
            };
            let across = normal.any_orthonormal_vector();
            let mut lines = vec![DVec3::new(next(), next(), next()).normalize()];
            for offset in [0.0, 1e-16, 1e-15, 1e-14, 1e-13, 1e-12, 1e-11, 1e-10, 1e-9] {
                for sign in [1.0, -1.0] {
                    let sine = PARALLEL_TOLERANCE + sign * offset;
                    let cosine = (1.0 - sine * sine).sqrt();
                    lines.push(across * cosine + normal * sine);
                    lines.push(across * cosine - normal * sine);
                }
            }
            for line in lines {
                let expected = match facing_of(facet(corners), line) {
                    Facing::Side { up, .. } => Some(up),
                    _ => None,
                };
                assert_eq!(faces_side(corners, line), expected, "{corners:?} {line}");
                let along = normal.dot(line).abs();
                near += usize::from((along - PARALLEL_TOLERANCE).abs() < 1e-12);
            }
        }
        assert!(near > 1000, "{near} lines near the tolerance");
        let flat = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert_eq!(faces_side(flat, DVec3::Z), None);
    }

    #[test]
    fn the_choice_settled_beside_other_work_is_the_one_settled_at_once() {
        // `choose` stops before the first line drawn ray by ray, draws it beside the
        // caller's work and settles the rest there: the same steps as settling at once. A
        // tilted, wavy grid of more facets than the least bound level, so that lines are
        // bounded, one is drawn ray by ray and principal axes are bounded after it.
        let mesh = grid(70, |i, j| {
            0.5 * (i as f64 * 0.7).sin() * (j as f64 * 0.3).cos() + 0.05 * i as f64
        });
        let free = projection::TestBudget::unlimited();
        let surface = Surface::new(&mesh, Sampling::Centroid, &free);
        assert!(!surface.largest[0].every);
        let centres = Centres::of(&mesh);
        let tried = candidates(&mesh, &surface, &centres, principal_axes(&mesh));
        assert!(tried.iter().any(|c| c.kind == CandidateKind::Principal));
        let tie = TIE_SHARE * centres.area_mm2;
        let mut at_once = Settling::new(&surface, tried.clone(), tie);
        assert_eq!(at_once.settle(Stop::Never), None);
        let mut in_two = Settling::new(&surface, tried, tie);
        let i = in_two
            .settle(Stop::BeforeEveryRay)
            .expect("a line to draw ray by ray");
        assert!(in_two.tried.iter().all(|c| !c.evaluated));
        assert!(in_two.pending.contains(&true));
        let d = Direction::new(DVec3::from_array(in_two.tried[i].direction)).unwrap();
        in_two.tried[i].undercut = surface.undercut(d);
        in_two.tried[i].evaluated = true;
        assert_eq!(in_two.settle(Stop::Never), None);
        assert!(!in_two.pending.contains(&true));
        assert_eq!(in_two.level, at_once.level);
        for (a, b) in in_two.tried.iter().zip(&at_once.tried) {
            assert_eq!(a.undercut.area_mm2.to_bits(), b.undercut.area_mm2.to_bits());
            assert_eq!(a.undercut.share.to_bits(), b.undercut.share.to_bits());
            assert_eq!(a.evaluated, b.evaluated);
        }
        assert!(at_once.tried[i].evaluated);
    }

    #[test]
    fn jacobi_diagonalises_a_known_matrix() {
        // Eigenvalues 1, 2, 4 along rotated axes.
        let r = [[0.6, -0.8, 0.0], [0.8, 0.6, 0.0], [0.0, 0.0, 1.0]];
        let d = [1.0, 2.0, 4.0];
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = (0..3).map(|k| r[i][k] * d[k] * r[j][k]).sum();
            }
        }
        let (values, vectors) = jacobi_eigen(m);
        for k in 0..3 {
            let v = [vectors[0][k], vectors[1][k], vectors[2][k]];
            for i in 0..3 {
                let mv: f64 = (0..3).map(|j| m[i][j] * v[j]).sum();
                assert!((mv - values[k] * v[i]).abs() < 1e-12);
            }
        }
        let mut sorted = values;
        sorted.sort_by(f64::total_cmp);
        for (s, d) in sorted.iter().zip(d) {
            assert!((s - d).abs() < 1e-12);
        }
    }
}
