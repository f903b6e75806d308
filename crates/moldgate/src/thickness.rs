//! Wall thickness of the part everywhere: one value per triangle, by rays along the inverted
//! normal, with a cross-width check for rays that run along a wall instead of across it.
//!
//! The paper's rule "R below the wall thickness" (measured along D at the gate node, in
//! [`crate::gate`]) and the designers' rule "gate into the thickest section" both read it.
//!
//! # The rule, per facet
//!
//! 1. A facet without area (area below 1e-12 of the squared box diagonal, or a normal that is
//!    not finite) is **unknown** (NaN) and weighs nothing in the statistics.
//! 2. From each sample point p of the facet (its centroid by default, see [`Sampling`]) a ray
//!    goes along the inverted normal -n, skipping the facet itself and every hit nearer than
//!    `1e-6` of the box diagonal (so a sliver's neighbours, met at distance ~0 by round-off,
//!    never give a zero thickness). The **opposite wall** is the first triangle hit, and it
//!    counts only if the ray leaves the solid there: its normal points along the ray
//!    (n_hit · -n > 0). The thickness is the distance to it. A ray through an edge meets two
//!    triangles at the same distance (within 1e-6 of the diagonal): it leaves if either does.
//! 3. If that ray hits nothing, or first meets a triangle facing it (it was outside the solid:
//!    the facet's normal is inverted), the same test is made along +n; a wall found that way
//!    means the facet is flipped and its thickness is measured the other way. (The facets
//!    across from a flipped facet see a wall facing them and are unknown, unless their own
//!    +n ray finds a consistent wall.)
//! 4. Otherwise the sample is **unknown**: on an open mesh a ray that leaves through the hole
//!    gives NaN, never infinity or the distance to some far surface.
//! 5. **Cross-width check.** On the narrow edge face of a plate the ray runs along the plate
//!    and measures its length, not its wall. So for a chord of length t, the surface point q
//!    nearest the chord's midpoint m is found; if it is nearer than t/2 (by more than 0.1 %),
//!    the chord may run along a wall, and the solid is measured across it at the midpoint and
//!    at the quarter points (a midpoint at a T-junction of two walls is wide every way). At
//!    each point m, the width is measured along the direction e from m to its nearest surface q
//!    (made perpendicular to the chord) and along the direction perpendicular to both: two
//!    rays each, ±e, to the walls where they leave the solid. If the smaller of those two
//!    widths is smaller than t, it is the thickness; if any cross ray leaves
//!    through a hole, the sample is unknown. Only a width below the smallest found so far
//!    (at first t) can change the answer, so each cross ray looks no farther than that width
//!    less what its partner already measured, and a point whose nearest surface is farther
//!    than half that width is not measured (every cross ray from it is longer). A cross ray
//!    that meets nothing at all still makes the sample unknown; one whose first hit past that
//!    length faces it (a ray that was outside the solid) no longer does, nor does the partner
//!    of a ray that found no wall within the length (it is not cast). Near a convex edge the
//!    nearest point is the edge face, but across the chord the solid is wide, so the facet
//!    keeps its thickness across the wall (a ball-based thickness would drop to ~0 there); when q is within the 1e-6
//!    diagonal of m (the chord runs in a face, as from a sliver along an edge), the chord is
//!    kept as it is.
//! 6. The facet's value is the mean of its known samples (NaN if none is known).
//! 7. **Large facets.** With the centroid sampling (the default), a facet whose area is at
//!    least [`LARGE_FACET_WALLS2`] times the square of its centroid's wall spans several
//!    walls' width, and one point may not stand for it: on a coarse mesh a facet of 612 mm^2
//!    on a 4 mm wall had its centroid over an inside boss, and the wall map showed 8.6 mm
//!    wedges across the wall. Such a facet is sampled again at the centroids of its regular
//!    k x k subdivision, k about its side over that wall (at most 8), and its value is the
//!    median of the known samples (the wall most of the facet has).
//!
//! The statistics ([`WallThickness`]) are over facets with a known value: minimum, maximum,
//! and the **nominal** thickness, the area-weighted median (half of the known area is
//! thinner). The unknown share is the area of unknown facets over the whole area.
//!
//! **Slivers.** A facet thinner than [`SLIVER_OF_NOMINAL`] of the nominal wall is a sliver:
//! a real but unmouldable film of solid in the mesh (on the shared parts: a step of 0.01 mm
//! between two faces of a lid, a 0.0001 mm film on a housing, facets 0.001 mm across), not a
//! wall. Slivers are counted apart ([`WallThickness::slivers`]) and left out of the minimum;
//! their own smallest value is [`WallThickness::sliver_min_mm`].

use std::cmp::Ordering;
use std::sync::OnceLock;

use rayon::prelude::*;

use crate::cancel::Cancel;
use crate::math::DVec3;
use crate::mesh::Mesh;
pub use crate::raycast::Sampling;
use crate::raycast::{Bvh, Ray, Region};

/// Options of [`wall_thickness`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThicknessOptions {
    /// Which points of each facet cast rays (default: the centroid only).
    pub sampling: Sampling,
    /// Whether rays that run along a wall are replaced by the width across it (rule 5 of the
    /// module; default on).
    pub cross_check: CrossCheck,
}

impl Default for ThicknessOptions {
    fn default() -> Self {
        ThicknessOptions {
            sampling: Sampling::Centroid,
            cross_check: CrossCheck::On,
        }
    }
}

/// Rule 5 of the module: the cross-width check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CrossCheck {
    /// Check every chord (the default).
    #[default]
    On,
    /// The raw ray length along the inverted normal.
    Off,
}

/// The wall thickness of every triangle, and its statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct WallThickness {
    /// Thickness of each triangle in mm, in the mesh's order; NaN where unknown (a ray that
    /// leaves an open mesh, a facet without area).
    pub per_triangle: Vec<f32>,
    /// Smallest known thickness that is not a sliver, mm (`None` when no facet is known).
    pub min_mm: Option<f64>,
    /// Facets thinner than [`SLIVER_OF_NOMINAL`] of the nominal wall, left out of `min_mm`.
    pub slivers: usize,
    /// Smallest sliver thickness, mm (`None` without slivers).
    pub sliver_min_mm: Option<f64>,
    /// Area-weighted median of the known thicknesses, mm.
    pub nominal_mm: Option<f64>,
    /// Largest known thickness, mm.
    pub max_mm: Option<f64>,
    /// Area of the unknown facets over the whole area (0 to 1).
    pub unknown_area_share: f64,
}

impl WallThickness {
    /// Thickness of triangle `t` in mm, or `None` when unknown or out of range.
    pub fn at_triangle(&self, t: usize) -> Option<f64> {
        self.per_triangle
            .get(t)
            .map(|&v| v as f64)
            .filter(|v| v.is_finite())
    }

    /// Thickness at each vertex, for colouring: the area-weighted mean of the known values of
    /// the triangles around it; NaN where none is known.
    pub fn per_vertex(&self, mesh: &Mesh) -> Vec<f32> {
        let mut sum = vec![0f64; mesh.vertices.len()];
        let mut weight = vec![0f64; mesh.vertices.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let Some(v) = self.at_triangle(t) else {
                continue;
            };
            let area = area(mesh.corners(t));
            for &i in tri {
                sum[i as usize] += v * area;
                weight[i as usize] += area;
            }
        }
        sum.iter()
            .zip(&weight)
            .map(|(s, w)| if *w > 0.0 { (s / w) as f32 } else { f32::NAN })
            .collect()
    }
}

fn area([a, b, c]: [DVec3; 3]) -> f64 {
    0.5 * (b - a).cross(c - a).length()
}

/// A tree's area cost above which its boxes overlap as no moulded part's do: the shared
/// parts' trees cost 15 to 39; a soup of random triangles across a box costs about 0.6 a
/// triangle (6,053 for 10,000).
pub const TANGLED_AREA_COST: f64 = 400.0;

/// The most work the walls may take on a tangled tree ([`TANGLED_AREA_COST`]), in box and
/// triangle visits estimated as the area cost times the facets measured: about 37 ns each
/// on two threads of the development machine, so about 7 s (the 352k housing's walls are
/// 1.4e7, in 0.54 s). 40,000 random triangles (9.7e8, 36 s) are refused; 10,000 (6.1e7,
/// 2 s) are measured. A tree of a moulded part's cost is never refused: its work grows
/// with its facets alone, bounded by the mesh's size.
pub const WALL_WORK_BUDGET: f64 = 2e8;

/// Refuses the walls of `facets` facets on `bvh` when its boxes overlap as no moulded
/// part's do and the work would pass [`WALL_WORK_BUDGET`]: before any wall is measured.
pub fn check_work(bvh: &Bvh, facets: usize) -> Result<(), crate::OptionsError> {
    let cost = bvh.area_cost();
    let work = cost * facets as f64;
    if cost > TANGLED_AREA_COST && work > WALL_WORK_BUDGET {
        return Err(crate::OptionsError::TangledSurface {
            cost,
            facets: facets as u64,
            work,
            budget: WALL_WORK_BUDGET,
        });
    }
    Ok(())
}

/// The wall thickness of every triangle of `mesh` (see the module for the rule). Builds its
/// own ray-casting tree; use [`wall_thickness_with`] to share one.
pub fn wall_thickness(mesh: &Mesh, options: &ThicknessOptions) -> WallThickness {
    wall_thickness_with(mesh, &Bvh::new(mesh), options)
}

/// [`wall_thickness`] with a tree already built over `mesh`.
pub fn wall_thickness_with(mesh: &Mesh, bvh: &Bvh, options: &ThicknessOptions) -> WallThickness {
    every_triangle(mesh, bvh, options, None, Known::default())
}

/// [`wall_thickness_with`] with what the caller knows of the mesh (see [`Known`]), stopping
/// once `cancel`, when given, is set (each facet reads it before its rays): `None` when it
/// was.
pub fn wall_thickness_until(
    mesh: &Mesh,
    bvh: &Bvh,
    options: &ThicknessOptions,
    known: Known,
    cancel: Option<&Cancel>,
) -> Option<WallThickness> {
    let w = every_triangle(mesh, bvh, options, cancel, known);
    (!crate::cancel::is_set(cancel)).then_some(w)
}

fn every_triangle(
    mesh: &Mesh,
    bvh: &Bvh,
    options: &ThicknessOptions,
    cancel: Option<&Cancel>,
    known: Known,
) -> WallThickness {
    // Every triangle: the tree's leaf order is already the order to cast in.
    let per_triangle = if bvh.len() == mesh.triangles.len() {
        thickness_in_order(mesh, bvh, options, bvh.leaf_order(), cancel, known)
    } else {
        let all: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
        thickness_in_order(mesh, bvh, options, &all, cancel, known)
    };
    summarise(mesh, per_triangle)
}

/// The thickness of the listed triangles only (NaN for the others), in the mesh's order:
/// for analyses that sample the surface, such as one triangle per flow cell. A triangle
/// listed more than once is measured once.
pub fn wall_thickness_of(
    mesh: &Mesh,
    bvh: &Bvh,
    options: &ThicknessOptions,
    triangles: &[u32],
) -> Vec<f32> {
    wall_thickness_of_known(mesh, bvh, options, triangles, Known::default(), None)
}

/// What a caller that loaded the mesh knows of it, which the rays would otherwise find out
/// for themselves: the same walls, less work.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Known {
    /// Whether every edge of the mesh is met by its reverse (a closed, consistently
    /// oriented surface; see `is_closed`), when known. `None`: a pass over the triangles
    /// finds it the first time a cross ray ends without a wall.
    pub closed: Option<bool>,
}

impl Known {
    /// What the load's topology tells: a mesh whose every edge has as many sides running
    /// each way is closed (the converse needs the pass: a facet without area leaves an
    /// edge unpaired in the topology's count but not in the pass).
    pub fn of(topology: &crate::mesh::Topology) -> Known {
        Known {
            closed: topology.sides_pair_up().then_some(true),
        }
    }
}

/// [`wall_thickness_of`] with what the caller knows of the mesh (see [`Known`]); once
/// `cancel` is set, the facets not yet cast are NaN.
pub fn wall_thickness_of_known(
    mesh: &Mesh,
    bvh: &Bvh,
    options: &ThicknessOptions,
    triangles: &[u32],
    known: Known,
    cancel: Option<&Cancel>,
) -> Vec<f32> {
    // Each listed triangle once, however often it is listed (a facet may own several
    // cells), out-of-range indices ignored.
    let mut wanted = vec![false; mesh.triangles.len()];
    for &t in triangles {
        if let Some(w) = wanted.get_mut(t as usize) {
            *w = true;
        }
    }
    // Cast in the tree's leaf order: neighbouring facets send their rays through the same
    // boxes, which stay in the cache.
    let order: Vec<u32> = if bvh.len() == mesh.triangles.len() {
        bvh.leaf_order()
            .iter()
            .copied()
            .filter(|&t| wanted[t as usize])
            .collect()
    } else {
        (0..mesh.triangles.len() as u32)
            .filter(|&t| wanted[t as usize])
            .collect()
    };
    thickness_in_order(mesh, bvh, options, &order, cancel, known)
}

/// The thickness of the listed triangles (NaN for the others), in the mesh's order, cast in
/// the order listed; once `cancel` is set, the facets not yet cast are NaN.
fn thickness_in_order(
    mesh: &Mesh,
    bvh: &Bvh,
    options: &ThicknessOptions,
    triangles: &[u32],
    cancel: Option<&Cancel>,
    known: Known,
) -> Vec<f32> {
    let diagonal = mesh.bounds().diagonal();
    let diagonal = if diagonal.is_finite() { diagonal } else { 0.0 };
    let probe = Probe {
        bvh,
        mesh,
        min_hit: 1e-6 * diagonal,
        options: *options,
        closed: match known.closed {
            Some(closed) => OnceLock::from(closed),
            None => OnceLock::new(),
        },
        band_slack: 1e-4 * diagonal,
    };
    let min_area = 1e-12 * diagonal * diagonal;
    let values: Vec<f32> = triangles
        .par_iter()
        .with_min_len(256)
        .map(|&t| {
            if crate::cancel::is_set(cancel) {
                return f32::NAN;
            }
            let t = t as usize;
            let corners = mesh.corners(t);
            let [a, b, c] = corners;
            let cross = (b - a).cross(c - a);
            let area = 0.5 * cross.length();
            if area.partial_cmp(&min_area) != Some(Ordering::Greater) || !cross.is_finite() {
                return f32::NAN;
            }
            let n = cross / (2.0 * area);
            let (mut sum, mut known) = (0.0, 0u32);
            options.sampling.for_each(corners, |p| {
                if let Some(v) = probe.sample(t as u32, p, n) {
                    sum += v;
                    known += 1;
                }
            });
            if known == 0 {
                return f32::NAN;
            }
            let mean = sum / known as f64;
            // Rule 7: a facet many walls wide sampled again, its median taken.
            if options.sampling == Sampling::Centroid {
                if let Some(k) = large_facet_subdivision(area, mean) {
                    let mut values = Vec::with_capacity(k * k);
                    Sampling::for_each_k(corners, k, |p| {
                        values.extend(probe.sample(t as u32, p, n));
                    });
                    if !values.is_empty() {
                        values.sort_by(f64::total_cmp);
                        return values[(values.len() - 1) / 2] as f32;
                    }
                }
            }
            mean as f32
        })
        .collect();
    let mut per_triangle = vec![f32::NAN; mesh.triangles.len()];
    for (&t, v) in triangles.iter().zip(values) {
        if let Some(slot) = per_triangle.get_mut(t as usize) {
            *slot = v;
        }
    }
    per_triangle
}

/// A facet whose area is at least this many times its centroid's wall squared is sampled
/// again (rule 7 of the module).
pub const LARGE_FACET_WALLS2: f64 = 4.0;

/// The subdivision k of a facet of `area` whose centroid reads `wall` when it is large for
/// that wall (rule 7): about one sample per wall along the facet's side, at most
/// [`crate::raycast::MAX_SUBDIVISION`]; `None` for a facet of a few walls' area.
fn large_facet_subdivision(area: f64, wall: f64) -> Option<usize> {
    if !(wall > 0.0 && area >= LARGE_FACET_WALLS2 * wall * wall) {
        return None;
    }
    let k = ((2.0 * area).sqrt() / wall).ceil();
    (k.is_finite() && k >= 2.0).then(|| (k as usize).min(crate::raycast::MAX_SUBDIVISION))
}

/// What one sample needs.
struct Probe<'a> {
    bvh: &'a Bvh,
    mesh: &'a Mesh,
    min_hit: f64,
    options: ThicknessOptions,
    /// Whether every edge of the mesh is met by its reverse (see [`is_closed`]), found the
    /// first time a cross ray ends without a wall.
    closed: OnceLock<bool>,
    /// Margin of the check's ball in `sample`, mm: the rays' edge slack
    /// ([`crate::raycast::EDGE_TOLERANCE`]) on triangles as long as the box's diagonal, and
    /// the f32 rounding of coordinates, both well inside 1e-4 of the diagonal.
    band_slack: f64,
}

impl Probe<'_> {
    /// Thickness at point `p` of triangle `t` with unit outward normal `n` (rules 2 to 5).
    fn sample(&self, t: u32, p: DVec3, n: DVec3) -> Option<f64> {
        let (dir, chord) = [-n, n].into_iter().find_map(|dir| {
            match self.exit(p, dir, Some(t), f64::INFINITY, &Region::WHOLE) {
                Exit::At(len) => Some((dir, len)),
                Exit::Beyond | Exit::Hole => None,
            }
        })?;
        if self.options.cross_check == CrossCheck::Off {
            return Some(chord);
        }
        // Every query of the check stays in one ball around the chord's midpoint: the
        // nearest-point balls (at most half the chord around the midpoint, a quarter around
        // the quarter points) and the cross rays (from the middle half of the chord, across
        // it, no longer than the chord). The subtrees that hold every triangle meeting that
        // ball are found once, and each query starts from them instead of the root: the same
        // triangles, so the same walls. The margin covers the f32 tests and the rays' edge
        // slack (see `band_slack`).
        let radius = chord * (1.0f64 + 0.25 * 0.25).sqrt() + 1e-3 * chord + self.band_slack;
        let region = self.bvh.region(p + dir * (0.5 * chord), radius);
        let mut width = chord;
        for (k, at) in [0.5, 0.25, 0.75].into_iter().enumerate() {
            let m = p + dir * (at * chord);
            // The largest ball around m inside the chord's ends; the nearest surface inside it
            // (by more than 0.1 %) says the chord may run along a wall. Only the midpoint
            // decides whether to look at all. A surface farther from m than half the width
            // found so far cannot narrow it (every cross ray from m runs at least that far
            // before it meets a surface), so the ball shrinks to that too.
            let reach = (chord * at.min(1.0 - at)).min(0.5 * width) * (1.0 - 1e-3);
            let Some(near) = self.bvh.nearest_within_in(m, reach, &region) else {
                if k == 0 {
                    return Some(chord);
                }
                continue;
            };
            if near.distance <= self.min_hit {
                // The chord runs in a face (a sliver at a convex edge): the ray is across
                // the wall, and the face beside it is not a wall to measure.
                if k == 0 {
                    return Some(chord);
                }
                continue;
            }
            width = width.min(self.cross_width(m, dir, near.triangle, width, &region)?);
        }
        Some(width)
    }

    /// The smallest width of the solid through `m` across the chord direction `dir`: along the
    /// direction to the nearest point of `triangle` (made perpendicular to the chord) and along
    /// the direction perpendicular to both (a chord beside a hole has its nearest surface in
    /// the hole but its wall the other way). Only widths below `limit` matter, so each pair of
    /// cross rays stops at `limit` (infinity when none is below it); `None` when a cross ray
    /// leaves through a hole within that length.
    fn cross_width(
        &self,
        m: DVec3,
        dir: DVec3,
        triangle: u32,
        limit: f64,
        region: &Region,
    ) -> Option<f64> {
        // The tree gives the nearest triangle, not its nearest point: found again in f64.
        let q = nearest_on_triangle(self.mesh.corners(triangle as usize), m);
        let e = q - m;
        let e = (e - dir * e.dot(dir)).normalize_or_zero();
        if e == DVec3::ZERO {
            return Some(f64::INFINITY);
        }
        let mut width = f64::INFINITY;
        for e in [e, dir.cross(e)] {
            let bound = width.min(limit);
            let there = match self.exit(m, e, None, bound, region) {
                Exit::At(d) => d,
                Exit::Beyond => continue,
                Exit::Hole => return None,
            };
            match self.exit(m, -e, None, bound - there, region) {
                Exit::At(d) => width = width.min(there + d),
                Exit::Beyond => {}
                Exit::Hole => return None,
            }
        }
        Some(width)
    }

    /// Where the ray from `p` along `dir` leaves the solid, looking no farther than
    /// `max_distance`: at the first hit, if its triangle faces along the ray. The first hit
    /// is looked for in `region`, which must hold the ray up to `max_distance`.
    fn exit(
        &self,
        p: DVec3,
        dir: DVec3,
        skip: Option<u32>,
        max_distance: f64,
        region: &Region,
    ) -> Exit {
        let mut ray = Ray::new(p, dir).within(self.min_hit, max_distance);
        ray.skip = skip;
        let Some(hit) = self.bvh.first_hit_in(&ray, region) else {
            // Nothing within the length looked at. A ray from inside a closed surface meets
            // it somewhere farther; on an open mesh, a ray that meets nothing farther either
            // leaves through a hole (any hit at all will do to tell, the cheapest query).
            let farther = max_distance < f64::INFINITY
                && (*self.closed.get_or_init(|| is_closed(self.mesh))
                    || self.bvh.any_hit(&ray.within(max_distance, f64::INFINITY)));
            return if farther { Exit::Beyond } else { Exit::Hole };
        };
        // Only the sign matters: the unnormalised normal saves a square root per hit.
        let leaves = |t: u32| {
            let [a, b, c] = self.mesh.corners(t as usize);
            let n = (b - a).cross(c - a);
            n.is_finite() && n.dot(dir) > 0.0
        };
        if leaves(hit.triangle) {
            return Exit::At(hit.distance);
        }
        // A ray through an edge meets both triangles at one distance, in no fixed order: it
        // leaves the solid if any of the triangles there faces along it.
        let tie = self.min_hit.max(1e-6 * hit.distance);
        let mut found = false;
        let at = ray.within(hit.distance - tie, hit.distance + tie);
        self.bvh.for_each_hit(&at, |h| {
            found = leaves(h.triangle);
            !found
        });
        if found {
            Exit::At(hit.distance)
        } else {
            Exit::Hole
        }
    }
}

/// Whether every directed edge a -> b of the mesh's triangles is matched by an edge b -> a
/// (a closed, consistently oriented surface, whose inside every ray leaves). A pass without
/// sorting or hashing of edges: at each vertex, the sums of a hash of the vertices its edges
/// go to and come from agree for every vertex exactly when the edges pair up (but for a
/// 2^-64 chance per vertex of a false agreement).
fn is_closed(mesh: &Mesh) -> bool {
    // splitmix64's finaliser: unrelated 64-bit values for neighbouring indices.
    let hash = |v: u32| {
        let mut z = (v as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    // Per vertex, the sum over the edges going out of it less the sum over those coming
    // in (wrapping): zero exactly when the two sums agree. One array, not two: a fresh
    // page of memory is dear (the kernel zeroes it).
    let mut differ = vec![0u64; mesh.vertices.len()];
    for tri in &mesh.triangles {
        for (a, b) in [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])] {
            if a as usize >= differ.len() || b as usize >= differ.len() {
                return false;
            }
            differ[a as usize] = differ[a as usize].wrapping_add(hash(b));
            differ[b as usize] = differ[b as usize].wrapping_sub(hash(a));
        }
    }
    differ.iter().all(|&d| d == 0)
}

/// Where a ray leaves the solid.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Exit {
    /// At this distance, mm.
    At(f64),
    /// Not within the length looked at: no surface there.
    Beyond,
    /// Its first hit faces it (it was outside the solid), or it hits nothing at all: it
    /// leaves through a hole of an open mesh.
    Hole,
}

/// The point of triangle `[a, b, c]` nearest to `p`, by projection onto its plane and, when
/// that falls outside, onto its nearest edge.
pub(crate) fn nearest_on_triangle([a, b, c]: [DVec3; 3], p: DVec3) -> DVec3 {
    let n = (b - a).cross(c - a);
    let len2 = n.length_squared();
    if len2 > 0.0 {
        let q = p - n * ((p - a).dot(n) / len2);
        let inside = [(a, b), (b, c), (c, a)]
            .iter()
            .all(|&(u, v)| (v - u).cross(q - u).dot(n) >= 0.0);
        if inside {
            return q;
        }
    }
    [(a, b), (b, c), (c, a)]
        .into_iter()
        .map(|(u, v)| crate::math::nearest_on_segment(u, v, p))
        .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
        .unwrap_or(a)
}

/// Walls thinner than this share of the nominal wall are slivers (see the module).
pub const SLIVER_OF_NOMINAL: f64 = 0.05;

/// Minimum, area-weighted median, maximum and unknown share of per-triangle values.
fn summarise(mesh: &Mesh, per_triangle: Vec<f32>) -> WallThickness {
    // Each known facet as one key of 8 bytes, its value then its index (see `value_key`):
    // sorted, they are in the order of a stable sort by value, made without one's buffer of
    // half the facets. The areas are found again along that order, a run at a time on all
    // threads, and summed in it, one after the other, as when they were held beside the keys.
    let mut known: Vec<u64> = Vec::with_capacity(per_triangle.len());
    let (mut total, mut unknown) = (0.0, 0.0);
    for (t, &v) in per_triangle.iter().enumerate() {
        let a = area(mesh.corners(t));
        total += a;
        if v.is_finite() {
            known.push(value_key(v, t as u32));
        } else {
            unknown += a;
        }
    }
    known.par_sort_unstable();
    let value = |key: u64| key_value(key) as f64;
    // Each area along the sorted keys, to `add` in that order, until it says to stop.
    let along = |add: &mut dyn FnMut(f64) -> bool| {
        let mut areas = Vec::new();
        for run in known.chunks(AREA_RUN) {
            run.par_iter()
                .map(|&key| area(mesh.corners(key as u32 as usize)))
                .collect_into_vec(&mut areas);
            for &a in &areas {
                if !add(a) {
                    return;
                }
            }
        }
    };
    let mut known_area = 0.0;
    along(&mut |a| {
        known_area += a;
        true
    });
    let mut nominal = None;
    let (mut acc, mut k) = (0.0, 0);
    along(&mut |a| {
        acc += a;
        if acc >= 0.5 * known_area {
            nominal = Some(value(known[k]));
            return false;
        }
        k += 1;
        true
    });
    let sliver = nominal.map_or(0.0, |n| SLIVER_OF_NOMINAL * n);
    let slivers = known.iter().take_while(|&&key| value(key) < sliver).count();
    WallThickness {
        min_mm: known.get(slivers).map(|&key| value(key)),
        slivers,
        sliver_min_mm: (slivers > 0).then(|| value(known[0])),
        nominal_mm: nominal,
        max_mm: known.last().map(|&key| value(key)),
        unknown_area_share: if total > 0.0 { unknown / total } else { 1.0 },
        per_triangle,
    }
}

/// Keys whose areas [`summarise`] finds at once.
const AREA_RUN: usize = 1 << 16;

/// The sort key of facet `t` with the finite value `v`: `v`'s bits, made to compare as
/// unsigned numbers in the order of [`f32::total_cmp`] ([`crate::math::ordered_bits`]),
/// above `t`.
fn value_key(v: f32, t: u32) -> u64 {
    u64::from(crate::math::ordered_bits(v)) << 32 | u64::from(t)
}

/// The value of a [`value_key`].
fn key_value(key: u64) -> f32 {
    crate::math::from_ordered_bits((key >> 32) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_on_triangle_matches_closed_forms() {
        let t = [DVec3::ZERO, DVec3::X * 4.0, DVec3::Y * 4.0];
        let p = DVec3::new(1.0, 1.0, 5.0);
        assert_eq!(nearest_on_triangle(t, p), DVec3::new(1.0, 1.0, 0.0));
        let p = DVec3::new(-2.0, 1.0, 0.0);
        assert_eq!(nearest_on_triangle(t, p), DVec3::new(0.0, 1.0, 0.0));
        let p = DVec3::new(4.0, 4.0, 0.0);
        assert!((nearest_on_triangle(t, p) - DVec3::new(2.0, 2.0, 0.0)).length() < 1e-12);
    }

    /// A 4 mm slab whose top is two facets of 1,800 mm^2, with a boss of 8 x 8 x 6 mm under
    /// the centroid of one: that centroid's chord runs through the boss (8 mm across it),
    /// the rest of the facet stands on 4 mm. Rule 7 samples the facet again and takes the
    /// median: 4 mm (the centroid alone read 8 mm, and the map showed a thick wedge).
    #[test]
    fn a_large_facet_takes_the_wall_most_of_it_has() {
        let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let vertices = vec![
            // Top, bottom, the boss's top ring (on the bottom face) and its bottom.
            v(0.0, 0.0, 4.0),
            v(60.0, 0.0, 4.0),
            v(60.0, 60.0, 4.0),
            v(0.0, 60.0, 4.0),
            v(0.0, 0.0, 0.0),
            v(60.0, 0.0, 0.0),
            v(60.0, 60.0, 0.0),
            v(0.0, 60.0, 0.0),
            v(36.0, 16.0, 0.0),
            v(44.0, 16.0, 0.0),
            v(44.0, 24.0, 0.0),
            v(36.0, 24.0, 0.0),
            v(36.0, 16.0, -6.0),
            v(44.0, 16.0, -6.0),
            v(44.0, 24.0, -6.0),
            v(36.0, 24.0, -6.0),
        ];
        let quad = |a: u32, b: u32, c: u32, d: u32| [[a, b, c], [a, c, d]];
        let mut triangles: Vec<[u32; 3]> = Vec::new();
        // Top (outward +z), sides, the bottom ring round the boss (-z), the boss's sides
        // and bottom.
        triangles.extend(quad(0, 1, 2, 3));
        for (a, b) in [(4, 5), (5, 6), (6, 7), (7, 4)] {
            triangles.extend(quad(a, b, b - 4, a - 4));
        }
        for (a, b) in [(4, 5), (5, 6), (6, 7), (7, 4)] {
            triangles.extend(quad(b, a, a + 4, b + 4));
        }
        for (a, b) in [(8, 9), (9, 10), (10, 11), (11, 8)] {
            triangles.extend(quad(b, a, a + 4, b + 4));
        }
        triangles.extend(quad(15, 14, 13, 12));
        let mesh = Mesh {
            vertices,
            triangles,
        };
        assert!(is_closed(&mesh), "the slab is closed and wound outwards");
        let walls = wall_thickness(&mesh, &ThicknessOptions::default());
        let top = walls.at_triangle(0).unwrap();
        assert!((top - 4.0).abs() < 1e-3, "the large facet reads {top} mm");
        // Its centroid alone reads the boss: the facet sampled once (a sampling given).
        let once = wall_thickness(
            &mesh,
            &ThicknessOptions {
                sampling: Sampling::Spacing(1e9),
                ..ThicknessOptions::default()
            },
        );
        let centroid = once.at_triangle(0).unwrap();
        assert!(
            (centroid - 8.0).abs() < 1e-3,
            "the centroid reads {centroid} mm"
        );
        // The other top facet has no boss under it: 4 mm either way.
        assert!((walls.at_triangle(1).unwrap() - 4.0).abs() < 1e-3);
    }

    #[test]
    fn closed_means_every_edge_meets_its_reverse() {
        // A tetrahedron, closed and consistently oriented.
        let mut mesh = Mesh {
            vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]],
        };
        assert!(is_closed(&mesh));
        mesh.triangles[3].swap(0, 1); // one facet flipped: its edges run the same way
        assert!(!is_closed(&mesh));
        mesh.triangles.pop(); // a hole
        assert!(!is_closed(&mesh));
        mesh.triangles.push([2, 0, 7]); // a vertex that does not exist
        assert!(!is_closed(&mesh));
        for name in ["cover", "cap", "plate", "bracket", "tray"] {
            assert!(is_closed(&crate::samples::sample(name).unwrap()), "{name}");
        }
    }

    #[test]
    fn the_statistics_are_those_of_a_stable_sort_by_value() {
        // The statistics as first written: the known facets' (value, area) in a stable sort
        // by value, the area summed along it.
        fn by_stable_sort(mesh: &Mesh, per_triangle: &[f32]) -> [Option<f64>; 4] {
            let mut known: Vec<(f32, f64)> = per_triangle
                .iter()
                .enumerate()
                .filter(|(_, v)| v.is_finite())
                .map(|(t, &v)| (v, area(mesh.corners(t))))
                .collect();
            known.sort_by(|x, y| x.0.total_cmp(&y.0));
            let half = 0.5 * known.iter().map(|k| k.1).sum::<f64>();
            let mut acc = 0.0;
            let nominal = known.iter().find_map(|&(v, a)| {
                acc += a;
                (acc >= half).then_some(v as f64)
            });
            let sliver = nominal.map_or(0.0, |n| SLIVER_OF_NOMINAL * n);
            let slivers = known.iter().take_while(|k| (k.0 as f64) < sliver).count();
            let min = known.get(slivers).map(|k| k.0 as f64);
            let sliver_min = (slivers > 0).then(|| known[0].0 as f64);
            [min, sliver_min, nominal, known.last().map(|k| k.0 as f64)]
        }
        let mesh = crate::samples::sample("bracket").unwrap();
        // Values of few kinds (many ties, so the order among equal values shows in the sum
        // of areas), slivers among them, and unknown facets.
        for kinds in [1u32, 2, 3, 7, 50] {
            let values: Vec<f32> = (0..mesh.triangles.len() as u32)
                .map(|t| match t.wrapping_mul(2654435761) % (kinds + 1) {
                    0 if kinds > 1 => f32::NAN,
                    1 => 0.001,
                    // Both zeros and a negative value, whose keys must sort as
                    // `total_cmp` does.
                    4 => -0.0,
                    5 => 0.0,
                    6 => -1.5,
                    k => 0.5 * k as f32,
                })
                .collect();
            let w = summarise(&mesh, values.clone());
            let found = [w.min_mm, w.sliver_min_mm, w.nominal_mm, w.max_mm];
            assert_eq!(found, by_stable_sort(&mesh, &values), "{kinds} kinds");
        }
    }

    #[test]
    fn value_keys_sort_as_total_cmp_and_give_their_value_back() {
        let values = [
            f32::MIN,
            -1.5,
            -f32::MIN_POSITIVE,
            -f32::from_bits(1),
            -0.0,
            0.0,
            f32::from_bits(1),
            f32::MIN_POSITIVE,
            0.001,
            1.5,
            f32::MAX,
        ];
        for (i, &x) in values.iter().enumerate() {
            for (j, &y) in values.iter().enumerate() {
                for (s, t) in [(0u32, 0u32), (0, 7), (7, 0), (u32::MAX, 0)] {
                    let by_keys = value_key(x, s).cmp(&value_key(y, t));
                    assert_eq!(by_keys, x.total_cmp(&y).then(s.cmp(&t)), "{i} {j} {s} {t}");
                }
            }
            assert_eq!(key_value(value_key(x, 3)).to_bits(), x.to_bits(), "{x}");
        }
    }

    #[test]
    fn what_the_topology_knows_gives_the_same_walls() {
        let topology_says = |mesh: &Mesh| Known::of(&crate::mesh::Topology::new(mesh)).closed;
        // Said closed only where the pass finds it so, and the same walls either way.
        let mut meshes: Vec<Mesh> = ["cover", "cap", "plate", "bracket", "tray"]
            .into_iter()
            .map(|name| crate::samples::sample(name).unwrap())
            .collect();
        let mut open = meshes[0].clone();
        open.triangles.truncate(open.triangles.len() - 3);
        let mut turned = meshes[1].clone();
        turned.triangles[5].swap(0, 1);
        meshes.extend([open, turned]);
        for (k, mesh) in meshes.iter().enumerate() {
            let said = topology_says(mesh);
            assert!(said.is_none() || said == Some(is_closed(mesh)), "mesh {k}");
            assert_eq!(said.is_some(), k < 5, "mesh {k}");
            let bvh = Bvh::new(mesh);
            let every: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
            let o = ThicknessOptions::default();
            let found = wall_thickness_of(mesh, &bvh, &o, &every);
            let known =
                wall_thickness_of_known(mesh, &bvh, &o, &every, Known { closed: said }, None);
            let bits = |w: &[f32]| w.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&found), bits(&known), "mesh {k}");
            // A set token: no facet cast.
            let token = Cancel::new();
            token.cancel();
            let stopped =
                wall_thickness_of_known(mesh, &bvh, &o, &every, Known::default(), Some(&token));
            assert!(stopped.iter().all(|w| w.is_nan()), "mesh {k}");
        }
    }

    #[test]
    fn median_is_area_weighted() {
        // Two triangles of area 1 (thickness 5) and one of area 4 (thickness 1).
        let mesh = Mesh {
            vertices: vec![
                DVec3::ZERO,
                DVec3::X * 2.0,
                DVec3::Y,
                DVec3::new(10.0, 0.0, 0.0),
                DVec3::new(14.0, 0.0, 0.0),
                DVec3::new(10.0, 2.0, 0.0),
                DVec3::new(20.0, 0.0, 0.0),
                DVec3::new(22.0, 0.0, 0.0),
                DVec3::new(20.0, 1.0, 0.0),
            ],
            triangles: vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]],
        };
        let w = summarise(&mesh, vec![5.0, 1.0, 5.0]);
        assert_eq!(w.nominal_mm, Some(1.0));
        assert_eq!((w.min_mm, w.max_mm), (Some(1.0), Some(5.0)));
        let w = summarise(&mesh, vec![5.0, f32::NAN, 5.0]);
        assert_eq!(w.nominal_mm, Some(5.0));
        assert!((w.unknown_area_share - 4.0 / 6.0).abs() < 1e-12);
        let w = summarise(&mesh, vec![f32::NAN; 3]);
        assert_eq!((w.min_mm, w.nominal_mm, w.max_mm), (None, None, None));
        assert_eq!(w.unknown_area_share, 1.0);
    }
}
