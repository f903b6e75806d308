//! Fill analysis: how far the melt travels from a gate, where it arrives last, where fronts
//! meet, what pressure it needs (the paper's Eq. 1), and the gate that shortens the worst
//! path (the balanced gate) or several gates that share the part.
//!
//! **Model.** The part is voxelised ([`voxel`]): the solid cells of its inside plus the cells
//! its surface passes through. The melt flows from cell to cell, never through air. The
//! bodies are the mesh's connected sets of triangles ([`Bodies`]); each cell belongs to the
//! body that made it and cells of different bodies are never neighbours, so a gate fills
//! only its own body at any cell size, and a part of several bodies gets a gate per body
//! (the paper's rule on each: its qualifying node nearest its centre of mass). Bodies of
//! less than [`STRAY_BODY_AREA_SHARE`] of the area are stray and left out.
//! Arrival fields are marched over the cells ([`march`]): the flow length is the length of
//! the shortest path through the solid; the fill order weights each millimetre by the flow
//! resistance of the wall it crosses.
//!
//! **Fill time.** The fill order is reported as an estimated fill time in seconds: the
//! resistance-weighted path (mm of nominal wall) over the Eq. 7 front velocity v. A raw
//! weighted length or a 0..1 rank would not compare across parts (the same number means a
//! different time at a different wall and material) and a rank hides how late the last
//! place is; seconds do both, and the Eq. 7 velocity is the paper's own. It converges as the
//! cells shrink because the weights depend on the measured wall only (floored at
//! [`MIN_WALL_OF_NOMINAL`] of H_ref, slivers read as the nominal wall), not on the cell.
//! It is an estimate (a front at constant speed slowed by thin walls), not a simulation.
//!
//! **Limits.** [`FlowOptions`] bounds the grid, the solid cells, the surface samples, the
//! gates and the several-gate search; each is checked before the work it bounds.
//!
//! **Resistance (derivation).** In a slit of thickness H, a power-law melt (index n,
//! consistency K) has a mean velocity
//! v = n / (2n + 1) (H / 2)^((n+1)/n) (|dp/ds| / K)^(1/n).
//! Under the same pressure gradient a front therefore moves at a speed proportional to
//! H^((n+1)/n), and the time to cross ds is proportional to H^(-(n+1)/n) ds. The fill-order
//! cost of a millimetre is (H_ref / H)^((n+1)/n), with H_ref the nominal wall of the
//! cell's body (the median of that body's wall samples, so that a body's fill time does not
//! depend on what else is in the file): for a Newtonian melt (n = 1) that is the 1/H^2 of Eq. 1; for the paper's materials (n about
//! 0.2-0.3) the exponent is 4-6, so thin walls hold the front back much more strongly.
//!
//! **Pressure.** Eq. 1, ΔP = 12 μ L v / H^2, taken along the path with the local H:
//! ΔP(x) = 12 μ v ∫ ds / H(s)^2 = 12 μ v T_2(x) / H_ref^2, where T_2 is the field with cost
//! (H_ref / H)^2, H_ref here the part's nominal wall (the factor 12 μ v / H_ref^2 cancels
//! it, so any one reference gives the same pressure). The estimate is its largest value over
//! the part, with μ = mu_opt and v from Eq. 7.

pub mod march;
pub mod suitability;
pub mod voxel;

use crate::clock::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::cancel::Cancel;
use crate::material::Material;
use crate::math::DVec3;
use crate::mesh::topology::body_of_triangle;
use crate::mesh::Mesh;
use crate::raycast::Bvh;
pub use march::{march, march_until, Field, Source};
pub use suitability::{NodeScore, ScoreKind, Suitability};
pub use voxel::Voxels;

/// What the balanced gate minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Objective {
    /// The largest flow length L_max.
    #[default]
    Length,
    /// The largest fill-order value (flow length weighted by the wall's resistance).
    Resistance,
}

impl Objective {
    /// Its name as the options spell it (`--objective`, `objective`).
    pub fn name(self) -> &'static str {
        match self {
            Objective::Length => "length",
            Objective::Resistance => "resistance",
        }
    }

    /// How the searches' values of this objective read in a report: what they are and their
    /// unit (L_max in mm; the fill time in s, which is what the resistance objective's values
    /// are reported in).
    pub fn value_words(self) -> (&'static str, &'static str) {
        match self {
            Objective::Length => ("longest flow path L_max", "mm"),
            Objective::Resistance => ("fill time", "s"),
        }
    }

    /// The field whose arrival decides which gate of a layout reaches a place first: the
    /// flow length, or the fill time (a layout's shares are read by it).
    pub fn field_words(self) -> &'static str {
        match self {
            Objective::Length => "flow length",
            Objective::Resistance => "fill time",
        }
    }

    /// This objective's value of a gate's fill: its L_max, mm, or its fill time, s.
    pub fn of_fill(self, fill: &GateFill) -> f64 {
        match self {
            Objective::Length => fill.l_max_mm,
            Objective::Resistance => fill.fill_time_s,
        }
    }

    /// A value of this objective as a report writes it, without its unit: L_max to 0.1 mm,
    /// a fill time to three significant figures ([`crate::report::seconds_text`]).
    pub fn value_text(self, x: f64) -> String {
        match self {
            Objective::Length => format!("{x:.1}"),
            Objective::Resistance => crate::report::seconds_text(x),
        }
    }
}

/// Options of the fill analysis, with the limits that bound its work. Every limit is
/// checked before the work it bounds: a cell size the user set is refused when it breaks
/// one ([`FillError::TooLarge`]); a cell size chosen from the part is coarsened until it
/// keeps them (with a warning).
#[derive(Debug, Clone, PartialEq)]
pub struct FlowOptions {
    /// Cell side in mm; `None` chooses it from the part (see [`cell_size`]).
    pub cell_mm: Option<f64>,
    /// Largest dense grid, in cells (solid or not). Default 24 million (about 200 MB of
    /// index and flags while voxelising).
    pub max_cells: f64,
    /// Largest count of solid cells, estimated before voxelising as V / h^3 + 2 A / h^2
    /// (volume and area of the part) and counted after. Each solid cell costs about 200
    /// bytes (neighbour table, walls, costs, the fields of a search). Default 5 million
    /// (about 1 GB).
    pub max_solid_cells: f64,
    /// Largest count of surface samples (see [`voxel::samples_for`]). Default 200 million
    /// (about 2 s of sampling).
    pub max_samples: f64,
    /// Most gates of a several-gate layout. Default 32.
    pub max_gates: usize,
    /// Largest work of the several-gate search, in cell visits: solid cells times the
    /// marches it may run (2 per added gate and 3 per gate in each of its 8 rounds, for
    /// each of its three starts).
    /// Default 2 billion (a minute or two on two cores).
    pub max_march_cells: f64,
}

impl Default for FlowOptions {
    fn default() -> Self {
        FlowOptions {
            cell_mm: None,
            max_cells: 24.0e6,
            max_solid_cells: 5.0e6,
            max_samples: 200.0e6,
            max_gates: 32,
            max_march_cells: 2.0e9,
        }
    }
}

/// The largest cell, as a fraction of the part's box diagonal: coarser cells cannot tell
/// the part's shape (its last place to fill could be anywhere in a cell larger than it).
pub const MAX_CELL_OF_DIAGONAL: f64 = 0.1;

/// What the limits of [`FlowOptions`] read of a set of triangles, summed once for every
/// cell size tried (see [`check_limits`]): the bodies' pass over the triangles sums it beside
/// their own sums, so that choosing the cell reads the triangles no more.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct LimitSums {
    /// Signed volume, mm^3 (of the tetrahedra from the origin).
    volume: f64,
    /// Area, mm^2.
    area: f64,
    /// Number of triangles.
    triangles: f64,
    /// Sum over the triangles of their box's three sides, mm (see [`voxel::samples_bound`]).
    side: f64,
    /// Sum over the triangles of the square of that, mm^2.
    side2: f64,
}

impl LimitSums {
    /// Adds triangle `[p, q, r]`; returns its area and signed volume, as summed.
    #[inline]
    fn add(&mut self, [p, q, r]: [DVec3; 3]) -> (f64, f64) {
        let a = 0.5 * (q - p).cross(r - p).length();
        let v = p.dot(q.cross(r)) / 6.0;
        let box_side = p.max(q).max(r) - p.min(q).min(r);
        let s = box_side.x + box_side.y + box_side.z;
        self.area += a;
        self.volume += v;
        self.triangles += 1.0;
        self.side += s;
        self.side2 += s * s;
        (a, v)
    }

    fn join(&mut self, other: &LimitSums) {
        self.volume += other.volume;
        self.area += other.area;
        self.triangles += other.triangles;
        self.side += other.side;
        self.side2 += other.side2;
    }

    /// The sums of the kept triangles of `mesh` (`keep[t] != u32::MAX`).
    fn of(mesh: &Mesh, keep: &[u32]) -> LimitSums {
        // Blocks of triangles summed in a plain loop each, then the blocks' sums in order:
        // the same sums on any number of threads.
        const BLOCK: usize = 4096;
        let sums: Vec<LimitSums> = keep
            .par_chunks(BLOCK)
            .enumerate()
            .map(|(i, block)| {
                let mut sums = LimitSums::default();
                for (j, &b) in block.iter().enumerate() {
                    if b != u32::MAX {
                        sums.add(mesh.corners(i * BLOCK + j));
                    }
                }
                sums
            })
            .collect();
        let mut all = LimitSums::default();
        for s in &sums {
            all.join(s);
        }
        all
    }

    /// [`voxel::samples_bound`] at cell side `h` from the sums: sum (s / step + 2)^2 is
    /// sum s^2 / step^2 + 4 sum s / step + 4 n.
    fn samples_bound(&self, h: f64) -> f64 {
        voxel::samples_bound_of_sums(self.side, self.side2, self.triangles, h)
    }
}

/// The first limit of `options` a voxelisation at `h` would break, as the error.
fn check_limits(
    mesh: &Mesh,
    body_of: &[u32],
    h: f64,
    sums: &LimitSums,
    options: &FlowOptions,
) -> Result<(), FillError> {
    let dense = Voxels::cells_for(&mesh.bounds(), h);
    if dense > options.max_cells {
        return Err(FillError::too_large(
            "grid cells",
            dense,
            options.max_cells,
            h,
            3.0,
        ));
    }
    let (v, a) = (sums.volume.abs(), sums.area);
    let solid = v / (h * h * h) + 2.0 * a / (h * h);
    if solid > options.max_solid_cells {
        return Err(FillError::too_large(
            "solid cells (estimated)",
            solid,
            options.max_solid_cells,
            h,
            3.0,
        ));
    }
    // The exact count (a pass of square roots over the triangles) only when the bound
    // from the triangles' boxes does not already keep the limit.
    if sums.samples_bound(h) <= options.max_samples {
        return Ok(());
    }
    let keep: Vec<bool> = body_of.iter().map(|&b| b != u32::MAX).collect();
    let samples = voxel::samples_for(mesh, h, Some(&keep));
    if samples > options.max_samples {
        return Err(FillError::too_large(
            "surface samples",
            samples,
            options.max_samples,
            h,
            2.0,
        ));
    }
    Ok(())
}

/// The cell side: half the nominal wall (a wall is two cells across, and the surface cells
/// add about one more), at most 1/120 of the part's diagonal; coarsened (by 5 % steps) until
/// it keeps the limits of `options`. A cell size given in `options` is checked instead:
/// refused when larger than [`MAX_CELL_OF_DIAGONAL`] of the diagonal or when it breaks a
/// limit. Returns the side and, when it was coarsened, the limit that made it so.
pub fn cell_size(
    mesh: &Mesh,
    nominal_wall_mm: f64,
    options: &FlowOptions,
) -> Result<(f64, Option<FillError>), FillError> {
    let body_of = vec![0u32; mesh.triangles.len()];
    let sums = LimitSums::of(mesh, &body_of);
    choose_cell(mesh, &body_of, &sums, nominal_wall_mm, options)
}

/// [`cell_size`] for the kept triangles of `body_of` (`u32::MAX` for the others), whose
/// [`LimitSums`] are `sums`.
fn choose_cell(
    mesh: &Mesh,
    body_of: &[u32],
    sums: &LimitSums,
    nominal_wall_mm: f64,
    options: &FlowOptions,
) -> Result<(f64, Option<FillError>), FillError> {
    let diagonal = mesh.bounds().diagonal();
    if let Some(h) = options.cell_mm {
        if !(h.is_finite() && h > 0.0) {
            return Err(FillError::option(
                "cell",
                format!("the cell size must be a positive number, got {h}"),
            ));
        }
        if h > MAX_CELL_OF_DIAGONAL * diagonal {
            return Err(FillError::option(
                "cell",
                format!(
                    "a cell of {} mm is larger than {} of the part's diagonal ({:.3} mm): at most {:.3} mm",
                    crate::error::figures(h),
                    MAX_CELL_OF_DIAGONAL,
                    diagonal,
                    MAX_CELL_OF_DIAGONAL * diagonal
                ),
            ));
        }
        return match check_limits(mesh, body_of, h, sums, options) {
            Ok(()) => Ok((h, None)),
            // The least cell that keeps every limit, not only the one broken first, and the
            // same whatever cell was asked for: from that one's estimate, stepped as the
            // cell chosen by itself is until it keeps them, then halved down to the least
            // that does (to a millionth), and given a thousandth over it so that its four
            // figures do not round below it.
            Err(FillError::TooLarge {
                what,
                count,
                limit,
                cell_mm,
                least_cell_mm,
            }) => {
                let most = MAX_CELL_OF_DIAGONAL * diagonal;
                let keeps = |h: f64| check_limits(mesh, body_of, h, sums, options).is_ok();
                // A cell so small that its count overflows (1e-200 mm) gives no estimate:
                // the search starts from the cell chosen by itself.
                let start = match least_cell_mm.is_finite() {
                    true => least_cell_mm.max(h),
                    false => (nominal_wall_mm / 2.0).clamp(h, most),
                };
                let least = match coarsen(start, most, |h| {
                    check_limits(mesh, body_of, h, sums, options)
                }) {
                    Ok((above, _)) => {
                        let (mut low, mut high) = (h, above);
                        while high - low > 1e-6 * high {
                            let middle = 0.5 * (low + high);
                            match keeps(middle) {
                                true => high = middle,
                                false => low = middle,
                            }
                        }
                        high * (1.0 + 1e-3)
                    }
                    Err((h, _)) => h,
                };
                Err(FillError::TooLarge {
                    what,
                    count,
                    limit,
                    cell_mm,
                    least_cell_mm: least,
                })
            }
            Err(e) => Err(e),
        };
    }
    let mut h = (nominal_wall_mm / 2.0).min(diagonal / 120.0);
    if !(h.is_finite() && h > 0.0) {
        return Err(FillError::option(
            "cell",
            format!("no cell size fits a part of diagonal {diagonal} mm"),
        ));
    }
    // The grid's cell count falls as h^-3: jump close, then step.
    let n = Voxels::cells_for(&mesh.bounds(), h);
    if n > options.max_cells {
        h *= (n / options.max_cells).cbrt();
    }
    let most = MAX_CELL_OF_DIAGONAL * diagonal;
    match coarsen(h, most, |h| check_limits(mesh, body_of, h, sums, options)) {
        Ok(chosen) => Ok(chosen),
        Err((_, first)) => Err(first),
    }
}

/// The cell side from `h` up, by 5 % steps, at most 400 of them and not past `most`, at
/// which `check` holds: `Ok` with it and the first refusal met on the way (the limit that
/// made it coarser, if any), or `Err` with the last side tried and the first refusal.
fn coarsen(
    mut h: f64,
    most: f64,
    check: impl Fn(f64) -> Result<(), FillError>,
) -> Result<(f64, Option<FillError>), (f64, FillError)> {
    let mut first = None;
    for _ in 0..400 {
        match check(h) {
            Ok(()) => return Ok((h, first)),
            Err(e) => {
                first.get_or_insert(e);
            }
        }
        h *= 1.05;
        if h > most {
            break;
        }
    }
    Err((
        h,
        first.unwrap_or_else(|| FillError::option("cell", "no cell size keeps the limits")),
    ))
}

/// Bodies whose area is below this share of the part's area are stray (loose facets,
/// zero-area slivers): they make no cells, need no gate and are not counted as bodies.
pub const STRAY_BODY_AREA_SHARE: f64 = 1e-3;

/// The name a body goes by in words and pictures: "body 1" for the body of index 0. The
/// reports' `body` fields are indices from 0; a designer counts the bodies from 1.
pub fn body_name(index: u32) -> String {
    format!("body {}", u64::from(index) + 1)
}

/// The bodies of a mesh as the fill analysis sees them.
#[derive(Debug, Clone)]
pub struct Bodies {
    /// Body of each triangle, numbered from 0 by first appearance; `u32::MAX` for the
    /// triangles of stray bodies.
    pub of_triangle: Vec<u32>,
    /// Number of bodies kept.
    pub count: usize,
    /// Number of stray bodies (area below [`STRAY_BODY_AREA_SHARE`] of the part's).
    pub stray: usize,
    /// Volume of each body (absolute signed volume of its triangles), mm^3.
    pub volume_mm3: Vec<f64>,
    /// Centre of mass of each body (of its volume; of its area when the volume is zero).
    pub centre: Vec<DVec3>,
    /// The sums the fill's limits read, over the kept bodies' triangles.
    pub(crate) kept: LimitSums,
}

impl Bodies {
    /// The mesh's bodies (connected sets of triangles, [`body_of_triangle`]), the stray ones
    /// dropped.
    pub fn of(mesh: &Mesh) -> Bodies {
        Bodies::of_counted(mesh, None)
    }

    /// [`Bodies::of`] with the number of bodies when it is known (the load's
    /// [`crate::mesh::Topology::bodies`]): a mesh of one body needs no union of its
    /// vertices to tell which triangle is in which. (A facet collapsed to one vertex that
    /// no other facet uses is no body to that count but a body of its own here: such a
    /// mesh takes the union.)
    pub fn of_counted(mesh: &Mesh, bodies: Option<u64>) -> Bodies {
        let collapsed = || mesh.triangles.iter().any(|t| t[0] == t[1] && t[1] == t[2]);
        let label = match bodies {
            Some(1) if !collapsed() => vec![0; mesh.triangles.len()],
            _ => body_of_triangle(mesh),
        };
        let n = label.iter().map(|&b| b as usize + 1).max().unwrap_or(0);
        // Each body's area and signed volume are its `LimitSums`' own.
        let mut sums = vec![LimitSums::default(); n];
        let mut moment = vec![DVec3::ZERO; n];
        let mut area_moment = vec![DVec3::ZERO; n];
        for (t, &b) in label.iter().enumerate() {
            let [p, q, r] = mesh.corners(t);
            let (a, v) = sums[b as usize].add([p, q, r]);
            // The tetrahedron (0, p, q, r) has its centroid at (p + q + r) / 4.
            moment[b as usize] += (p + q + r) * (v / 4.0);
            area_moment[b as usize] += (p + q + r) * (a / 3.0);
        }
        let total: f64 = sums.iter().map(|s| s.area).sum();
        let mut renumber = vec![u32::MAX; n];
        let mut count = 0u32;
        let (mut volume_mm3, mut centre) = (Vec::new(), Vec::new());
        let mut kept = LimitSums::default();
        for (b, body) in sums.iter().enumerate() {
            let (area, volume) = (body.area, body.volume);
            if area >= STRAY_BODY_AREA_SHARE * total && area > 0.0 {
                renumber[b] = count;
                count += 1;
                kept.join(body);
                volume_mm3.push(volume.abs());
                centre.push(if volume.abs() > 1e-12 * total.powf(1.5) {
                    moment[b] / volume
                } else {
                    area_moment[b] / area
                });
            }
        }
        Bodies {
            of_triangle: label.iter().map(|&b| renumber[b as usize]).collect(),
            count: count as usize,
            stray: n - count as usize,
            volume_mm3,
            centre,
            kept,
        }
    }
}

/// The thinnest wall the costs see, as a share of the nominal wall. Thinner readings come
/// mostly from edges, chamfers and slivers, where a ray meets a neighbouring face; a front
/// does not squeeze through such a place but goes around it, which the march finds as the
/// cheaper path. A floor fixed to H_ref (not to the cell) keeps the fill time converging
/// as the cells shrink: with a floor of h, finer cells let thinner readings in and the
/// fill-order maximum grew from 108 to 3279 on deskhop_case_bottom between cells of 0.91
/// and 0.45 mm.
pub const MIN_WALL_OF_NOMINAL: f64 = 0.5;

/// The voxelised part with its wall thickness and the costs of the three fields.
#[derive(Debug, Clone)]
pub struct Domain {
    /// The solid cells.
    pub voxels: Voxels,
    /// Body of each cell (the mesh body that made it, [`Voxels::body`]).
    pub body: Vec<u32>,
    /// Number of bodies (one more than the largest body number of a cell).
    pub bodies: usize,
    /// Volume of each body, mm^3: its cells' volume, or the mesh's volume of the body
    /// when [`analyse`] knows it (closed bodies).
    pub body_volume_mm3: Vec<f64>,
    /// Nominal wall thickness of the part, mm: the reference of the Eq. 1 pressure cost.
    pub nominal_wall_mm: f64,
    /// Nominal wall H_ref of each body, mm: the reference of its fill-time cost, its wall
    /// floor and its flow ratio, so that a body's fill reads as it would alone.
    pub body_nominal_wall_mm: Vec<f64>,
    /// Wall thickness per cell, mm.
    pub wall_mm: Vec<f32>,
    /// Fill-order cost per cell: (H_ref / H)^((n+1)/n).
    pub fill_cost: Vec<f32>,
    /// Eq. 1 cost per cell: (H_ref / H)^2.
    pub pressure_cost: Vec<f32>,
    /// Power-law index n used for the fill cost.
    pub n: f64,
}

impl Domain {
    /// Voxelises `mesh` at `h` mm. `triangle_wall_mm` gives the wall thickness of each
    /// triangle (NaN where unknown); cells take the thickness of their triangle, and unknown
    /// values and slivers (below [`crate::thickness::SLIVER_OF_NOMINAL`] of H_ref) take the
    /// nominal wall. The thickness is clamped to
    /// [[`MIN_WALL_OF_NOMINAL`] H_ref, 100 H_ref] so the costs stay finite and do not
    /// depend on the cell size.
    pub fn new(
        mesh: &Mesh,
        h: f64,
        triangle_wall_mm: Option<&[f32]>,
        nominal_wall_mm: f64,
        material: &Material,
    ) -> Domain {
        Domain::from_voxels(
            Voxels::new(mesh, h),
            triangle_wall_mm,
            nominal_wall_mm,
            material,
        )
    }

    /// [`Domain::new`] on cells already made.
    pub fn from_voxels(
        voxels: Voxels,
        triangle_wall_mm: Option<&[f32]>,
        nominal_wall_mm: f64,
        material: &Material,
    ) -> Domain {
        let bodies = voxels
            .body
            .iter()
            .map(|&b| b as usize + 1)
            .max()
            .unwrap_or(0);
        Domain::with_body_walls(
            voxels,
            triangle_wall_mm,
            nominal_wall_mm,
            &vec![nominal_wall_mm; bodies],
            material,
        )
    }

    /// [`Domain::from_voxels`] with a nominal wall per body (`body_nominal_wall_mm[b]`, the
    /// part's `nominal_wall_mm` for a body it does not name). Each cell's wall is floored,
    /// capped and read as a sliver against its own body's H_ref, and its fill-time cost is
    /// (H_ref(body) / H)^((n+1)/n): a body's fill time is then what it would be alone, not
    /// seen through the wall of another body. The Eq. 1 cost stays (H_part / H)^2 with the
    /// part's wall, whose factor 12 μ v / H_part^2 cancels it: the pressure is 12 μ v ∫ ds /
    /// H^2 whatever the reference.
    pub fn with_body_walls(
        voxels: Voxels,
        triangle_wall_mm: Option<&[f32]>,
        nominal_wall_mm: f64,
        body_nominal_wall_mm: &[f64],
        material: &Material,
    ) -> Domain {
        let mut domain = Domain::without_walls(voxels);
        let walls = domain.walls_of(
            triangle_wall_mm,
            nominal_wall_mm,
            body_nominal_wall_mm,
            material,
        );
        domain.set_walls(walls);
        domain
    }

    /// The cells with their bodies and volumes, before their walls are known: no wall nor
    /// cost yet ([`Domain::set_walls`] gives them), which the flow length does not read.
    fn without_walls(voxels: Voxels) -> Domain {
        let h = voxels.h;
        let body = voxels.body.clone();
        let bodies = body.iter().map(|&b| b as usize + 1).max().unwrap_or(0);
        let mut body_volume_mm3 = vec![0.0; bodies];
        for &b in &body {
            body_volume_mm3[b as usize] += h * h * h;
        }
        Domain {
            fill_cost: Vec::new(),
            pressure_cost: Vec::new(),
            voxels,
            body,
            bodies,
            body_volume_mm3,
            nominal_wall_mm: f64::NAN,
            body_nominal_wall_mm: Vec::new(),
            wall_mm: Vec::new(),
            n: f64::NAN,
        }
    }

    /// The walls and costs of the cells, as [`Domain::with_body_walls`] describes them.
    fn walls_of(
        &self,
        triangle_wall_mm: Option<&[f32]>,
        nominal_wall_mm: f64,
        body_nominal_wall_mm: &[f64],
        material: &Material,
    ) -> CellWalls {
        let body = &self.body;
        let body_nominal: Vec<f64> = (0..self.bodies)
            .map(|b| {
                body_nominal_wall_mm
                    .get(b)
                    .copied()
                    .filter(|w| w.is_finite() && *w > 0.0)
                    .unwrap_or(nominal_wall_mm)
            })
            .collect();
        // Per cell on all threads (each value its own, whatever the order).
        let wall_mm: Vec<f32> = self
            .voxels
            .triangle
            .par_iter()
            .zip(body)
            .with_min_len(4096)
            .map(|(&t, &b)| {
                let reference = body_nominal[b as usize];
                let w = triangle_wall_mm
                    .and_then(|w| w.get(t as usize).copied())
                    .map(f64::from)
                    // Slivers are films, not walls (see [`crate::thickness`]): unknown.
                    .filter(|w| {
                        w.is_finite() && *w >= crate::thickness::SLIVER_OF_NOMINAL * reference
                    })
                    .unwrap_or(reference);
                w.clamp(MIN_WALL_OF_NOMINAL * reference, 100.0 * reference) as f32
            })
            .collect();
        let n = material.n;
        let exponent = (n + 1.0) / n;
        let (fill_cost, pressure_cost) = rayon::join(
            || {
                wall_mm
                    .par_iter()
                    .zip(body)
                    .with_min_len(4096)
                    .map(|(&w, &b)| (body_nominal[b as usize] / w as f64).powf(exponent) as f32)
                    .collect()
            },
            || {
                wall_mm
                    .par_iter()
                    .with_min_len(4096)
                    .map(|&w| (nominal_wall_mm / w as f64).powf(2.0) as f32)
                    .collect()
            },
        );
        CellWalls {
            nominal_wall_mm,
            body_nominal_wall_mm: body_nominal,
            wall_mm,
            fill_cost,
            pressure_cost,
            n,
        }
    }

    /// Gives the cells their walls and costs.
    fn set_walls(&mut self, walls: CellWalls) {
        let CellWalls {
            nominal_wall_mm,
            body_nominal_wall_mm,
            wall_mm,
            fill_cost,
            pressure_cost,
            n,
        } = walls;
        self.nominal_wall_mm = nominal_wall_mm;
        self.body_nominal_wall_mm = body_nominal_wall_mm;
        self.wall_mm = wall_mm;
        self.fill_cost = fill_cost;
        self.pressure_cost = pressure_cost;
        self.n = n;
    }

    /// The source at a surface point, or `None` when no solid cell is near it.
    pub fn source(&self, point: DVec3) -> Option<Source> {
        self.voxels
            .cell_near(point)
            .map(|cell| Source { point, cell })
    }

    /// The body of the solid cell nearest a surface point, `None` when no cell is near it.
    pub fn body_at(&self, point: DVec3) -> Option<u32> {
        self.source(point).map(|s| self.body[s.cell as usize])
    }

    /// Body `b`'s share of the part's volume.
    pub fn volume_share(&self, b: u32) -> f64 {
        let total: f64 = self.body_volume_mm3.iter().sum();
        self.body_volume_mm3[b as usize] / total.max(f64::MIN_POSITIVE)
    }

    /// The cost array of an objective.
    pub fn cost(&self, objective: Objective) -> Option<&[f32]> {
        Kind::of(objective).cost(self)
    }
}

/// The walls of a [`Domain`]'s cells and what they cost the fields, made apart from the
/// cells ([`Domain::walls_of`]) so that the flow length can be marched meanwhile.
struct CellWalls {
    nominal_wall_mm: f64,
    body_nominal_wall_mm: Vec<f64>,
    wall_mm: Vec<f32>,
    fill_cost: Vec<f32>,
    pressure_cost: Vec<f32>,
    n: f64,
}

/// A point and the value of the fields there.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PointValue {
    /// Position, mm: on the part's surface (the nearest point of the cell's triangle) in
    /// [`analyse`]'s results; the cell centre from [`fill_from`].
    pub point: [f64; 3],
    /// Flow length from the gate, mm.
    pub flow_length_mm: f64,
    /// Estimated fill time when the front arrives, s (see [`GateFill::fill_time_s`]).
    pub fill_time_s: f64,
}

/// A place where two melt fronts meet head on, an estimate of a weld line.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WeldLine {
    /// A representative point (the cell of the group nearest its mean), mm.
    pub point: [f64; 3],
    /// Cells in the group.
    pub cells: usize,
    /// Extent of the group (largest distance from the representative point), mm.
    pub extent_mm: f64,
    /// Flow length there, mm.
    pub flow_length_mm: f64,
    /// Mean angle between the meeting fronts, degrees (180: head on).
    pub meeting_angle_deg: f64,
}

/// The fill from one gate.
#[derive(Debug, Clone, Serialize)]
pub struct GateFill {
    /// The gate, mm.
    pub gate: [f64; 3],
    /// The body it feeds (see [`Bodies`]).
    pub body: u32,
    /// Share of the part's volume it reaches: each body's volume times the share of its
    /// cells reached, over the whole volume (below 1 when the part has several bodies).
    pub reached_share: f64,
    /// Wall thickness across the surface at the gate, mm: the wall of the triangle of the
    /// gate's cell, measured along its inverted normal ([`crate::thickness`]'s rule), as the
    /// flow resistance sees it. (The paper's wall at the gate, `wall_along_d_mm` of the
    /// gate, is measured along the demolding direction instead.)
    pub wall_across_mm: f64,
    /// Largest flow length, mm.
    pub l_max_mm: f64,
    /// Mean flow length over the volume it reaches, mm.
    pub l_mean_mm: f64,
    /// The point reached last by flow length (on the surface, as [`PointValue::point`]).
    pub farthest: [f64; 3],
    /// Estimated fill time of the last place to fill, s: the fill-order field (each mm
    /// weighted by the flow resistance of its wall, (H_ref / H)^((n+1)/n)) over the Eq. 7
    /// front velocity. It is the time a front moving at the Eq. 7 velocity through the
    /// nominal wall would take, slowed where walls are thinner and hastened where thicker;
    /// it converges as the cells shrink and compares gates on one part, not parts (each
    /// body's walls are weighed against its own nominal wall).
    pub fill_time_s: f64,
    /// The estimated time by which 99 % of the volume it reaches is filled, s (the fill
    /// order of the reached cells, which are of one size, at its 99th percentile). Where a
    /// few thin places fill far later than the rest, they set [`GateFill::fill_time_s`]
    /// whatever the gate; this time says how much of the part they hold back.
    pub fill_time_99_s: f64,
    /// L / t: each body's longest flow over that body's nominal wall, the largest over the
    /// bodies the gates reach (with one body, L_max over the nominal wall).
    pub flow_ratio: f64,
    /// The material's limit of that ratio, if known.
    pub flow_ratio_limit: Option<f64>,
    /// True when the ratio exceeds the limit.
    pub exceeds_flow_ratio: bool,
    /// Pressure drop to the last point by Eq. 1 along the path with local walls, MPa.
    pub pressure_mpa: f64,
    /// The last places to fill, where the fill ends and air may be trapped: local maxima of
    /// the fill order reached at [`LAST_TO_FILL_SHARE`] (80 %) of the fill time or later,
    /// highest first, at most five. Dead ends that fill earlier are not listed.
    pub last_to_fill: Vec<PointValue>,
    /// Where fronts meet head on after flowing around an obstacle.
    pub weld_lines: Vec<WeldLine>,
}

/// The fields of one gate, kept for pictures.
#[derive(Debug, Clone)]
pub struct GateFields {
    /// Flow length.
    pub length: Field,
    /// Fill order (resistance-weighted), mm of nominal wall; times [`seconds_per_mm`] it is
    /// the fill time.
    pub fill: Field,
}

impl GateFields {
    /// The field the searches read for `objective`.
    pub fn of(&self, objective: Objective) -> &Field {
        match objective {
            Objective::Length => &self.length,
            Objective::Resistance => &self.fill,
        }
    }
}

/// Seconds per mm of fill-order path: 1 / v with v the Eq. 7 front velocity.
pub fn seconds_per_mm(material: &Material) -> f64 {
    1e-3 / material.melt_velocity_m_s()
}

/// Eq. 1 pressure factor: ΔP = factor · T_2 with T_2 in mm, result in MPa.
pub fn pressure_factor_mpa_per_mm(material: &Material, nominal_wall_mm: f64) -> f64 {
    let v = material.melt_velocity_m_s();
    let h = nominal_wall_mm * 1e-3;
    // 12 mu v / H^2 in Pa per metre of path; 1e-3 m per mm; 1e-6 MPa per Pa.
    12.0 * material.mu_opt * v / (h * h) * 1e-3 * 1e-6
}

/// Analyses the fill from a gate at `point`. `None` when no solid cell is near the point.
pub fn fill_from(
    domain: &Domain,
    point: DVec3,
    material: &Material,
) -> Option<(GateFill, GateFields)> {
    fill_from_all(domain, &[point], material).map(|(fill, fields, _)| (fill, fields))
}

/// Analyses the fill from several gates open together (one layout): the fronts of every
/// gate are marched at once, so each place is reached from its nearest gate along the flow.
/// The [`GateFill`] is the layout's (its `gate`, `body` and `wall_across_mm` are the first
/// gate's); the [`GateShare`]s give each gate's share of the reached volume and its largest
/// flow length inside it (`candidate` is the gate's index in `points`). `None` when `points`
/// is empty or a point has no solid cell near it.
pub fn fill_from_all(
    domain: &Domain,
    points: &[DVec3],
    material: &Material,
) -> Option<(GateFill, GateFields, Vec<GateShare>)> {
    let sources: Vec<Source> = points
        .iter()
        .map(|&p| domain.source(p))
        .collect::<Option<_>>()?;
    Some(fill_from_sources(domain, points, &sources, material))
}

/// [`fill_from_all`] from the gates' sources (`points` with their cells).
fn fill_from_sources(
    domain: &Domain,
    points: &[DVec3],
    sources: &[Source],
    material: &Material,
) -> (GateFill, GateFields, Vec<GateShare>) {
    let [length, fill, pressure] = march_layout(domain, sources, [None, None, None]);
    let (gate_fill, shares) = summarise_layout(
        domain,
        points,
        sources,
        material,
        [&length, &fill, &pressure],
    );
    (gate_fill, GateFields { length, fill }, shares)
}

/// The fields of a layout of gates: flow length, fill order and pressure, in that order
/// ([`Kind`]). Those given are taken as they are (marched from the same `sources`); the
/// others are marched side by side.
fn march_layout(domain: &Domain, sources: &[Source], given: [Option<Field>; 3]) -> [Field; 3] {
    let v = &domain.voxels;
    let mut missing: Vec<(usize, Option<Field>)> = given.into_iter().enumerate().collect();
    missing.par_iter_mut().for_each(|(kind, field)| {
        if field.is_none() {
            *field = Some(march(v, sources, Kind::ALL[*kind].cost(domain)));
        }
    });
    let mut fields = missing.into_iter().map(|(_, f)| f.expect("marched above"));
    std::array::from_fn(|_| fields.next().expect("three fields"))
}

/// The three fields of a gate's fill.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Flow length: a cost of 1 per mm.
    Length,
    /// Fill order: the fill cost of each cell.
    Fill,
    /// Eq. 1 pressure: the pressure cost of each cell.
    Pressure,
}

impl Kind {
    const ALL: [Kind; 3] = [Kind::Length, Kind::Fill, Kind::Pressure];

    fn cost(self, domain: &Domain) -> Option<&[f32]> {
        match self {
            Kind::Length => None,
            Kind::Fill => Some(&domain.fill_cost),
            Kind::Pressure => Some(&domain.pressure_cost),
        }
    }

    /// The field the searches march for `objective`.
    fn of(objective: Objective) -> Kind {
        match objective {
            Objective::Length => Kind::Length,
            Objective::Resistance => Kind::Fill,
        }
    }
}

/// What [`fill_from_all`] reports of a layout, from its three fields.
fn summarise_layout(
    domain: &Domain,
    points: &[DVec3],
    sources: &[Source],
    material: &Material,
    [length, fill, pressure]: [&Field; 3],
) -> (GateFill, Vec<GateShare>) {
    let src = sources[0];
    let point = points[0];
    let v = &domain.voxels;
    let reached: Vec<u32> = (0..v.len() as u32)
        .filter(|&c| length.t[c as usize].is_finite())
        .collect();
    let (far, l_max) = argmax(&length.t);
    let l_mean = reached.iter().map(|&c| length.t[c as usize]).sum::<f64>() / reached.len() as f64;
    let per_mm = seconds_per_mm(material);
    let fill_time_s = argmax(&fill.t).1 * per_mm;
    let fill_time_99_s = percentile_99(&fill.t) * per_mm;
    let mut reached_volume = vec![0usize; domain.bodies];
    let mut cells = vec![0usize; domain.bodies];
    // Each body's longest flow: a layout's gates may feed several bodies.
    let mut body_l_max = vec![0.0f64; domain.bodies];
    for c in 0..v.len() {
        let b = domain.body[c] as usize;
        cells[b] += 1;
        let t = length.t[c];
        reached_volume[b] += t.is_finite() as usize;
        if t.is_finite() && t > body_l_max[b] {
            body_l_max[b] = t;
        }
    }
    let total_volume: f64 = domain.body_volume_mm3.iter().sum();
    let reached_share = (0..domain.bodies)
        .map(|b| domain.body_volume_mm3[b] * reached_volume[b] as f64 / cells[b].max(1) as f64)
        .sum::<f64>()
        / total_volume.max(f64::MIN_POSITIVE);
    let p_max = argmax(&pressure.t).1;
    // Eq. 1's L / H, each body's longest flow over its own nominal wall, the largest over
    // the bodies the gates reach (so the order of a layout's gates does not matter).
    let flow_ratio = body_l_max
        .iter()
        .enumerate()
        .map(|(b, &l)| {
            l / domain
                .body_nominal_wall_mm
                .get(b)
                .copied()
                .unwrap_or(domain.nominal_wall_mm)
        })
        .fold(0.0, f64::max);
    let limit = material.max_flow_ratio;
    let (last_to_fill, weld_lines) = rayon::join(
        || last_to_fill(v, &fill.t, &length.t, per_mm, 5),
        || weld_lines(v, &length.t),
    );
    let gate_fill = GateFill {
        gate: point.to_array(),
        body: domain.body[src.cell as usize],
        reached_share,
        wall_across_mm: domain.wall_mm[src.cell as usize] as f64,
        l_max_mm: l_max,
        l_mean_mm: l_mean,
        farthest: v.centre(far).to_array(),
        fill_time_s,
        fill_time_99_s,
        flow_ratio,
        flow_ratio_limit: limit,
        exceeds_flow_ratio: limit.is_some_and(|m| flow_ratio > m),
        pressure_mpa: p_max * pressure_factor_mpa_per_mm(material, domain.nominal_wall_mm),
        last_to_fill,
        weld_lines,
    };
    let bodies: Vec<u32> = sources
        .iter()
        .map(|s| domain.body[s.cell as usize])
        .collect();
    let shares = shares_of(domain, length, points, &bodies);
    (gate_fill, shares)
}

/// The warning for a fill whose last 1 % fills far later than the rest (more than
/// [`crate::display::TAIL_FACTOR`] times the 99 % time, where the pictures' colours stop at
/// that time): a few thin places then set the fill time whatever the gate.
fn late_tail_warning(fill: &GateFill, gate: &str) -> Option<String> {
    let (last, most) = (fill.fill_time_s, fill.fill_time_99_s);
    if !(most > 0.0 && last > f64::from(crate::display::TAIL_FACTOR) * most) {
        return None;
    }
    let place = fill
        .last_to_fill
        .first()
        .map(|p| {
            let [x, y, z] = p.point;
            format!(" (the last at ({x:.3}, {y:.3}, {z:.3}) mm)")
        })
        .unwrap_or_default();
    Some(format!(
        "the last 1 % of the volume fills far later than the rest: the {gate}'s fill time is {} s, yet 99 % of the volume is filled by {} s; a few places of thin walls fill last{place} and set the fill time of nearly any gate: to compare gates, read L_max and the pressure first",
        crate::report::seconds_text(last),
        crate::report::seconds_text(most),
    ))
}

/// Under the resistance objective, the warning for one slow place (a thin wall) that fills
/// last from the paper gate and from the balanced gate alike (their last places within two
/// and a half cells `h` of each other) when the balanced gate moved to within half its L_max
/// of it: the fill time to that place, not the fill of the part, chose the gate, at the cost
/// of a longer L_max. Gating beside a thin place goes against gating into the thick
/// sections; the 99 % times tell the fill of the part.
fn slow_place_warning(
    paper: &GateFill,
    balanced: &BalancedFill,
    objective: Objective,
    h: f64,
) -> Option<String> {
    if objective != Objective::Resistance || balanced.is_paper_gate {
        return None;
    }
    let b = &balanced.fill;
    let (p_last, b_last) = (paper.last_to_fill.first()?, b.last_to_fill.first()?);
    let apart = DVec3::from_array(p_last.point).distance(DVec3::from_array(b_last.point));
    let moved_to_it = b_last.flow_length_mm < 0.5 * b.l_max_mm
        && 1.5 * b_last.flow_length_mm < p_last.flow_length_mm;
    if apart > 2.5 * h || !moved_to_it {
        return None;
    }
    let [x, y, z] = b_last.point;
    Some(format!(
        "one slow place, at ({x:.3}, {y:.3}, {z:.3}) mm, fills last from the paper gate and from the balanced gate alike (a thin wall holds the front there): the balanced gate minimises the fill time to it, and moved from {:.1} to {:.1} mm of flow path from it, at the cost of L_max {:.1} -> {:.1} mm; a gate beside a thin place goes against gating into the thick sections: read the 99 % times (paper {} s, balanced {} s) and L_max, or thicken that place",
        p_last.flow_length_mm,
        b_last.flow_length_mm,
        paper.l_max_mm,
        b.l_max_mm,
        crate::report::seconds_text(paper.fill_time_99_s),
        crate::report::seconds_text(b.fill_time_99_s),
    ))
}

/// The 99th percentile of a field's finite values (0 when there is none): the least value
/// at or below which 99 % of them lie (the value of rank ceil(0.99 n), counted from 1).
fn percentile_99(t: &[f64]) -> f64 {
    let mut reached: Vec<f64> = t.iter().copied().filter(|x| x.is_finite()).collect();
    let Some(rank) = crate::display::rank_of_99th(reached.len()) else {
        return 0.0;
    };
    *reached.select_nth_unstable_by(rank, f64::total_cmp).1
}

/// Each source's share of the volume a multi-source field reaches, and its largest value
/// inside that share (the shares of [`volumes_of`]).
fn shares_of(domain: &Domain, field: &Field, points: &[DVec3], bodies: &[u32]) -> Vec<GateShare> {
    let (volumes, l_max) = volumes_of(domain, field, points.len());
    let reached = volumes.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    points
        .iter()
        .enumerate()
        .map(|(g, p)| GateShare {
            candidate: g,
            point: p.to_array(),
            body: bodies[g],
            volume_share: volumes[g] / reached,
            l_max_mm: Some(l_max[g]),
            fill_time_s: None,
        })
        .collect()
}

/// The volume, mm^3, each of the `n` sources of a multi-source field reaches first, and its
/// largest value inside it. A cell stands for its body's volume over its body's cells (the
/// bodies' cells are of one size but not of one fill of solid), so that a source that alone
/// fills a body has that body's volume, as the report gives it.
fn volumes_of(domain: &Domain, field: &Field, n: usize) -> (Vec<f64>, Vec<f64>) {
    let bodies = domain.bodies.max(1);
    // Cells of each body, and of each source in each body.
    let mut cells = vec![0usize; bodies];
    let mut count = vec![0usize; n * bodies];
    let mut l_max = vec![0.0f64; n];
    for c in 0..field.t.len() {
        let b = domain.body[c] as usize;
        cells[b] += 1;
        let g = field.source[c] as usize;
        if g < n && field.t[c].is_finite() {
            count[g * bodies + b] += 1;
            l_max[g] = l_max[g].max(field.t[c]);
        }
    }
    let volumes = (0..n)
        .map(|g| {
            (0..bodies)
                .map(|b| {
                    count[g * bodies + b] as f64 / cells[b].max(1) as f64
                        * domain.body_volume_mm3.get(b).copied().unwrap_or(1.0)
                })
                .sum::<f64>()
        })
        .collect();
    (volumes, l_max)
}

/// The cell with the largest finite value and that value (lowest cell on ties).
pub fn argmax(t: &[f64]) -> (u32, f64) {
    let mut best = (0u32, f64::NEG_INFINITY);
    for (i, &x) in t.iter().enumerate() {
        if x.is_finite() && x > best.1 {
            best = (i as u32, x);
        }
    }
    best
}

/// The places listed as last to fill are those the front reaches in the last part of the
/// fill: at [`LAST_TO_FILL_SHARE`] of the fill time or later. A dead end near the gate (a
/// rib, a boss) is a local maximum of the fill time too, but it fills early: air there is
/// pushed out while the front still moves on elsewhere, so it is neither the end of the fill
/// nor where air is trapped last. (On the 352k housing such a place filled at 0.025 s of a
/// 0.106 s fill.)
pub const LAST_TO_FILL_SHARE: f64 = 0.8;

/// Local maxima of `order` over the 26 neighbours that fill at [`LAST_TO_FILL_SHARE`] of
/// its largest value or later, highest first, at least a tenth of the largest flow length
/// apart, at most `count` of them.
fn last_to_fill(
    v: &Voxels,
    order: &[f64],
    length: &[f64],
    seconds_per_mm: f64,
    count: usize,
) -> Vec<PointValue> {
    let offsets = voxel::neighbour_offsets();
    let late = LAST_TO_FILL_SHARE * argmax(order).1;
    let mut maxima: Vec<u32> = (0..v.len() as u32)
        .into_par_iter()
        .filter(|&c| {
            let t = order[c as usize];
            t.is_finite()
                && t >= late
                && offsets.iter().all(|&(o, _)| {
                    v.neighbour(c, o)
                        .is_none_or(|n| order[n as usize] <= t || !order[n as usize].is_finite())
                })
        })
        .collect();
    maxima.sort_by(|&a, &b| {
        order[b as usize]
            .total_cmp(&order[a as usize])
            .then(a.cmp(&b))
    });
    let spread = 0.1 * argmax(length).1;
    let mut out: Vec<PointValue> = Vec::new();
    for c in maxima {
        let p = v.centre(c);
        if out
            .iter()
            .all(|q| DVec3::from_array(q.point).distance(p) >= spread)
        {
            out.push(PointValue {
                point: p.to_array(),
                flow_length_mm: length[c as usize],
                fill_time_s: order[c as usize] * seconds_per_mm,
            });
            if out.len() == count {
                break;
            }
        }
    }
    out
}

/// The direction the front travels at each cell: the upwind gradient of T from the face
/// neighbours (unit, or zero where undefined).
fn front_direction(v: &Voxels, t: &[f64]) -> Vec<DVec3> {
    const AXES: [[i32; 3]; 3] = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    (0..v.len() as u32)
        .into_par_iter()
        .map(|c| {
            let tc = t[c as usize];
            if !tc.is_finite() {
                return DVec3::ZERO;
            }
            let mut g = [0.0; 3];
            for (k, axis) in AXES.iter().enumerate() {
                // The neighbour the front came from along this axis (the smaller T).
                let minus = v.neighbour(c, axis.map(|x| -x)).map(|n| t[n as usize]);
                let plus = v.neighbour(c, *axis).map(|n| t[n as usize]);
                let m = minus.unwrap_or(f64::INFINITY);
                let p = plus.unwrap_or(f64::INFINITY);
                if m < tc && m <= p {
                    g[k] = tc - m;
                } else if p < tc {
                    g[k] = -(tc - p);
                }
            }
            DVec3::from_array(g).normalize_or_zero()
        })
        .collect()
}

/// Cells where two fronts meet head on (each front travels towards the other, at more than
/// 120 degrees to each other), grouped into connected lines, largest first. Groups smaller
/// than three cells are noise of the discrete field and dropped.
fn weld_lines(v: &Voxels, t: &[f64]) -> Vec<WeldLine> {
    let dir = front_direction(v, t);
    let offsets = voxel::neighbour_offsets();
    let cos_limit = (120f64).to_radians().cos();
    // Each cell's widest meeting angle with a neighbour (NaN where none meets it).
    let angle: Vec<f64> = (0..v.len() as u32)
        .into_par_iter()
        .map(|c| {
            let mut angle = f64::NAN;
            let dc = dir[c as usize];
            if dc == DVec3::ZERO {
                return angle;
            }
            let pc = v.centre(c);
            // The neighbours in the table's order, which is `offsets`'; where the fronts
            // meet at less than the limit (almost every pair), nothing more is asked.
            for n in v.table.of(c) {
                if n == u32::MAX {
                    continue;
                }
                let dn = dir[n as usize];
                let cos = dc.dot(dn);
                if cos < cos_limit {
                    let towards = v.centre(n) - pc;
                    if dc.dot(towards) > 0.0 && dn.dot(-towards) > 0.0 {
                        let a = cos.clamp(-1.0, 1.0).acos().to_degrees();
                        if angle.is_nan() || angle < a {
                            angle = a;
                        }
                    }
                }
            }
            angle
        })
        .collect();
    // Group the flagged cells (26-neighbour components).
    let mut seen = vec![false; v.len()];
    let mut groups = Vec::new();
    for start in 0..v.len() as u32 {
        if seen[start as usize] || angle[start as usize].is_nan() {
            continue;
        }
        seen[start as usize] = true;
        let mut stack = vec![start];
        let mut members = Vec::new();
        while let Some(c) = stack.pop() {
            members.push(c);
            for &(o, _) in &offsets {
                if let Some(n) = v.neighbour(c, o) {
                    if !seen[n as usize] && !angle[n as usize].is_nan() {
                        seen[n as usize] = true;
                        stack.push(n);
                    }
                }
            }
        }
        if members.len() < 3 {
            continue;
        }
        let mean = members.iter().map(|&c| v.centre(c)).sum::<DVec3>() / members.len() as f64;
        let &rep = members
            .iter()
            .min_by(|&&a, &&b| {
                v.centre(a)
                    .distance_squared(mean)
                    .total_cmp(&v.centre(b).distance_squared(mean))
                    .then(a.cmp(&b))
            })
            .expect("non-empty");
        let p = v.centre(rep);
        let extent = members
            .iter()
            .map(|&c| v.centre(c).distance(p))
            .fold(0.0, f64::max);
        groups.push(WeldLine {
            point: p.to_array(),
            cells: members.len(),
            extent_mm: extent,
            flow_length_mm: t[rep as usize],
            meeting_angle_deg: members.iter().map(|&c| angle[c as usize]).sum::<f64>()
                / members.len() as f64,
        });
    }
    groups.sort_by(|a, b| {
        b.cells
            .cmp(&a.cells)
            .then(a.point[0].total_cmp(&b.point[0]))
    });
    groups.truncate(8);
    groups
}

/// The result of the balanced-gate search.
#[derive(Debug, Clone, Serialize)]
pub struct Balanced {
    /// Index of the chosen candidate in the list given.
    pub candidate: usize,
    /// Its objective value (L_max, or the largest fill-order value), mm.
    pub value: f64,
    /// The lower bound of the objective over all candidates when the search stopped.
    pub lower_bound: f64,
    /// Field runs it took.
    pub runs: usize,
    /// True when the bound proves the choice optimal (to the tolerance).
    pub proven: bool,
}

impl Balanced {
    /// For a search that stopped unproven, the most any candidate could lower the
    /// objective below the chosen one's value, % of that value: no candidate's value is
    /// below the search's lower bound. `None` when the search proved its choice, or when
    /// its numbers give no such figure (a value of zero, a bound not finite).
    pub fn unproven_gap_pct(&self) -> Option<f64> {
        if self.proven
            || self.value.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            || !self.lower_bound.is_finite()
        {
            return None;
        }
        Some((100.0 * (self.value - self.lower_bound.max(0.0)) / self.value).max(0.0))
    }

    /// What the search proved, in words for a report: empty for a proven search, else
    /// how far a candidate could still beat the chosen one, e.g. "not proven optimal
    /// after 40 flow fields: a candidate could be up to 6.2 % lower".
    pub fn unproven_words(&self) -> String {
        match self.unproven_gap_pct() {
            None if self.proven => String::new(),
            None => format!("not proven optimal after {} flow fields", self.runs),
            Some(gap) => format!(
                "not proven optimal after {} flow fields: a candidate could be up to {gap:.1} % lower",
                self.runs
            ),
        }
    }
}

/// The candidate that minimises the largest arrival value over its body, without a run per
/// candidate.
///
/// The arrival value is a distance, so it is symmetric: the run from a far point x gives
/// d(c, x) for every candidate c at once, and max over the far points found so far is a
/// lower bound of each candidate's true worst value. The candidate with the least bound is
/// run; if its worst value equals its bound (within `tolerance`), no other candidate can do
/// better and the search stops; else its farthest points join the far points. Candidates
/// outside the body of `first` are not considered. After 40 runs the search stops unproven
/// with the best candidate it evaluated and the bound it reached (round parts, whose far
/// points are spread around a rim, need many far points).
pub fn balanced_gate(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: Source,
    tolerance: f64,
) -> Option<Balanced> {
    let start = march(&domain.voxels, &[first], domain.cost(objective));
    balanced_gate_from(domain, candidates, objective, first, &start, tolerance)
}

/// [`balanced_gate`] with the field of `first` for the objective already marched (the fill
/// analysis has it from the first gate's fill); it counts as the search's first run.
pub fn balanced_gate_from(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: Source,
    start: &Field,
    tolerance: f64,
) -> Option<Balanced> {
    let _arrays = march::KeepArrays::new();
    balanced_search(
        domain,
        candidates,
        objective,
        first,
        start,
        tolerance,
        FAR_REACH,
        (0, |_| ()),
    )
    .map(|s| s.found)
}

/// [`balanced_gate_from`], its runs from far points stopped past `far_reach` times the
/// least worst value known (any positive reach gives the same answer; the tests try
/// several). Beside the run of each of the first `side_rounds` candidates it evaluates
/// ([`SIDE_MARCH_ROUNDS`] in the analyses), `beside(candidate)` runs on another thread
/// when one is idle (that run alone would leave it so), and not at all otherwise; what it
/// gave for the chosen candidate comes back with the choice, when that candidate was the
/// last evaluated and a thread was free to make it.
#[allow(clippy::too_many_arguments)]
fn balanced_search<T: Send>(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: Source,
    start: &Field,
    tolerance: f64,
    far_reach: f64,
    (side_rounds, beside): (usize, impl Fn(usize) -> T + Sync),
) -> Option<Searched<T>> {
    let cost = domain.cost(objective);
    let v = &domain.voxels;
    let body = domain.body[first.cell as usize];
    let pool = in_body(domain, candidates, body);
    if pool.is_empty() {
        return None;
    }
    let mut runs = 1;
    let mut far = far_points(v, &start.t, FAR_POINTS);
    // Per candidate, the largest value at it of the far points' marches: its bound when
    // `exact`, else a lower bound (a march stopped before reaching it gives its reach).
    let mut bound = vec![0.0f64; candidates.len()];
    let mut exact = vec![true; candidates.len()];
    // Per candidate, the largest value at it of the runs that reached it (its bound once
    // every run has).
    let mut reached = vec![0.0f64; candidates.len()];
    // The far points whose marches stopped early, to be marched whole when the bounds
    // they left inexact are needed.
    let mut stopped: Vec<u32> = Vec::new();
    let max_runs = 40;
    let mut seen: Option<(f64, usize)> = None;
    let mut round = 0;
    let far_source = |f: u32| Source {
        point: v.centre(f),
        cell: f,
    };
    // The first gate's worst value, the least known before any candidate is evaluated.
    let first_worst = argmax(&start.t).1;
    loop {
        // Runs from the new far points, in parallel; each raises the bounds. A run stops
        // past `limit`, a little over the least worst value known (the first gate's, or
        // the best candidate's evaluated so far): the least bound, all the search reads
        // exactly, is below every candidate's worst value, and a candidate not reached by
        // then is bounded by the reach.
        let limit = far_reach * seen.map_or(first_worst, |(s, _)| s.min(first_worst));
        let fields: Vec<(Field, f64)> = far
            .par_iter()
            .map(|&f| march_until(v, &[far_source(f)], cost, |_, t| beyond(t, limit)))
            .collect();
        runs += fields.len();
        for ((field, reach), &f) in fields.iter().zip(&far) {
            if reach.is_finite() {
                stopped.push(f);
            }
            for &i in &pool {
                let t = field.t[candidates[i].cell as usize];
                if t.is_finite() || reach.is_infinite() {
                    reached[i] = reached[i].max(t);
                    bound[i] = bound[i].max(t);
                } else {
                    bound[i] = bound[i].max(*reach);
                    exact[i] = false;
                }
            }
        }
        // The least bound decides when its candidate's bound is exact and every inexact
        // bound is surely beyond it (then that candidate's true bound is too); else the
        // stopped runs are marched whole, which makes every bound exact. Either way the
        // choice is the one of whole runs.
        if !bounds_decide(&pool, &bound, &exact) {
            let whole: Vec<Field> = stopped
                .par_iter()
                .map(|&f| march(v, &[far_source(f)], cost))
                .collect();
            for &i in &pool {
                for field in &whole {
                    reached[i] = reached[i].max(field.t[candidates[i].cell as usize]);
                }
                bound[i] = reached[i];
                exact[i] = true;
            }
            stopped.clear();
        }
        let &best = pool
            .iter()
            .min_by(|&&a, &&b| bound[a].total_cmp(&bound[b]).then(a.cmp(&b)))
            .expect("non-empty pool");
        // Seeded at the cell centre, like the far points, so that the runs are symmetric.
        let centred = Source {
            point: v.centre(candidates[best].cell),
            cell: candidates[best].cell,
        };
        // `beside` runs only on a thread that would otherwise wait (one that took it from
        // this one): its work is kept only after the last run, so on a busy or single
        // thread it is left to the caller, who makes it for the chosen candidate alone.
        // Past the first rounds the candidate's run is alone (see `SIDE_MARCH_ROUNDS`).
        round += 1;
        let (field, aside) = if round <= side_rounds {
            rayon::join_context(
                |_| march(v, &[centred], cost),
                |ctx| ctx.migrated().then(|| beside(best)),
            )
        } else {
            (march(v, &[centred], cost), None)
        };
        runs += 1;
        let value = argmax(&field.t).1;
        if seen.is_none_or(|(v, _)| value < v) {
            seen = Some((value, best));
        }
        let proven = value <= bound[best] + tolerance;
        if proven || runs >= max_runs {
            // Unproven: the best candidate evaluated so far, with the bound that every
            // candidate is known to reach.
            let (value, candidate) = if proven {
                (value, best)
            } else {
                seen.expect("one run")
            };
            let aside = aside.filter(|_| candidate == best);
            let balanced = Balanced {
                candidate,
                value,
                lower_bound: bound[best],
                runs,
                proven,
            };
            return Some(Searched {
                found: balanced,
                aside,
                rounds: round,
            });
        }
        far = far_points(v, &field.t, FAR_POINTS);
    }
}

/// What [`balanced_search`] found: the balanced gate, what ran beside its run (when it was
/// the last run and a thread was idle), and how many candidates' runs it made.
struct Searched<T> {
    found: Balanced,
    aside: Option<T>,
    /// Read by the tests.
    #[cfg_attr(not(test), allow(dead_code))]
    rounds: usize,
}

/// The indices of the candidates in body `body`.
/// A gate from the suitability map's best node that beats the balanced gate `b`.
struct MapGate {
    /// Its fill.
    fill: GateFill,
    /// Its flow length and fill order fields.
    fields: GateFields,
    /// Its search: its objective, and the map's bound, proven (the node is exact).
    search: Balanced,
    /// The map's score of the node (from its cell's centre).
    map_score: f64,
}

/// The map's best node as the balanced gate, when the search did not prove its own gate
/// and the node is exact, on the body of the search (`first`'s), and of an objective lower
/// than the search `b`'s by more than `cell` from its own surface point (`value` of a gate's summary,
/// in the map's units). An exact best node is proven best among the nodes: every other
/// node's score is a lower bound at least as high.
fn map_best_gate(
    domain: &Domain,
    (candidates, first): (&[Source], Source),
    map: &suitability::Suitability,
    b: &Balanced,
    material: &Material,
    (value, cell): (fn(&GateFill) -> f64, f64),
) -> Option<MapGate> {
    if b.proven {
        return None;
    }
    let best = &map.nodes[map.best?];
    let point = DVec3::from_array(best.point);
    let source = domain.source(point)?;
    let candidate = candidates
        .iter()
        .position(|c| c.cell == source.cell && c.point == source.point)?;
    let same_body = domain.body[source.cell as usize] == domain.body[first.cell as usize];
    let gains = |v: f64| v < b.value - cell;
    if best.kind != suitability::ScoreKind::Exact || !same_body || !gains(best.score) {
        return None;
    }
    let [length, fill, pressure] = march_layout(domain, &[source], [None, None, None]);
    let fields = [&length, &fill, &pressure];
    let (summary, _) = summarise_layout(domain, &[point], &[source], material, fields);
    let v = value(&summary);
    gains(v).then_some(MapGate {
        fill: summary,
        fields: GateFields { length, fill },
        search: Balanced {
            candidate,
            value: v,
            lower_bound: best.score.min(v),
            runs: 0,
            proven: true,
        },
        map_score: best.score,
    })
}

/// Warnings for the fill's own gates (the balanced gate when it moved from the paper gate,
/// each gate of a layout, each body's own gate) whose node's disc is not flat within the
/// analysis's tolerance: the paper gate gets its warning from the gate search, and these
/// are qualifying nodes too, whose seats were not checked for flatness (the paper does not
/// require it).
fn seat_warnings(
    analysis: &crate::gate::Analysis,
    balanced: Option<&BalancedFill>,
    several: Option<&MultiGate>,
    body_gates: &[BodyGate],
) -> Vec<String> {
    let tol = analysis.flat_tolerance_mm;
    let step_at = |p: [f64; 3]| {
        let p = DVec3::from_array(p);
        analysis
            .qualifying_points
            .iter()
            .position(|&q| q == p)
            .and_then(|i| analysis.qualifying_step_mm.get(i))
            .map(|&s| s as f64)
            .filter(|&s| s > tol)
    };
    let words = |what: String, p: [f64; 3], step: f64| {
        format!(
            "{what} at ({:.3}, {:.3}, {:.3}) is not on a flat seat: its disc reaches {step:.2} mm off its height along D (a step, rib or slope; flatness tolerance {tol:.3} mm; --require-flat keeps only flat nodes)",
            p[0], p[1], p[2]
        )
    };
    let mut warnings = Vec::new();
    if let Some(b) = balanced.filter(|b| !b.is_paper_gate) {
        if let Some(step) = step_at(b.fill.gate) {
            warnings.push(words("the balanced gate".into(), b.fill.gate, step));
        }
    }
    // A layout's gates off a flat seat, in one warning.
    if let Some(layout) = several {
        let off: Vec<(usize, f64)> = (0..layout.gates.len())
            .filter_map(|k| step_at(layout.gates[k].point).map(|s| (k, s)))
            .collect();
        match off.as_slice() {
            [] => {}
            [(k, step)] => {
                let what = format!("gate {} of the layout of {}", k + 1, layout.gates.len());
                warnings.push(words(what, layout.gates[*k].point, *step));
            }
            _ => warnings.push(format!(
                "{} gates of the layout of {} are not on a flat seat: {} (how far each disc reaches off its height along D: a step, rib or slope; flatness tolerance {tol:.3} mm; --require-flat keeps only flat nodes)",
                off.len(),
                layout.gates.len(),
                off.iter()
                    .map(|(k, s)| format!("gate {} {s:.2} mm", k + 1))
                    .collect::<Vec<_>>()
                    .join(", "),
            )),
        }
    }
    // The bodies' own gates, but one that is the grid gate itself (warned by the gate
    // search); a parting line's gate is an edge gate, with no seat.
    let grid_gate = analysis.grid_gate.as_ref().map(|g| g.point.to_array());
    for b in body_gates
        .iter()
        .filter(|b| b.rule == BodyGateRule::Paper && b.gate != grid_gate)
    {
        if let Some((g, step)) = b.gate.and_then(|g| step_at(g).map(|s| (g, s))) {
            let what = format!("the own gate of {}", body_name(b.body));
            warnings.push(words(what, g, step));
        }
    }
    warnings
}

/// A warning for each fill reported whose flow ratio L/t exceeds the material's limit: the
/// paper gate's, the balanced gate's when it is another gate, a layout's of several gates,
/// the designer's gates'.
fn flow_ratio_warnings(
    paper: &GateFill,
    balanced: Option<&BalancedFill>,
    several: Option<&MultiGate>,
    placed: Option<&PlacedFill>,
) -> Vec<String> {
    let layout = several.and_then(|m| Some((m.gates.len(), m.fill.as_ref()?)));
    let layout_words = layout.map(|(k, _)| format!("the layout of {k} gates"));
    let fills = [
        Some(("the paper gate", paper)),
        balanced
            .filter(|b| !b.is_paper_gate)
            .map(|b| ("the balanced gate", &b.fill)),
        layout_words.as_deref().zip(layout.map(|(_, f)| f)),
        placed.map(|p| match p.shares.len() {
            1 => ("your gate", &p.fill),
            _ => ("your gates together", &p.fill),
        }),
    ];
    fills
        .into_iter()
        .flatten()
        .filter(|(_, f)| f.exceeds_flow_ratio)
        .filter_map(|(what, f)| {
            let limit = f.flow_ratio_limit?;
            Some(format!(
                "from {what} the longest flow is {:.0} times the wall (L/t), over the material's limit of {limit:.0}: the melt may freeze before it reaches the last place to fill (a short shot); more gates, a gate nearer the middle of the flow, thicker walls or a material of longer flow would shorten it",
                f.flow_ratio
            ))
        })
        .collect()
}

/// A layout's gate filling less than this share of the volume does nothing useful.
pub const IDLE_GATE_SHARE: f64 = 0.01;

/// A measure the balanced gate did not minimise counts as worse than the paper gate's when
/// it is larger by more than this share.
pub const OTHER_MEASURE_WORSE_SHARE: f64 = 0.01;

/// The warning for a balanced gate that beats the paper gate by its objective but is worse
/// by a measure it did not minimise (the search minimises one: a gate of shorter fill time
/// may have a longer flow path or need more pressure), with the values of both gates.
fn worse_by_other_measures(
    objective: Objective,
    mode: crate::GateMode,
    paper: &GateFill,
    balanced: &GateFill,
) -> Option<String> {
    let worse_by = |x: f64, y: f64| y > x * (1.0 + OTHER_MEASURE_WORSE_SHARE);
    // How much worse, in per cent of the answer's gate's value.
    let share = |x: f64, y: f64| format!("{:.0} %", 100.0 * (y / x - 1.0));
    let (p, b) = (paper, balanced);
    // The other objective in its own words, then Eq. 1's pressure, which neither minimises.
    let mut worse: Vec<String> = [Objective::Length, Objective::Resistance]
        .into_iter()
        .filter(|&o| o != objective && worse_by(o.of_fill(p), o.of_fill(b)))
        .map(|o| {
            let (what, unit) = o.value_words();
            let by = share(o.of_fill(p), o.of_fill(b));
            let (x, y) = (o.value_text(o.of_fill(p)), o.value_text(o.of_fill(b)));
            format!("{what} {x} -> {y} {unit} (+{by})")
        })
        .collect();
    if worse_by(p.pressure_mpa, b.pressure_mpa) {
        worse.push(format!(
            "pressure {} -> {} MPa (+{})",
            crate::report::three_figures(p.pressure_mpa),
            crate::report::three_figures(b.pressure_mpa),
            share(p.pressure_mpa, b.pressure_mpa)
        ));
    }
    let other = match objective {
        Objective::Length => Objective::Resistance,
        Objective::Resistance => Objective::Length,
    };
    // The answer's gate, which the balanced gate is compared with: the grid's, or on the
    // parting line in aesthetic mode.
    let gate = mode.name();
    (!worse.is_empty()).then(|| {
        format!(
            "the balanced gate minimises the {} only: against the {gate} gate it is worse in {} ({gate} -> balanced); --objective {} minimises the {} instead",
            objective.value_words().0,
            worse.join(", "),
            other.name(),
            other.value_words().0,
        )
    })
}

/// The warning for a layout's gates that add nothing to its objective
/// ([`MultiGate::redundant`]), each alone: the objective is the slowest place's value, which
/// the other gates reach as soon without it.
fn redundant_warning(layout: &MultiGate, objective: Objective) -> String {
    let (what, unit) = objective.value_words();
    let n = layout.gates.len();
    let list = |items: Vec<String>| match items.len() {
        1 => items[0].clone(),
        k => format!("{} and {}", items[..k - 1].join(", "), items[k - 1]),
    };
    let r = &layout.redundant;
    let numbers = list(r.iter().map(|&g| (g + 1).to_string()).collect());
    let shares = list(
        r.iter()
            .map(|&g| format!("{:.1}", 100.0 * layout.gates[g].volume_share))
            .collect(),
    );
    let (gates, adds, without) = match r.len() {
        1 => ("gate", "adds", "without it"),
        2 => (
            "gates",
            "each add",
            "without either one (one at a time, not both)",
        ),
        _ => (
            "gates",
            "each add",
            "without any one of them (one at a time, not all)",
        ),
    };
    let others = match n - 1 {
        1 => "the other gate reaches".to_string(),
        k => format!("the other {k} gates reach"),
    };
    let fewer = match n - 1 {
        1 => "one gate does".to_string(),
        k => format!("{k} gates do"),
    };
    format!(
        "{gates} {numbers} of the layout of {n} ({shares} % of the volume) {adds} nothing to the layout's {what}: {without}, {others} no place later than its {} {unit} (as the search measures it, from the gates' flow cells), so by this measure, which the slowest place alone sets, {fewer} as well (a gate may still even out the fill)",
        objective.value_text(layout.value()),
    )
}

/// The warning for a layout's gates that fill less than [`IDLE_GATE_SHARE`] of the volume:
/// under the fill-time objective the place reached last is often a small pocket of thin
/// wall, and the search may gate it, which shortens the fill time of the whole by that
/// pocket's alone. (No two gates overlap: the search keeps them a gate's diameter apart.)
fn idle_gates(layout: &MultiGate) -> Option<String> {
    let n = layout.gates.len();
    let idle: Vec<String> = (0..n)
        .filter(|&k| layout.gates[k].volume_share < IDLE_GATE_SHARE)
        .map(|k| {
            format!(
                "gate {} ({:.1} %)",
                k + 1,
                100.0 * layout.gates[k].volume_share
            )
        })
        .collect();
    (!idle.is_empty()).then(|| {
        format!(
            "{} of the layout of {n} gates fill less than {:.0} % of the volume each ({}): such a gate serves a small place the flow reaches late (often a thin wall or a pocket), not the part, yet it may set the layout's value: a thicker wall there may serve better than a gate",
            idle.len(),
            100.0 * IDLE_GATE_SHARE,
            idle.join(", "),
        )
    })
}

fn in_body(domain: &Domain, candidates: &[Source], body: u32) -> Vec<usize> {
    (0..candidates.len())
        .filter(|&i| domain.body[candidates[i].cell as usize] == body)
        .collect()
}

/// Far points taken from each run of the balanced search.
const FAR_POINTS: usize = 6;

/// Rounds of the balanced search whose candidate's run has the candidate's own field
/// marched beside it on an idle thread (kept when that round is the search's last and its
/// candidate the one chosen). On the shared parts every search that proves its gate does so
/// within 4 rounds (1 round on 7 parts, 2 on 3, 3 on 1, 4 on 2), and the others run to
/// the limit of runs (11 to 18 rounds) and choose the best seen, most often not the last:
/// a side march past the first rounds is dropped, and it competes with the run for memory.
/// Beside the first four rounds only rather than every round, paired: the RAM connector
/// cap's `--fill` 0.987 of the wall time and 0.821 of the CPU time, the Watchy top's 0.976
/// and 0.819, the PSU cover's 1.010 and 0.921; the parts of four rounds or fewer as before
/// (docs/performance.md).
const SIDE_MARCH_ROUNDS: usize = 4;

/// How far the balanced search's runs from far points reach, as a multiple of the least
/// worst value known (a first guess of the least bound; the search stays exact whatever it
/// is, and marches a run whole again when the guess was short).
const FAR_REACH: f64 = 1.02;

/// True when the least of the pool's bounds, the candidate the search takes (the lowest
/// index among equals), is the one whole runs give: its bound is exact and every inexact
/// (lower) bound is surely beyond it.
fn bounds_decide(pool: &[usize], bound: &[f64], exact: &[bool]) -> bool {
    let &best = pool
        .iter()
        .min_by(|&&a, &&b| bound[a].total_cmp(&bound[b]).then(a.cmp(&b)))
        .expect("non-empty pool");
    exact[best]
        && pool
            .iter()
            .all(|&i| exact[i] || beyond(bound[i] * (1.0 - 2.4e-7), bound[best]))
}

/// The cell of the largest value, then other local maxima of `t` within 5 % of it and at
/// least a quarter of it away from those already taken, up to `count`.
fn far_points(v: &Voxels, t: &[f64], count: usize) -> Vec<u32> {
    let (top, max) = argmax(t);
    let mut out = vec![top];
    if count > 1 {
        let mut near_max: Vec<u32> = (0..v.len() as u32)
            .filter(|&c| t[c as usize].is_finite() && t[c as usize] >= 0.95 * max)
            .collect();
        near_max.sort_by(|&a, &b| t[b as usize].total_cmp(&t[a as usize]).then(a.cmp(&b)));
        for c in near_max {
            if out.len() == count {
                break;
            }
            let p = v.centre(c);
            if out.iter().all(|&o| v.centre(o).distance(p) >= 0.15 * max) {
                out.push(c);
            }
        }
    }
    out
}

/// One gate of a several-gate layout.
#[derive(Debug, Clone, Serialize)]
pub struct GateShare {
    /// Candidate index.
    pub candidate: usize,
    /// The gate point, mm.
    pub point: [f64; 3],
    /// The body it is on (numbered from 0 in the order of the bodies' first triangles, as
    /// [`BodyGate::body`]).
    pub body: u32,
    /// Share of the reached volume this gate fills first.
    pub volume_share: f64,
    /// Longest flow path inside its share, mm; `None` when the layout minimised the fill
    /// time (its shares are of the fill-time field, and only their time is known).
    pub l_max_mm: Option<f64>,
    /// Fill time of its share, s; `None` when the layout minimised the flow length.
    pub fill_time_s: Option<f64>,
}

impl GateShare {
    /// The value of the objective the layout minimised (mm of L_max or s of fill time, see
    /// [`Objective::value_words`]).
    pub fn value(&self) -> f64 {
        self.l_max_mm.or(self.fill_time_s).unwrap_or(f64::NAN)
    }
}

/// Several gates that together minimise the largest arrival value (a k-centre problem).
#[derive(Debug, Clone, Serialize)]
pub struct MultiGate {
    /// The gates.
    pub gates: Vec<GateShare>,
    /// Longest flow path with all gates open, mm; `None` when the layout minimised the
    /// fill time.
    pub l_max_mm: Option<f64>,
    /// Fill time with all gates open, s; `None` when the layout minimised the flow length.
    pub fill_time_s: Option<f64>,
    /// The estimated fill time with all gates open, s, whichever objective chose the layout
    /// (the latest arrival of one march from every gate at once under the fill's cost, the
    /// time the pictures colour): with the resistance objective it is `fill_time_s`; with
    /// the flow-length objective it is the time of the layout found, which the search did
    /// not minimise. `None` until the fill analysis has marched it.
    pub layout_fill_time_s: Option<f64>,
    /// The fill with all the gates open, as a gate's fill (its `gate`, `body` and
    /// `wall_across_mm` the first gate's): L_max, L/t (each body's over its own nominal
    /// wall), the Eq. 1 pressure, the fill time, the last places to fill and the weld
    /// lines. `None` until the fill analysis has marched it.
    pub fill: Option<GateFill>,
    /// How much shorter the objective is than with the balanced gate (the best single gate
    /// the report gives: the paper gate when no candidate beats it), by the value its fill
    /// reports, %.
    pub improvement_pct: f64,
    /// Smallest volume share over the largest (1: perfectly even).
    pub balance: f64,
    /// Marches it ran, the searches summed (within a search a march from a cell it had
    /// marched from before is not run again; those of a gate examined ahead and dropped,
    /// when the gate before it moved, count: the searches look ahead only on more threads
    /// than [`several_gates`] runs searches, so on two threads there are none).
    pub runs: usize,
    /// The gates (indices into `gates`) without which, each alone, the others reach no cell
    /// later than the layout's value: by the objective they add nothing (see
    /// [`redundant_gates`]); only one of them at a time can go.
    pub redundant: Vec<usize>,
    /// The bodies its gates are on (1 on a part of one body; on a part of several, each
    /// body the candidates lie on gets a gate while there are gates enough).
    pub bodies: usize,
}

impl MultiGate {
    /// The value of the objective the layout minimised (see [`GateShare::value`]).
    pub fn value(&self) -> f64 {
        self.l_max_mm.or(self.fill_time_s).unwrap_or(f64::NAN)
    }

    /// How it compares with the best single gate, in words: how much shorter its value is,
    /// or, over several bodies, that a single gate feeds one body only (its value is then
    /// not the measure of what the gates bring).
    pub fn against_single_words(&self) -> String {
        match self.bodies {
            0 | 1 => format!(
                "{:.1} % shorter than with the balanced gate",
                self.improvement_pct
            ),
            n => format!(
                "on {n} bodies, each fed by its own gates, where the balanced gate alone feeds one"
            ),
        }
    }

    /// What its balance is, in words: the smallest share over the largest, within a body
    /// when the layout is on several.
    pub fn balance_words(&self) -> &'static str {
        match self.bodies {
            0 | 1 => "smallest share / largest",
            _ => "smallest share / largest of the gates of one body",
        }
    }

    /// Whether its gates leave part of the part unreached (a body without a gate of the
    /// layout), once its fill is made.
    pub fn leaves_a_body(&self) -> bool {
        self.fill.as_ref().is_some_and(|f| f.reached_share < 0.9995)
    }
}

/// The searches of a several-gate layout, each from its own start, that run side by side
/// (see [`several_gates`]).
const SEVERAL_STARTS: usize = 3;

/// A layout of several gates that shortens the objective by less than this against the
/// best single gate is warned about: the extra gates buy little by this measure.
pub const SMALL_LAYOUT_GAIN_PCT: f64 = 10.0;

/// Places `k` gates among `candidates` (same body as `first`, which starts the layout):
/// farthest-point seeding (each new gate is the candidate nearest, along the flow, to the
/// point the current gates reach last; a 2-approximation of the k-centre optimum), then
/// rounds of local improvement in which each gate moves to the centre of its own share (the
/// candidate nearest to both ends of the share's longest path), kept while the overall
/// worst value does not grow and the shares' worst values fall. The local improvement
/// stops at a layout no single move betters, which depends on where it started (two gates on the `plate` sample from its
/// middle: L_max 54.9 mm, from a corner: 41.4 mm), so the search runs three times, side by
/// side: from `first`; from the candidate nearest the place `first` reaches last (seeded
/// from there); and from the layout of the body's cells split into `k` clusters in space
/// ([`clustered_layout`]), improved by the same moves. The layout of the lowest worst value
/// is kept (the earlier on a tie). The third start finds what the two others miss on a
/// long box: from a point and its far corner, the moves bring both gates to the middle (a
/// corner's share is a triangle whose longest path is the diagonal), where the clusters
/// split the box across its length (two gates on the `tray` sample: L_max 57.7 mm from
/// the first two starts, 47.0 mm from the third).
///
/// **No two gates overlap**: a candidate nearer than `min_distance_mm` (a gate's diameter, in
/// the fill analysis) to a gate of the layout is neither a seed nor a move's place. (Without
/// the rule, a seed or a move could land a gate a fraction of a millimetre from another, the
/// two discs one gate in the mould: on 10 of 102 layouts of the shared parts.)
pub fn several_gates(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: usize,
    k: usize,
    min_distance_mm: f64,
) -> Option<MultiGate> {
    several_gates_from(
        domain,
        candidates,
        objective,
        first,
        k,
        min_distance_mm,
        None,
    )
}

/// [`several_gates`] with, when the caller has it, the field of `candidates[first]` for the
/// objective already marched (the fill analysis has it from the balanced gate's fill); it
/// is then not marched again, nor counted in the runs (the second start is found from it).
pub fn several_gates_from(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: usize,
    k: usize,
    min_distance_mm: f64,
    start: Option<&Field>,
) -> Option<MultiGate> {
    let _arrays = march::KeepArrays::new();
    let v = &domain.voxels;
    let marched = start.is_none();
    let field;
    let start = match start {
        Some(f) => f,
        None => {
            field = march(v, &[candidates[first]], domain.cost(objective));
            &field
        }
    };
    // The second start: the candidate nearest (in a straight line) to the place the first
    // gate reaches last.
    let far = v.centre(argmax(&start.t).0);
    let body = domain.body[candidates[first].cell as usize];
    let second =
        nearest_of(candidates, in_body(domain, candidates, body), far).filter(|&i| i != first);
    let ask = Ask {
        objective,
        k,
        min_distance_mm,
    };
    // The three starts' searches run side by side; each looks ahead (examines the next
    // gate beside the present one, work that is dropped when the present gate moves) only
    // when there are more threads than searches. On fewer, the searches already keep every
    // thread busy and the work ahead only adds to it: on two threads, the housing's three
    // gates took 0.92 of the wall time without it, and four gates 0.91 (the same layouts).
    let look_ahead = rayon::current_num_threads() > SEVERAL_STARTS;
    let search = |from: usize, given: Option<&Field>| {
        several_gates_search(domain, candidates, ask, from, given, look_ahead, None)
    };
    // The third start: the layout of the body's cells split into k clusters.
    let clustered = || {
        let pool = in_body(domain, candidates, body);
        let layout = clustered_layout(domain, candidates, &pool, body, k, min_distance_mm)?;
        several_gates_search(
            domain,
            candidates,
            ask,
            layout[0],
            None,
            look_ahead,
            Some(&layout),
        )
    };
    let (a, (b, c)) = rayon::join(
        || search(first, Some(start)),
        || rayon::join(|| second.and_then(|second| search(second, None)), clustered),
    );
    let mut a = a?;
    // A march run for the start counts once, whichever layout is kept.
    let runs = a.runs
        + b.as_ref().map_or(0, |b| b.runs)
        + c.as_ref().map_or(0, |c| c.runs)
        + usize::from(marched);
    for other in [b, c].into_iter().flatten() {
        if other.value() < a.value() {
            a = other;
        }
    }
    a.runs = runs;
    Some(a)
}

/// A layout of `k` gates from the cells of `body` split into `k` clusters of nearby cells
/// (Lloyd's k-means in space, from farthest-point seeds): for each cluster's mean, the
/// nearest candidate of `pool` at least `min_distance_mm` from those already taken. On a
/// long plate it splits the plate across its length, where the searches from a point and
/// its farthest place start from opposite corners.
fn clustered_layout(
    domain: &Domain,
    candidates: &[Source],
    pool: &[usize],
    body: u32,
    k: usize,
    min_distance_mm: f64,
) -> Option<Vec<usize>> {
    let v = &domain.voxels;
    let cells: Vec<DVec3> = (0..v.len() as u32)
        .filter(|&c| domain.body[c as usize] == body)
        .map(|c| v.centre(c))
        .collect();
    if cells.len() < k || pool.len() < k {
        return None;
    }
    let mean = cells.iter().copied().sum::<DVec3>() / cells.len() as f64;
    // The cell farthest from every centre so far (the last of equals, as `max_by` gives),
    // each cell's squared distance to its nearest centre kept as the centres are added.
    let farthest = |nearest_d2: &[f64]| {
        let (i, _) = nearest_d2
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .expect("cells");
        cells[i]
    };
    let mut nearest_d2: Vec<f64> = cells
        .par_iter()
        .map(|p| mean.distance_squared(*p))
        .collect();
    let mut centres = vec![farthest(&nearest_d2)];
    nearest_d2.fill(f64::INFINITY);
    while centres.len() < k {
        if v.stopped() {
            return None;
        }
        let newest = *centres.last().expect("a centre");
        nearest_d2
            .par_iter_mut()
            .zip(&cells)
            .for_each(|(d, p)| *d = d.min(newest.distance_squared(*p)));
        centres.push(farthest(&nearest_d2));
    }
    let mut label = vec![0usize; cells.len()];
    for _ in 0..30 {
        if v.stopped() {
            return None;
        }
        let changed = label
            .par_iter_mut()
            .zip(&cells)
            .map(|(l, p)| {
                let nearest = (0..k)
                    .min_by(|&a, &b| {
                        centres[a]
                            .distance_squared(*p)
                            .total_cmp(&centres[b].distance_squared(*p))
                    })
                    .expect("k > 0");
                let changed = nearest != *l;
                *l = nearest;
                changed
            })
            .reduce(|| false, |a, b| a | b);
        let mut sums = vec![(DVec3::ZERO, 0usize); k];
        for (i, p) in cells.iter().enumerate() {
            sums[label[i]].0 += *p;
            sums[label[i]].1 += 1;
        }
        for (c, (sum, n)) in centres.iter_mut().zip(&sums) {
            if *n > 0 {
                *c = *sum / *n as f64;
            }
        }
        if !changed {
            break;
        }
    }
    let mut layout: Vec<usize> = Vec::with_capacity(k);
    for c in &centres {
        let &best = pool
            .iter()
            .filter(|&&i| {
                !layout.contains(&i)
                    && layout.iter().all(|&j| {
                        candidates[j].point.distance(candidates[i].point) >= min_distance_mm
                    })
            })
            .min_by(|&&a, &&b| {
                candidates[a]
                    .point
                    .distance(*c)
                    .total_cmp(&candidates[b].point.distance(*c))
                    .then(a.cmp(&b))
            })?;
        layout.push(best);
    }
    Some(layout)
}

/// What one several-gate search is asked for: the objective, how many gates, and how near
/// two gates may be.
#[derive(Debug, Clone, Copy)]
struct Ask {
    objective: Objective,
    k: usize,
    min_distance_mm: f64,
}

/// [`several_gates_from`]; `look_ahead`: whether the next gate is examined at the same time as
/// the present one (the same answer either way; the tests compare the two).
fn several_gates_search(
    domain: &Domain,
    candidates: &[Source],
    ask: Ask,
    first: usize,
    start: Option<&Field>,
    look_ahead: bool,
    seeded: Option<&[usize]>,
) -> Option<MultiGate> {
    let Ask {
        objective,
        k,
        min_distance_mm,
    } = ask;
    let cost = domain.cost(objective);
    let v = &domain.voxels;
    let body = domain.body[candidates[first].cell as usize];
    let pool = in_body(domain, candidates, body);
    if k == 0 || pool.len() < k {
        return None;
    }
    let mut runs = 0;
    let mut chosen = seeded.map_or_else(|| vec![first], <[usize]>::to_vec);
    let mut field = match start.filter(|_| chosen.len() == 1) {
        Some(f) => f.clone(),
        None => {
            runs += 1;
            let sources: Vec<Source> = chosen.iter().map(|&i| candidates[i]).collect();
            march(v, &sources, cost)
        }
    };
    let from_centre = CentreMarches::new(v, cost);
    // Whether candidate `i` is at least `min_distance_mm` from every gate of `gates` but the
    // one at `except` (whose place it would take).
    let apart = |i: usize, gates: &[usize], except: Option<usize>| {
        let p = candidates[i].point;
        gates
            .iter()
            .enumerate()
            .all(|(g, &j)| Some(g) == except || candidates[j].point.distance(p) >= min_distance_mm)
    };
    // Which cells hold a candidate the search may still take: the nearest of them to a far
    // point is needed, not the whole field from it.
    let mut open = vec![false; v.len()];
    // Stopped, the search gives up: each march it would start would stop at once, but
    // only after making its arrays of every cell.
    while chosen.len() < k {
        if v.stopped() {
            return None;
        }
        for &i in &pool {
            open[candidates[i].cell as usize] = false;
        }
        let takeable: Vec<usize> = pool
            .iter()
            .copied()
            .filter(|&i| !chosen.contains(&i) && apart(i, &chosen, None))
            .collect();
        for &i in &takeable {
            open[candidates[i].cell as usize] = true;
        }
        let (far, _) = argmax(&field.t);
        let nearest = |f: &Field| {
            takeable
                .iter()
                .map(|&i| f.t[candidates[i].cell as usize])
                .fold(f64::INFINITY, f64::min)
        };
        let mut b = f64::INFINITY;
        let (from_far, _) = from_centre.of(
            far,
            |f, reach| beyond(reach, nearest(f)),
            |c, t| {
                if open[c as usize] {
                    b = b.min(t);
                }
                beyond(t, b)
            },
        );
        let &next = takeable.iter().min_by(|&&a, &&b| {
            from_far.t[candidates[a].cell as usize]
                .total_cmp(&from_far.t[candidates[b].cell as usize])
                .then(a.cmp(&b))
        })?;
        chosen.push(next);
        let sources: Vec<Source> = chosen.iter().map(|&i| candidates[i]).collect();
        field = march(v, &sources, cost);
        runs += 1;
    }
    // Local improvement: each gate to the centre of its share, kept while the overall worst
    // value falls.
    let mut worst = argmax(&field.t).1;
    let trial_runs = std::sync::atomic::AtomicUsize::new(0);
    // What examining gate g finds, from the layout `chosen`, its field and its worst value:
    // the move to the centre of its share, if there is one to try, with the trial's field.
    let examine = |g: usize, field: &Field, chosen: &[usize], worst: f64| -> Examined {
        let share: Vec<u32> = (0..v.len() as u32)
            .filter(|&c| field.source[c as usize] == g as u32)
            .collect();
        if share.is_empty() {
            return Examined::Empty;
        }
        // The share's two ends: its cell farthest from the gate, x1, and its cell farthest
        // from x1, x2. The candidate nearest to both (least of the larger distance) is the
        // centre of the share's longest path.
        let x1 = share
            .iter()
            .copied()
            .max_by(|&a, &b| {
                field.t[a as usize]
                    .total_cmp(&field.t[b as usize])
                    .then(b.cmp(&a))
            })
            .expect("non-empty");
        // From x1, every cell of the share is needed (for x2); the march stops when the
        // last of them is accepted.
        let mut in_share = vec![false; v.len()];
        for &c in &share {
            in_share[c as usize] = true;
        }
        let mut left = share.len();
        let (from_x1, reach_x1) = from_centre.of(
            x1,
            |f, _| share.iter().all(|&c| f.t[c as usize].is_finite()),
            |c, _| {
                if in_share[c as usize] {
                    left -= 1;
                }
                left == 0
            },
        );
        let x2 = share
            .iter()
            .copied()
            .filter(|&c| from_x1.t[c as usize].is_finite())
            .max_by(|&a, &b| {
                from_x1.t[a as usize]
                    .total_cmp(&from_x1.t[b as usize])
                    .then(b.cmp(&a))
            })
            .unwrap_or(x1);
        // From x2, only the cells up to the best candidate's value are needed: a candidate
        // beyond it is farther from x2, so worse. A candidate the march from x1 did not
        // reach is at least that march's reach from x1; when the best value found is below
        // it (with the margin of `beyond`), the choice is the one the whole fields give,
        // else the whole field from x1 decides.
        let eligible: Vec<usize> = pool
            .iter()
            .copied()
            .filter(|&i| i == chosen[g] || (!chosen.contains(&i) && apart(i, chosen, Some(g))))
            .collect();
        let mut open = vec![false; v.len()];
        for &i in &eligible {
            open[candidates[i].cell as usize] = true;
        }
        let choose = |from_x1: &Field| {
            let best_of = |f: &Field| {
                eligible
                    .iter()
                    .map(|&i| {
                        let c = candidates[i].cell as usize;
                        from_x1.t[c].max(f.t[c])
                    })
                    .fold(f64::INFINITY, f64::min)
            };
            let mut b = f64::INFINITY;
            let (from_x2, _) = from_centre.of(
                x2,
                |f, reach| beyond(reach, best_of(f)),
                |c, t| {
                    if open[c as usize] {
                        b = b.min(t.max(from_x1.t[c as usize]));
                    }
                    beyond(t, b)
                },
            );
            let f = |i: usize| {
                let c = candidates[i].cell as usize;
                from_x1.t[c].max(from_x2.t[c])
            };
            let &best = eligible
                .iter()
                .min_by(|&&a, &&b| f(a).total_cmp(&f(b)).then(a.cmp(&b)))
                .expect("non-empty");
            (best, f(best))
        };
        let (mut try_c, value) = choose(&from_x1);
        if reach_x1.is_finite() && !beyond(reach_x1, value) {
            let (whole, _) = from_centre.of(x1, |_, reach| reach.is_infinite(), |_, _| false);
            try_c = choose(&whole).0;
        }
        if try_c == chosen[g] {
            return Examined::Stays;
        }
        let mut trial = chosen.to_vec();
        trial[g] = try_c;
        let sources: Vec<Source> = trial.iter().map(|&i| candidates[i]).collect();
        // The move is kept only if the overall worst value does not grow: once the march
        // accepts a cell beyond the present worst, the move is refused, and the rest of
        // the field is not needed.
        let limit = worst + 1e-9;
        let (trial_field, reach) = march_until(v, &sources, cost, |_, t| t > limit);
        trial_runs.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if reach.is_finite() {
            return Examined::Refused;
        }
        Examined::Tries {
            trial,
            field: trial_field,
        }
    };
    // Moves kept so far, and for each gate the count at which it was last examined without
    // moving: while no move is kept, the same gate meets the same field and layout again
    // and would stay, so its three marches are not run again.
    let mut moves = 0usize;
    let mut stayed_at: Vec<Option<usize>> = vec![None; k];
    // Rounds of examining every gate in order, at most `ROUNDS`, while a round keeps a
    // move. The gate examined at or after gate `g` of round `round` (`improved`: a move was
    // kept earlier in that round), as (round, gate, improved); `None` when the search ends.
    const ROUNDS: usize = 8;
    let following = |mut round: usize,
                     mut g: usize,
                     mut improved: bool,
                     moves: usize,
                     stayed_at: &[Option<usize>]| loop {
        if let Some(x) = (g..k).find(|&x| stayed_at[x] != Some(moves)) {
            return Some((round, x, improved));
        }
        if !improved || round + 1 >= ROUNDS {
            return None;
        }
        (round, g, improved) = (round + 1, 0, false);
    };
    // The examination that comes next when the gate examined now keeps its place, made at
    // the same time from the same layout (round, gate, finding): it stands when it is the
    // next one indeed and no move was kept in between (the layout is then unchanged), and
    // is dropped otherwise (its marches from the ends of its share stay kept). The answer
    // is that of one gate after the other; the runs count every march run.
    let mut ahead: Option<(usize, usize, Examined)> = None;
    let mut at = following(0, 0, false, moves, &stayed_at);
    while let Some((round, g, mut improved)) = at {
        if v.stopped() {
            return None;
        }
        let found = match ahead.take() {
            Some((r, h, found)) if (r, h) == (round, g) => found,
            _ => {
                let mut stays = stayed_at.clone();
                stays[g] = Some(moves);
                match following(round, g + 1, improved, moves, &stays).filter(|_| look_ahead) {
                    Some((r, h, _)) => {
                        let (a, b) = rayon::join(
                            || examine(g, &field, &chosen, worst),
                            || examine(h, &field, &chosen, worst),
                        );
                        ahead = Some((r, h, b));
                        a
                    }
                    None => examine(g, &field, &chosen, worst),
                }
            }
        };
        let kept = match found {
            Examined::Empty => false,
            Examined::Stays | Examined::Refused => {
                stayed_at[g] = Some(moves);
                false
            }
            Examined::Tries {
                trial,
                field: trial_field,
            } => {
                let trial_worst = argmax(&trial_field.t).1;
                // Keep the move when the overall worst value does not grow and the sum of
                // the shares' worst values falls (a gate may improve its share while
                // another share still sets the overall worst).
                if trial_worst <= worst + 1e-9
                    && share_sum(&trial_field, k) < share_sum(&field, k) - 1e-9
                {
                    worst = trial_worst;
                    chosen = trial;
                    field = trial_field;
                    moves += 1;
                    true
                } else {
                    stayed_at[g] = Some(moves);
                    false
                }
            }
        };
        if kept {
            improved = true;
            ahead = None;
        }
        at = following(round, g + 1, improved, moves, &stayed_at);
    }
    let runs = runs + from_centre.runs() + trial_runs.into_inner();
    Some(layout_of(domain, candidates, &chosen, &field, worst, runs))
}

/// The layout of the gates `chosen` (indices into `candidates`) from their field: each
/// gate's share of the reached volume (its cells' share of each body it reaches, weighed by
/// that body's volume, so that a gate that fills a body alone has that body's share) and
/// its longest value there, the balance of the shares within each body, the layout's value
/// `worst` (in the objective's units, under `l_max_mm` until the caller names it) and the
/// marches `runs` it took.
fn layout_of(
    domain: &Domain,
    candidates: &[Source],
    chosen: &[usize],
    field: &Field,
    worst: f64,
    runs: usize,
) -> MultiGate {
    let bodies = domain.bodies.max(1);
    let (volumes, l_max) = volumes_of(domain, field, chosen.len());
    let body_of = |i: usize| domain.body[candidates[i].cell as usize] as usize;
    let reached = volumes.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    let gates: Vec<GateShare> = chosen
        .iter()
        .enumerate()
        .map(|(g, &i)| GateShare {
            candidate: i,
            point: candidates[i].point.to_array(),
            body: body_of(i) as u32,
            volume_share: volumes[g] / reached,
            l_max_mm: Some(l_max[g]),
            fill_time_s: None,
        })
        .collect();
    // The balance within each body of two gates or more (gates of different bodies do not
    // share a volume), the least of them; 1 when no body has two.
    let balance = (0..bodies)
        .filter_map(|b| {
            let shares: Vec<f64> = (0..chosen.len())
                .filter(|&g| body_of(chosen[g]) == b)
                .map(|g| volumes[g])
                .collect();
            (shares.len() > 1).then(|| {
                shares.iter().copied().fold(f64::INFINITY, f64::min)
                    / shares
                        .iter()
                        .copied()
                        .fold(0.0, f64::max)
                        .max(f64::MIN_POSITIVE)
            })
        })
        .fold(1.0, f64::min);
    let mut on: Vec<usize> = chosen.iter().map(|&i| body_of(i)).collect();
    on.sort_unstable();
    on.dedup();
    MultiGate {
        gates,
        l_max_mm: Some(worst),
        fill_time_s: None,
        layout_fill_time_s: None,
        fill: None,
        improvement_pct: 0.0,
        balance,
        runs,
        redundant: Vec::new(),
        bodies: on.len(),
    }
}

/// [`several_gates_from`] over the bodies of a part: on a part of one body (or whose
/// candidates lie on one) it is that search. Otherwise each body the candidates lie on gets
/// a gate, the start's body first and then the others by volume, as far as `k` goes (each
/// body is moulded from its own gates: no melt crosses between bodies); each body's gates
/// are found by [`several_gates_from`] on that body alone, its first from `first` on the
/// start's body and elsewhere from the candidate nearest the centre of the body's cells;
/// each gate beyond one a body goes, one at a time, to the body whose layout has the worst
/// value then. The layout's shares and values are those of one march from all its gates.
/// `None` when the bodies' candidates cannot take `k` gates.
pub fn several_gates_over_bodies(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: usize,
    k: usize,
    min_distance_mm: f64,
    start: Option<&Field>,
) -> Option<MultiGate> {
    let first_body = domain.body[candidates[first].cell as usize];
    let mut bodies: Vec<u32> = candidates
        .iter()
        .map(|c| domain.body[c.cell as usize])
        .filter(|&b| b != first_body)
        .collect();
    bodies.sort_unstable();
    bodies.dedup();
    if bodies.is_empty() || k < 2 {
        return several_gates_from(
            domain,
            candidates,
            objective,
            first,
            k,
            min_distance_mm,
            start,
        );
    }
    let volume = |b: u32| domain.body_volume_mm3[b as usize];
    bodies.sort_by(|&a, &b| volume(b).total_cmp(&volume(a)).then(a.cmp(&b)));
    bodies.insert(0, first_body);
    bodies.truncate(k);
    let v = &domain.voxels;
    let firsts: Vec<usize> = bodies
        .iter()
        .map(|&b| {
            if b == first_body {
                return first;
            }
            let (sum, count) = (0..v.len() as u32)
                .filter(|&c| domain.body[c as usize] == b)
                .fold((DVec3::ZERO, 0usize), |(sum, n), c| {
                    (sum + v.centre(c), n + 1)
                });
            let centre = sum / count.max(1) as f64;
            nearest_of(candidates, in_body(domain, candidates, b), centre)
                .expect("a body listed holds a candidate")
        })
        .collect();
    let search = |i: usize, count: usize| {
        several_gates_from(
            domain,
            candidates,
            objective,
            firsts[i],
            count,
            min_distance_mm,
            start.filter(|_| i == 0),
        )
    };
    let mut layouts: Vec<Option<MultiGate>> = (0..bodies.len())
        .into_par_iter()
        .map(|i| search(i, 1))
        .collect();
    let mut full: Vec<bool> = layouts.iter().map(Option::is_none).collect();
    let mut runs = 0;
    for _ in bodies.len()..k {
        let worst = (0..bodies.len()).filter(|&i| !full[i]).max_by(|&a, &b| {
            let value = |i: usize| layouts[i].as_ref().map_or(f64::NAN, MultiGate::value);
            value(a).total_cmp(&value(b)).then(b.cmp(&a))
        })?;
        let count = layouts[worst].as_ref().map_or(0, |l| l.gates.len());
        match search(worst, count + 1) {
            Some(layout) => {
                runs += layouts[worst].as_ref().map_or(0, |l| l.runs);
                layouts[worst] = Some(layout);
            }
            None => full[worst] = true,
        }
        if v.stopped() {
            return None;
        }
    }
    let chosen: Vec<usize> = layouts
        .iter()
        .flatten()
        .flat_map(|l| l.gates.iter().map(|g| g.candidate))
        .collect();
    if chosen.len() < k {
        return None;
    }
    runs += layouts.iter().flatten().map(|l| l.runs).sum::<usize>() + 1;
    let sources: Vec<Source> = chosen.iter().map(|&i| candidates[i]).collect();
    let field = march(v, &sources, domain.cost(objective));
    let worst = argmax(&field.t).1;
    Some(layout_of(domain, candidates, &chosen, &field, worst, runs))
}

/// The gates of `layout` (found among `candidates`, its value in the field's units) that
/// add nothing to its objective: without each alone, the march of the others reaches no
/// cell beyond the layout's value by more than `tolerance`. One march per
/// gate, each stopped at the first cell beyond, so a gate that is needed costs little.
pub fn redundant_gates(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    layout: &MultiGate,
    tolerance: f64,
) -> Vec<usize> {
    let n = layout.gates.len();
    if n < 2 {
        return Vec::new();
    }
    let limit = layout.value() + tolerance;
    let cost = domain.cost(objective);
    // On a part of several bodies a gate may be its body's only one: the others then
    // reach fewer cells, and it is needed however late they reach the rest.
    let source = |o: usize| candidates[layout.gates[o].candidate];
    let reached = |f: &Field| f.t.iter().filter(|t| t.is_finite()).count();
    let all = (domain.bodies > 1).then(|| {
        reached(&march(
            &domain.voxels,
            &(0..n).map(source).collect::<Vec<_>>(),
            cost,
        ))
    });
    (0..n)
        .into_par_iter()
        .filter(|&g| {
            // Stopped, no gate is named.
            if domain.voxels.stopped() {
                return false;
            }
            let others: Vec<Source> = (0..n).filter(|&o| o != g).map(source).collect();
            let (field, reach) = march_until(&domain.voxels, &others, cost, |_, t| t > limit);
            reach.is_infinite() && all.is_none_or(|all| reached(&field) >= all)
        })
        .collect()
}

/// The marches of a search from cell centres, kept by cell: such a march depends on its
/// cell alone, so when a gate's share keeps its ends from one examination to the next (the
/// move of another gate changed little of it), its two marches are not run again. A march
/// may have stopped early (its reach is then the last value it accepted); a kept one serves
/// when it is enough for the new use. Fields are dropped oldest first past
/// [`CentreMarches::BYTES`].
struct CentreMarches<'a> {
    voxels: &'a Voxels,
    cost: Option<&'a [f32]>,
    kept: std::sync::Mutex<std::collections::VecDeque<Kept>>,
    runs: std::sync::atomic::AtomicUsize,
    capacity: usize,
}

/// A kept march: its cell, its field and its reach (infinite for a whole field).
struct Kept {
    cell: u32,
    field: std::sync::Arc<Field>,
    reach: f64,
}

impl<'a> CentreMarches<'a> {
    /// Bytes of fields kept at most (12 bytes a cell each): the three starts' searches run
    /// side by side, 384 MiB in all.
    const BYTES: usize = 128 << 20;

    fn new(voxels: &'a Voxels, cost: Option<&'a [f32]>) -> Self {
        CentreMarches {
            voxels,
            cost,
            kept: Default::default(),
            runs: Default::default(),
            capacity: (Self::BYTES / (12 * voxels.len().max(1))).max(2),
        }
    }

    /// The field from the centre of cell `c` and its reach: a kept whole one, or a kept one
    /// for which `enough(field, reach)` holds, or marched until `stop` (see [`march_until`]) and kept in place of any other
    /// kept from `c`. `stop` must not end the march before `enough` holds.
    fn of(
        &self,
        c: u32,
        enough: impl Fn(&Field, f64) -> bool,
        stop: impl FnMut(u32, f64) -> bool,
    ) -> (std::sync::Arc<Field>, f64) {
        let lock = || self.kept.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(k) = lock()
            .iter()
            .find(|k| k.cell == c && (k.reach.is_infinite() || enough(&k.field, k.reach)))
        {
            return (k.field.clone(), k.reach);
        }
        let source = Source {
            point: self.voxels.centre(c),
            cell: c,
        };
        let (field, reach) = march_until(self.voxels, &[source], self.cost, stop);
        let field = std::sync::Arc::new(field);
        self.runs.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let mut kept = lock();
        kept.retain(|k| k.cell != c || k.reach > reach);
        if kept.len() >= self.capacity {
            kept.pop_front();
        }
        kept.push_back(Kept {
            cell: c,
            field: field.clone(),
            reach,
        });
        (field, reach)
    }

    /// Marches run.
    fn runs(&self) -> usize {
        self.runs.load(std::sync::atomic::Ordering::Relaxed)
    }
}

/// What examining one gate of a several-gate layout found.
enum Examined {
    /// Its share is empty.
    Empty,
    /// It stays: the centre of its share is where it is.
    Stays,
    /// It would move: the layout with the move and its field (one march of the layout, with
    /// those from the share's ends).
    Tries { trial: Vec<usize>, field: Field },
    /// It would move, but the layout with the move reaches beyond the present worst value,
    /// so the move is refused (its march stopped there).
    Refused,
}

/// True when `t` is surely beyond `b` for the searches' early stops: by more than the f32
/// rounding of the march's queue keys (a relative 2.4e-7), so that every cell of value up to
/// `b` was accepted before a cell of value `t`.
fn beyond(t: f64, b: f64) -> bool {
    t > b + 1e-6 * b.abs() + 1e-9
}

/// The sum over the `k` shares of a multi-source field of their largest values.
fn share_sum(field: &Field, k: usize) -> f64 {
    let mut worst = vec![0.0f64; k];
    for (t, &s) in field.t.iter().zip(&field.source) {
        if t.is_finite() && (s as usize) < k {
            worst[s as usize] = worst[s as usize].max(*t);
        }
    }
    worst.iter().sum()
}

/// Seconds per stage of the fill analysis.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct FlowTimes {
    /// Voxelising and the cost fields (without the wall measurement).
    pub voxels_s: f64,
    /// Measuring the wall thickness (one ray per surface cell). With the flow-length
    /// objective the walls are measured beside the paper gate's flow length and the
    /// balanced search, so this is their own time, shared with those; `paper_s` and
    /// `balanced_s` count only what those took beyond it, and the three add up to the
    /// stage's wall time.
    pub wall_s: f64,
    /// Building the ray-casting tree the wall is measured with (set by the caller, which
    /// may share the tree with other analyses; 0 when not measured).
    pub tree_s: f64,
    /// Of `voxels_s`, the time the bodies and cells took beside the search for the gate
    /// (when the caller made them there: [`prepare`]); 0 when made in the fill's own stage.
    pub cells_beside_s: f64,
    /// Fields from the paper gate: its flow length, fill order and pressure (made beside
    /// the walls and the search, see `wall_s`).
    pub paper_s: f64,
    /// Balanced-gate search and its fields, and the paper gate's summary. With several
    /// gates or the suitability map, the balanced gate's fill is made beside them and
    /// counts here only where it made that stage longer.
    pub balanced_s: f64,
    /// Several gates.
    pub several_s: f64,
    /// The designer's gates (`gate_at`).
    pub placed_s: f64,
    /// The gate-suitability map, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub suitability_s: Option<f64>,
}

/// Timer helper.
pub(crate) fn seconds(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

/// Which gate is the answer when the fill is analysed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Strategy {
    /// The paper's gate (nearest the centre of mass).
    #[default]
    Paper,
    /// The qualifying candidate that minimises the objective.
    Balanced,
}

/// Options of [`analyse`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FillOptions {
    /// Voxel resolution.
    pub flow: FlowOptions,
    /// Which gate is the answer.
    pub strategy: Strategy,
    /// What the balanced gate and several gates minimise.
    pub objective: Objective,
    /// Number of gates; 1 is the single-gate analysis.
    pub gates: usize,
    /// What pictures of the fill are coloured by (read by the front ends through
    /// [`FillAnalysis::field`]; default the fill time).
    pub colour_by: ColourBy,
    /// Also score every qualifying node as a gate ([`suitability`]). Default false.
    pub suitability: bool,
    /// Gates placed by the designer (surface points, mm), filled together as one layout
    /// ([`FillAnalysis::placed`]); when given, the pictured field is theirs. Default none.
    pub placed: Vec<DVec3>,
}

/// The fill from the gates the designer placed, open together.
#[derive(Debug, Clone, Serialize)]
pub struct PlacedFill {
    /// The layout's fill: L_max, Eq. 1 pressure, L/t, last places to fill, weld lines.
    pub fill: GateFill,
    /// Each gate's share of the reached volume and its L_max inside it, in the order given.
    pub shares: Vec<GateShare>,
    /// Wall across the surface at each gate, mm (as [`GateFill::wall_across_mm`]).
    pub wall_across_mm: Vec<f64>,
}

/// The balanced gate and its fill.
#[derive(Debug, Clone, Serialize)]
pub struct BalancedFill {
    /// Its fill.
    pub fill: GateFill,
    /// The search.
    pub search: Balanced,
    /// Reduction of the objective from the paper gate, percent (>= 0).
    pub improvement_pct: f64,
    /// True when no candidate beats the paper gate by more than the discretisation, so the
    /// balanced gate is the paper gate.
    pub is_paper_gate: bool,
}

/// Where the wall thickness of the cells came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WallSource {
    /// Per-triangle wall thickness measured on the mesh.
    Measured,
    /// A uniform wall, estimated as 2 V / A (exact for a thin closed plate).
    VolumeOverArea,
    /// A uniform wall of a hundredth of the part's diagonal: the mesh encloses no volume
    /// (an open surface, a sheet), so neither a measure nor 2 V / A gives one.
    DiagonalShare,
}

impl WallSource {
    /// The source in words, as the summary and the page give it after the nominal wall.
    pub fn words(self) -> &'static str {
        match self {
            WallSource::Measured => "measured",
            WallSource::VolumeOverArea => "2V/A estimate",
            WallSource::DiagonalShare => {
                "a hundredth of the part's diagonal: the mesh encloses no volume"
            }
        }
    }
}

/// Everything the fill analysis found.
#[derive(Debug, Clone, Serialize)]
pub struct FillAnalysis {
    /// Cell side, mm.
    pub cell_mm: f64,
    /// Solid cells.
    pub cells: usize,
    /// Bodies of the mesh (connected sets of triangles, [`Bodies`]), stray ones not counted.
    pub bodies: usize,
    /// Stray bodies left out: area below [`STRAY_BODY_AREA_SHARE`] of the part's (loose
    /// facets, zero-area slivers).
    pub stray_bodies: usize,
    /// With several bodies, a gate for each (a gate fills only its own body).
    pub body_gates: Vec<BodyGate>,
    /// Nominal wall H_ref, mm.
    pub nominal_wall_mm: f64,
    /// Where the cell walls came from.
    pub wall_source: WallSource,
    /// The flow-cell walls of the analysis, one sample per surface cell (measured with
    /// [`Walls::Measure`] or read from [`Walls::Given`]).
    pub wall: Option<WallSummary>,
    /// What the balanced gate minimises.
    pub objective: Objective,
    /// Which gate is the answer.
    pub strategy: Strategy,
    /// Eq. 1 pressure per mm of path at the nominal wall, MPa/mm.
    pub pressure_mpa_per_mm: f64,
    /// Fill from the paper gate (the answer of `locate`: grid or aesthetic gate).
    pub paper: Option<GateFill>,
    /// Fill from the balanced gate.
    pub balanced: Option<BalancedFill>,
    /// Several gates, when more than one was asked for.
    pub several: Option<MultiGate>,
    /// The fill from the designer's gates ([`FillOptions::placed`]); the report shows it
    /// beside the judgement of those gates, not here.
    #[serde(skip)]
    pub placed: Option<PlacedFill>,
    /// The gate-suitability map of the qualifying nodes, when asked for
    /// ([`FillOptions::suitability`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub suitability: Option<Suitability>,
    /// Warnings of the fill analysis.
    pub warnings: Vec<String>,
    /// Seconds per stage.
    pub times: FlowTimes,
    /// The answer's fields per mesh vertex, for pictures (see [`FillAnalysis::field`]); with
    /// several gates, the flow length and fill time of all of them together.
    #[serde(skip)]
    pub per_vertex: VertexFields,
    /// The same field on the cells, in real units (NaN where unreached), with their lookup
    /// by position: what the pictures draw ([`crate::display`]); `None` when the pictures
    /// show the height along D.
    #[serde(skip)]
    pub field_cells: Option<std::sync::Arc<crate::display::CellField>>,
    /// The answer's gate point.
    #[serde(skip)]
    pub answer: Option<DVec3>,
}

/// Why the fill analysis could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FillError {
    /// The analysis found no gate to start from.
    #[error("no gate to fill from: {0}")]
    NoGate(String),
    /// No solid cell near the gate.
    #[error("the gate at ({0:.3}, {1:.3}, {2:.3}) is not on the voxelised part: the triangles do not enclose a solid there (an open, self-intersecting or random surface), so the fill cannot start")]
    GateOffPart(f64, f64, f64),
    /// No layout of that many gates, a gate's diameter apart, among the candidates.
    #[error(
        "{asked} gates asked for, but the search found no layout of that many gates at least a gate's diameter apart among the {available} qualifying candidates that feed the gate's body"
    )]
    TooFewCandidates {
        /// Gates asked for.
        asked: usize,
        /// Candidates available.
        available: usize,
    },
    /// Bad option: the option at fault (`cell`, `gates`) and what is wrong.
    #[error("{message}")]
    Option {
        /// The option, as a study option's name.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The caller's cancellation token was set while the analysis ran.
    #[error("the fill analysis was cancelled")]
    Cancelled,
    /// The work would break a limit of [`FlowOptions`]; nothing was allocated.
    #[error("{what}: {} at a cell of {cell} mm, over the limit of {limit:.3e}; choose a cell of at least {least} mm", if .count.is_finite() { format!("{:.3e}", .count) } else { "more than a double can hold".to_string() }, cell = crate::error::figures(*.cell_mm), least = crate::error::figures(*.least_cell_mm))]
    TooLarge {
        /// What is counted.
        what: &'static str,
        /// The count the work would reach.
        count: f64,
        /// The limit.
        limit: f64,
        /// The cell side it was counted at, mm.
        cell_mm: f64,
        /// About the least cell side that keeps the limit, mm.
        least_cell_mm: f64,
    },
}

impl FillError {
    /// A bad option `field`: `message`.
    pub(crate) fn option(field: &'static str, message: impl Into<String>) -> Self {
        FillError::Option {
            field,
            message: message.into(),
        }
    }

    /// The study option at fault, when one is: the cell size for a cell or a count of
    /// the work it sets over its limit.
    pub fn field(&self) -> Option<&'static str> {
        match self {
            FillError::Option { field, .. } => Some(field),
            FillError::TooLarge { .. } => Some("cell"),
            _ => None,
        }
    }

    /// The refusal of `count` of `what` at cells of `cell_mm`, over `limit`; the count
    /// grows as the cell's side to the power `-power` (3 for cells, 2 for surface samples),
    /// which gives the least side that keeps the limit (with 5 % to spare, for the grid's
    /// spare layers).
    pub(crate) fn too_large(
        what: &'static str,
        count: f64,
        limit: f64,
        cell_mm: f64,
        power: f64,
    ) -> Self {
        FillError::TooLarge {
            what,
            count,
            limit,
            cell_mm,
            least_cell_mm: cell_mm * (count / limit).powf(1.0 / power) * 1.05,
        }
    }
}

/// The gate of one body of a part with several.
#[derive(Debug, Clone, Serialize)]
pub struct BodyGate {
    /// The body.
    pub body: u32,
    /// Its share of the part's volume.
    pub volume_share: f64,
    /// Its centre of mass, mm.
    pub centre_of_mass: [f64; 3],
    /// The gate by `rule` on the body; `None` when no qualifying node (no parting line)
    /// lies on the body.
    pub gate: Option<[f64; 3]>,
    /// The rule that placed it: the answer's own (the paper's rule, or with `--aesthetic`
    /// the parting line's).
    pub rule: BodyGateRule,
    /// True for the body of the answer's gate.
    pub is_answer_body: bool,
    /// True when the pictures show the body filled from this gate, which they draw: the
    /// gates they show (the designer's when placed, else the answer's) do not reach it.
    pub pictured: bool,
    /// Largest flow length from that gate over its body, mm.
    pub l_max_mm: Option<f64>,
    /// Estimated fill time of the body from that gate, s, against the body's own nominal
    /// wall.
    pub fill_time_s: Option<f64>,
    /// The body's nominal wall H_ref, mm: the median of its own wall samples (the part's
    /// nominal wall when it has none).
    pub nominal_wall_mm: f64,
}

/// The rule that places a body's own gate ([`BodyGate::rule`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BodyGateRule {
    /// The paper's rule on the body alone: its qualifying node nearest its centre of mass.
    Paper,
    /// The aesthetic rule on the body alone (`--aesthetic`): the point of its parting line
    /// nearest its centre of mass, outside the keep-out regions.
    PartingLine,
}

impl BodyGateRule {
    /// The rule in words, for the front ends.
    pub fn words(self) -> &'static str {
        match self {
            BodyGateRule::Paper => {
                "the paper's rule on this body alone: its qualifying node nearest its centre of mass"
            }
            BodyGateRule::PartingLine => {
                "the aesthetic rule on this body alone: the point of its parting line nearest its centre of mass"
            }
        }
    }

    /// Why a body has no gate by the rule, for the front ends.
    pub fn no_gate_words(self) -> &'static str {
        match self {
            BodyGateRule::Paper => "no qualifying node on it: no gate",
            BodyGateRule::PartingLine => "no parting line on it: no gate",
        }
    }
}

/// What a picture is coloured by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColourBy {
    /// Flow length from the answer's gate, mm.
    FlowLength,
    /// Estimated fill time from the answer's gate, s.
    #[default]
    FillTime,
    /// Wall thickness the fill analysis used, mm.
    Wall,
    /// Height along the demolding direction (the scene's own colouring, no fill field).
    Height,
}

/// The answer's fields per mesh vertex (NaN where the vertex's cell is unreached); only the
/// one of [`FillOptions::colour_by`] is filled, the others are empty.
#[derive(Debug, Clone, Default)]
pub struct VertexFields {
    /// Flow length, mm.
    pub flow_length_mm: Vec<f32>,
    /// Estimated fill time, s.
    pub fill_time_s: Vec<f32>,
    /// Wall thickness of the cell, mm.
    pub wall_mm: Vec<f32>,
}

impl FillAnalysis {
    /// The colour field of the answer's gate for pictures, in real units (the colour bar
    /// spans the values' real minimum and maximum).
    /// `None` for [`ColourBy::Height`], which the scene draws itself. Empty values unless
    /// `by` is the analysis's [`FillOptions::colour_by`].
    pub fn field(&self, by: ColourBy) -> Option<crate::scene::Field> {
        let (name, unit, values) = match by {
            ColourBy::FlowLength => ("flow length", "mm", &self.per_vertex.flow_length_mm),
            ColourBy::FillTime => ("fill time (estimate)", "s", &self.per_vertex.fill_time_s),
            ColourBy::Wall => ("wall thickness", "mm", &self.per_vertex.wall_mm),
            ColourBy::Height => return None,
        };
        Some(crate::scene::Field {
            name: name.into(),
            unit: unit.into(),
            per_vertex: values.clone(),
            cells: (!values.is_empty())
                .then(|| self.field_cells.clone())
                .flatten(),
            span: None,
        })
    }
}

/// Where the fill analysis takes the wall thickness from.
#[derive(Debug, Clone, Copy)]
pub enum Walls<'a> {
    /// Measure it with this tree: one ray per surface cell, from the centroid of a triangle
    /// through the cell along its inverted normal ([`crate::thickness`]'s rule).
    Measure(&'a Bvh),
    /// Given per triangle by [`crate::thickness`]'s rule (NaN where unknown), as
    /// [`crate::thickness::wall_thickness_with`] measures every facet. The fill reads them
    /// as it reads its own samples (the cell size from the 2 V / A estimate, the nominal wall
    /// the median over the surface cells), so its answer is the one of [`Walls::Measure`]:
    /// asking for the wall of every facet beside the fill does not change the fill.
    Given(&'a [f32]),
    /// A uniform wall of 2 V / A.
    Estimate,
}

/// The wall thickness seen by the fill analysis, over its samples (one per surface cell).
#[derive(Debug, Clone, Serialize)]
pub struct WallSummary {
    /// Samples measured (surface cells).
    pub samples: usize,
    /// Smallest known value that is not a sliver (below
    /// [`crate::thickness::SLIVER_OF_NOMINAL`] of the median), mm.
    pub min_mm: Option<f64>,
    /// Samples thinner than that (slivers), left out of `min_mm`.
    pub slivers: usize,
    /// 5th percentile, mm (robust to slivers at small features).
    pub p05_mm: Option<f64>,
    /// The nominal wall: median of the samples (each stands for one cell of surface), mm.
    pub nominal_mm: Option<f64>,
    /// 95th percentile, mm.
    pub p95_mm: Option<f64>,
    /// Largest known value, mm (corners, where a chord runs up a wall, read high).
    pub max_mm: Option<f64>,
    /// Share of samples with no known value (rays leaving an open mesh).
    pub unknown_share: f64,
    /// Seconds spent measuring.
    pub time_s: f64,
}

/// The part's bodies and cells, which the fill analysis makes before it needs the gate: they
/// depend on the mesh, its centres (the part's, summed at load) and the limits alone, so a
/// caller can make them beside the search for the gate ([`prepare`], [`analyse_prepared`]).
#[derive(Debug)]
pub struct Cells {
    bodies: Bodies,
    /// The wall estimated from the centres (2 V / A; without a volume, a hundredth of the
    /// part's diagonal), mm.
    estimate: f64,
    /// Whether the mesh encloses no volume (an open surface, a sheet): its cells are a film
    /// along the surface.
    no_volume: bool,
    /// The limit that coarsened the cells, if one did.
    coarsened: Option<FillError>,
    voxels: Voxels,
    /// What the caller knew of the mesh, for the walls.
    known: crate::thickness::Known,
    /// Seconds spent making them.
    seconds: f64,
}

impl Cells {
    /// Seconds spent making them.
    pub fn seconds(&self) -> f64 {
        self.seconds
    }
}

/// The bodies and cells of `mesh` for the fill analysis (the first part of [`analyse`]);
/// `centres` are the part's (those of its [`crate::gate::Analysis`]). Every limit of
/// [`FlowOptions`] on the cells is checked before the work it bounds.
pub fn prepare(
    mesh: &Mesh,
    centres: &crate::centre::Centres,
    options: &FillOptions,
) -> Result<Cells, FillError> {
    prepare_with(mesh, centres, None, options, None)
}

/// [`prepare`] with the mesh's topology when the caller loaded it: the number of bodies
/// (see [`Bodies::of_counted`]) and whether the surface is closed (for the walls, see
/// [`crate::thickness::Known`]) are then read from it, not found again. The same cells,
/// and the same analysis. Once `cancel` is set, the cells stop at their next step
/// ([`FillError::Cancelled`]).
pub fn prepare_with(
    mesh: &Mesh,
    centres: &crate::centre::Centres,
    topology: Option<&crate::mesh::Topology>,
    options: &FillOptions,
    cancel: Option<&Cancel>,
) -> Result<Cells, FillError> {
    let t = Instant::now();
    let mut bodies = Bodies::of_counted(mesh, topology.map(|t| t.bodies));
    let known = topology.map_or_else(Default::default, crate::thickness::Known::of);
    let c = centres;
    let no_volume = !(c.volume_mm3 > 0.0 && c.area_mm2 > 0.0);
    let estimate = if !no_volume {
        2.0 * c.volume_mm3 / c.area_mm2
    } else {
        mesh.bounds().diagonal() / 100.0
    };
    let (h, coarsened) = choose_cell(
        mesh,
        &bodies.of_triangle,
        &bodies.kept,
        estimate,
        &options.flow,
    )?;
    // `choose_cell` checked the grid, the estimated solid cells and the samples at h.
    let voxels = Voxels::build(mesh, h, &bodies.of_triangle, cancel).ok_or(FillError::Cancelled)?;
    // The triangles' bodies served the cells only (which hold each cell's body): let go
    // before the walls and the marches (4 bytes a triangle of the mesh).
    bodies.of_triangle = Vec::new();
    if voxels.len() as f64 > options.flow.max_solid_cells {
        return Err(FillError::too_large(
            "solid cells",
            voxels.len() as f64,
            options.flow.max_solid_cells,
            h,
            3.0,
        ));
    }
    Ok(Cells {
        bodies,
        estimate,
        no_volume,
        coarsened,
        voxels,
        known,
        seconds: seconds(t),
    })
}

/// Runs the fill analysis of a located part: fields from the paper gate, the balanced gate
/// (always computed, so the report can compare), several gates when asked for, and a gate
/// per body when the part has several. Every limit of [`FlowOptions`] is checked before the
/// work it bounds.
pub fn analyse(
    mesh: &Mesh,
    analysis: &crate::gate::Analysis,
    material: &Material,
    walls: Walls,
    options: &FillOptions,
) -> Result<FillAnalysis, FillError> {
    analyse_prepared(mesh, analysis, material, walls, options, None, || {
        prepare(mesh, &analysis.centres, options)
    })
}

/// [`analyse`] with the bodies and cells of [`prepare`] (the same mesh, the analysis's
/// centres and the same options), made beforehand or by `cells` when asked: the same
/// answer, and the same errors in the same order (the gate and the count of gates are
/// checked before the cells' error is given).
///
/// Once `cancel` is set, every march stops within a few thousand cells and the analysis
/// returns [`FillError::Cancelled`] at its next check (between its steps), so that a
/// service's timed-out study frees its core within a march or two, not minutes later.
pub fn analyse_prepared(
    mesh: &Mesh,
    analysis: &crate::gate::Analysis,
    material: &Material,
    walls: Walls,
    options: &FillOptions,
    cancel: Option<&Cancel>,
    cells: impl FnOnce() -> Result<Cells, FillError>,
) -> Result<FillAnalysis, FillError> {
    let gate = analysis
        .gate()
        .map_err(|e| FillError::NoGate(e.to_string()))?
        .point();
    if options.gates > options.flow.max_gates {
        return Err(FillError::option(
            "gates",
            format!(
                "{} gates asked for, over the limit of {}",
                options.gates, options.flow.max_gates
            ),
        ));
    }
    // The marches below keep their working arrays per thread until the analysis ends.
    let _arrays = march::KeepArrays::new();
    let mut warnings = Vec::new();
    let mut times = FlowTimes::default();
    let Cells {
        bodies,
        estimate,
        no_volume,
        coarsened,
        mut voxels,
        known,
        seconds: cells_s,
    } = cells()?;
    let estimate_source = match no_volume {
        true => WallSource::DiagonalShare,
        false => WallSource::VolumeOverArea,
    };
    voxels.cancel = cancel.cloned();
    // The several-gate search's work depends only on the cells and the gates: refused
    // before the walls, the paper gate and the balanced search are made.
    if options.gates > 1 {
        let k = options.gates as f64;
        // Three searches, one from each start (see `several_gates`), and a march per gate
        // for the gates the layout does without.
        let work = voxels.len() as f64 * (3.0 * (2.0 * k + 24.0 * k + 1.0) + k);
        if work > options.flow.max_march_cells {
            return Err(FillError::too_large(
                "cell visits of the several-gate search",
                work,
                options.flow.max_march_cells,
                voxels.h,
                3.0,
            ));
        }
    }
    let check = || match crate::cancel::is_set(cancel) {
        true => Err(FillError::Cancelled),
        false => Ok(()),
    };
    check()?;
    let t = Instant::now();
    let h = voxels.h;
    if let Some(why) = coarsened {
        warnings.push(format!(
            "flow cells coarsened to {h:.4} mm to keep a limit ({why})"
        ));
    }
    // The cells first, their walls and costs once measured (below).
    let mut domain = Domain::without_walls(voxels);
    // The mesh's volume of each body when every body is closed (its cells' volume else).
    if bodies.volume_mm3.len() == domain.bodies && bodies.volume_mm3.iter().all(|&v| v > 0.0) {
        domain.body_volume_mm3 = bodies.volume_mm3.clone();
    }
    let first = domain
        .source(gate)
        .ok_or(FillError::GateOffPart(gate.x, gate.y, gate.z))?;
    // Candidates: the qualifying nodes' surface points on the voxelised part.
    let candidates: Vec<Source> = analysis
        .qualifying_points
        .iter()
        .filter_map(|&p| domain.source(p))
        .collect();
    let kind = Kind::of(options.objective);
    // With the aesthetic gate chosen, the balanced search starts from the paper's grid gate
    // on the same body, and that gate stays the balanced gate unless a candidate beats it
    // by more than one cell, as when it is the chosen gate: both modes give one balanced
    // gate (a search ends within a cell of the optimum, and where depends on its start). A
    // grid gate on another body, or none, leaves the search to the chosen gate.
    let search_first = analysis
        .grid_gate
        .as_ref()
        .and_then(|g| domain.source(g.point))
        .filter(|s| {
            s.point != first.point
                && domain.body[s.cell as usize] == domain.body[first.cell as usize]
        });
    let cells_here_s = seconds(t);

    // Two sides at once. One measures the walls per triangle (given, or measured here for
    // the triangles of the surface cells only: either way the cells read them alike, so
    // the fill does not depend on whether every facet was measured beside it), makes the
    // cells' costs from them and marches the paper gate's fill order and pressure. The
    // other marches the paper gate's flow length, which needs no wall, and when the
    // objective is the flow length (the default) runs the balanced search from it: the
    // search's runs are chains of marches that leave a thread idle between them, which
    // the walls' rays fill. Every value is the one of the stages made one after the
    // other.
    let t = Instant::now();
    let walls_side = || {
        let t_wall = Instant::now();
        let measured = match walls {
            Walls::Measure(bvh) => {
                // A facet that owns several cells is listed once per cell and measured once.
                let owners: Vec<u32> = domain
                    .voxels
                    .triangle
                    .iter()
                    .zip(&domain.voxels.surface)
                    .filter(|(_, &s)| s)
                    .map(|(&t, _)| t)
                    .collect();
                Some(crate::thickness::wall_thickness_of_known(
                    mesh,
                    bvh,
                    &crate::thickness::ThicknessOptions::default(),
                    &owners,
                    known,
                    cancel,
                ))
            }
            _ => None,
        };
        // Walls cut short by the caller's token are not summarised, nor the costs and the
        // paper gate's fields made from them: the analysis stops after this side.
        if crate::cancel::is_set(cancel) {
            return None;
        }
        let triangle_walls = match walls {
            Walls::Given(w) => Some(w),
            Walls::Measure(_) => measured.as_deref(),
            Walls::Estimate => None,
        };
        let (nominal, wall_source, wall, body_nominal) = match triangle_walls {
            Some(w) => {
                let summary = summarise_walls(&domain.voxels, w, seconds(t_wall));
                let nominal = summary.nominal_mm.unwrap_or(estimate);
                let source = if summary.nominal_mm.is_some() {
                    WallSource::Measured
                } else {
                    estimate_source
                };
                let body_nominal = body_nominal_walls(&domain.voxels, w);
                (nominal, source, Some(summary), body_nominal)
            }
            None => (estimate, estimate_source, None, Vec::new()),
        };
        // Each body's own median wall is its reference (a body without samples takes the
        // part's): a thin lid beside a thick box fills as it would alone. The walls
        // measured per triangle (4 bytes a triangle of the mesh) are let go once the cells
        // hold theirs, before the marches.
        let t_costs = Instant::now();
        let costs = domain.walls_of(triangle_walls, nominal, &body_nominal, material);
        drop(measured);
        let costs_s = seconds(t_costs);
        let t_paper = Instant::now();
        let v = &domain.voxels;
        let (fill, pressure) = rayon::join(
            || march(v, &[first], Some(&costs.fill_cost)),
            || march(v, &[first], Some(&costs.pressure_cost)),
        );
        let paper_s = seconds(t_paper);
        Some((
            costs,
            (nominal, wall_source, wall),
            (fill, pressure),
            (costs_s, paper_s),
        ))
    };
    let length_side = || {
        let t_length = Instant::now();
        let v = &domain.voxels;
        let length = march(v, &[first], None);
        let length_s = seconds(t_length);
        let search = (kind == Kind::Length).then(|| {
            let grid = search_first.map(|s| (s, march(v, &[s], None)));
            let (from, start) = grid.as_ref().map_or((first, &length), |(s, f)| (*s, f));
            let found = balanced_search(
                &domain,
                &candidates,
                options.objective,
                from,
                start,
                h,
                FAR_REACH,
                (SIDE_MARCH_ROUNDS, |c| march(v, &[candidates[c]], None)),
            )
            // The chosen candidate's field, when no idle thread made it beside the
            // search's last run: made here rather than after both sides.
            .map(|Searched { found, aside, .. }| {
                let field = aside.unwrap_or_else(|| march(v, &[candidates[found.candidate]], None));
                (found, Some(field))
            });
            (found, grid)
        });
        (length, length_s, search)
    };
    let (walls_made, (length, length_s, search)) = rayon::join(walls_side, length_side);
    let (costs, (nominal, wall_source, wall), (fill, pressure), (costs_s, paper_fill_s)) =
        walls_made.ok_or(FillError::Cancelled)?;
    let joined_s = seconds(t);
    domain.set_walls(costs);
    // The cell size is set from an estimate of the wall before it is measured; warn only
    // when the measured wall is less than 1.5 cells across.
    if h > nominal / 1.5 {
        warnings.push(format!(
            "flow cells of {h:.3} mm are coarse for the nominal wall of {nominal:.3} mm (under 1.5 cells across): flow lengths are rough; try --cell {:.3}",
            nominal / 2.0
        ));
    }
    // The stages ran side by side: the walls and the cells' costs count their own time,
    // the paper gate's fields the longer of their two sides, the search the rest of the
    // joined time (see `FlowTimes::wall_s`).
    times.wall_s = wall.as_ref().map_or(0.0, |w| w.time_s).min(joined_s);
    let costs_s = costs_s.min(joined_s - times.wall_s);
    times.voxels_s = cells_s + cells_here_s + costs_s;
    times.paper_s = paper_fill_s
        .max(length_s)
        .min(joined_s - times.wall_s - costs_s);
    let searched_s = joined_s - times.wall_s - costs_s - times.paper_s;
    if no_volume {
        warnings.push(
            "the mesh encloses no volume (an open surface or a sheet): the fill runs on a film of cells along its surface, so its walls, pressure and flow ratio are not those of a moulded part; close the mesh for a fill analysis".into(),
        );
    }
    if bodies.count > 1 {
        warnings.push(format!(
            "the part has {} separate bodies; a gate fills only its own body (see the gate per body)",
            bodies.count
        ));
    }
    if bodies.stray > 0 {
        warnings.push(format!(
            "{} stray bodies (area below {} % of the part's) left out of the fill",
            bodies.stray,
            100.0 * STRAY_BODY_AREA_SHARE
        ));
    }
    check()?;

    let paper_fields = GateFields { length, fill };
    let t = Instant::now();
    let v = &domain.voxels;
    let start = paper_fields.of(options.objective);
    // The paper gate's summary, beside the search of the fill-order objective (which needs
    // the walls, so it starts here) or beside nothing: it reads the fields the search does
    // not change.
    let (mut paper, search) = rayon::join(
        || {
            let GateFields { length, fill } = &paper_fields;
            let fields = [length, fill, &pressure];
            summarise_layout(&domain, &[gate], &[first], material, fields).0
        },
        || {
            search.unwrap_or_else(|| {
                let grid = search_first.map(|s| (s, march(v, &[s], kind.cost(&domain))));
                let (from, start) = grid.as_ref().map_or((first, start), |(s, f)| (*s, f));
                let found = balanced_search(
                    &domain,
                    &candidates,
                    options.objective,
                    from,
                    start,
                    h,
                    FAR_REACH,
                    (SIDE_MARCH_ROUNDS, |c| {
                        march(v, &[candidates[c]], kind.cost(&domain))
                    }),
                )
                .map(|Searched { found, aside, .. }| (found, aside));
                (found, grid)
            })
        },
    );
    drop(pressure);
    let answer_name = match analysis.options.mode {
        crate::GateMode::Aesthetic => "aesthetic gate",
        _ => "paper gate",
    };
    if paper.reached_share < 0.999 {
        warnings.push(format!(
            "the {} feeds {} only: {:.1} % of the part's volume is not reached",
            answer_name,
            body_name(paper.body),
            100.0 * (1.0 - paper.reached_share)
        ));
    }
    let per_mm = seconds_per_mm(material);
    // The objective in its reported units: L_max in mm, or the fill time in s.
    let (objective_value, scale): (fn(&GateFill) -> f64, f64) = match options.objective {
        Objective::Length => (|f| f.l_max_mm, 1.0),
        Objective::Resistance => (|f| f.fill_time_s, per_mm),
    };
    // The balanced gate: its objective's field was marched beside the search's last run,
    // and decides whether it beats the paper gate (the same value its fill reports). Its
    // other two fields and its summary, needed only for the report, are made beside the
    // suitability map and the several-gate search, which read the objective's field only.
    let (search, grid) = search;
    let head = search.map(|(search, aside)| {
        let sources = [candidates[search.candidate]];
        let field = aside.unwrap_or_else(|| march(v, &sources, kind.cost(&domain)));
        let value = argmax(&field.t).1 * scale;
        (search, field, value)
    });
    // One cell (the fields' resolution) in the objective's units.
    let cell_value = h * scale;
    // The grid gate (a candidate itself) beside the aesthetic gate: it stays the balanced
    // gate unless the search's candidate beats it by more than one cell.
    let head = match (head, grid) {
        (Some((search, field, value)), Some((g, grid_field))) => {
            let grid_value = argmax(&grid_field.t).1 * scale;
            match candidates.iter().position(|c| c.point == g.point) {
                Some(i) if value >= grid_value - cell_value => {
                    let search = Balanced {
                        candidate: i,
                        ..search
                    };
                    Some((search, grid_field, grid_value))
                }
                _ => Some((search, field, value)),
            }
        }
        (head, _) => head,
    };
    // Whether the balanced gate's value beats the paper gate's by more than one cell (the
    // fields' resolution, in the objective's units): a smaller gain is the discretisation's,
    // not the gate's, and does not move the gate.
    let paper_value = objective_value(&paper);
    let beats = |value: f64| value < paper_value - cell_value;
    if head.is_none() {
        warnings.push(if candidates.is_empty() {
            format!(
                "no balanced gate: no grid node qualifies for a gate ({}), so the fill is the {answer_name}'s alone",
                analysis.why_no_candidate()
            )
        } else {
            format!(
                "no balanced gate: no qualifying grid node lies on the body the {answer_name} feeds, so the fill is the {answer_name}'s alone"
            )
        });
    }
    times.balanced_s = searched_s + seconds(t);
    // The balanced gate's objective field, when it is the balanced gate's own (it beat the
    // paper gate).
    let balanced_field = head
        .as_ref()
        .filter(|(_, _, value)| beats(*value))
        .map(|(search, field, _)| (search, field));
    let complete = || {
        let t = Instant::now();
        let balanced = head.as_ref().map(|(search, field, value)| {
            // The search marches from cell centres; the reported gate is the candidate's
            // surface point, whose field differs by up to a cell. The search reports the
            // value of the fill it gives, and the bound it proved capped at that value.
            let bound = search.lower_bound * scale;
            if !beats(*value) {
                // Within the discretisation the paper gate is as good (it is a candidate
                // itself unless it is the aesthetic gate): keep it, so the balanced gate
                // never does worse than the paper gate.
                let value = objective_value(&paper);
                let search = Balanced {
                    value,
                    lower_bound: bound.min(value),
                    ..*search
                };
                let fill = BalancedFill {
                    fill: paper.clone(),
                    search,
                    improvement_pct: 0.0,
                    is_paper_gate: true,
                };
                return (fill, None);
            }
            let point = candidates[search.candidate].point;
            let sources = [candidates[search.candidate]];
            let mut given = [None, None, None];
            given[kind as usize] = Some(field.clone());
            let [length, fill, pressure] = march_layout(&domain, &sources, given);
            let fields = [&length, &fill, &pressure];
            let (fill_summary, _) = summarise_layout(&domain, &[point], &sources, material, fields);
            let value = objective_value(&fill_summary);
            let improvement_pct = 100.0 * (1.0 - value / objective_value(&paper));
            let search = Balanced {
                value,
                lower_bound: bound.min(value),
                ..*search
            };
            let balanced = BalancedFill {
                fill: fill_summary,
                search,
                improvement_pct,
                is_paper_gate: false,
            };
            (balanced, Some(GateFields { length, fill }))
        });
        (balanced, seconds(t))
    };
    let rest = || -> Result<_, FillError> {
        let mut times = FlowTimes::default();
        let t = Instant::now();
        let suitability = if options.suitability {
            use suitability::Given;
            // The paper gate is a node (or, the aesthetic gate, on the parting line: exact for
            // a node only when it shares its cell).
            let mut given = vec![Given {
                field: start,
                node_cell: Some(first.cell),
            }];
            let mut budget = 0;
            if let Some((search, _, _)) = &head {
                budget = 2 * search.runs;
            }
            if let Some((search, field)) = balanced_field {
                given.push(Given {
                    field,
                    node_cell: Some(candidates[search.candidate].cell),
                });
            }
            let map = suitability::suitability(
                &domain,
                &analysis.qualifying_points,
                options.objective,
                &given,
                budget,
                scale,
                h,
                options.flow.max_march_cells,
            )?;
            times.suitability_s = Some(seconds(t));
            Some(map)
        } else {
            None
        };

        let t = Instant::now();
        let several = if options.gates > 1 {
            // Start from the balanced gate (or the paper gate's nearest candidate).
            let start = match &head {
                Some((search, _, _)) => search.candidate,
                None => {
                    nearest_candidate(&candidates, gate).ok_or(FillError::TooFewCandidates {
                        asked: options.gates,
                        available: 0,
                    })?
                }
            };
            let available = in_body(
                &domain,
                &candidates,
                domain.body[candidates[start].cell as usize],
            )
            .len();
            // The balanced gate's fill marched the first gate's field when it beat the paper
            // gate (the same source: its candidate's surface point and cell).
            let first_field = balanced_field
                .filter(|(search, _)| search.candidate == start)
                .map(|(_, field)| field);
            let mut layout = several_gates_over_bodies(
                &domain,
                &candidates,
                options.objective,
                start,
                options.gates,
                // No two gates' discs overlap.
                2.0 * analysis.options.gate_radius_mm,
                first_field,
            )
            .ok_or(FillError::TooFewCandidates {
                asked: options.gates,
                available,
            })?;
            // No place later than the layout's value (its f32 queue keys aside).
            let tolerance = 1e-6 * layout.value().abs();
            layout.redundant =
                redundant_gates(&domain, &candidates, options.objective, &layout, tolerance);
            if options.objective == Objective::Resistance {
                // The search's values are of the fill-time field: seconds, under their name.
                layout.fill_time_s = layout.l_max_mm.take().map(|x| x * per_mm);
                for g in &mut layout.gates {
                    g.fill_time_s = g.l_max_mm.take().map(|x| x * per_mm);
                }
            }
            Some(layout)
        } else {
            None
        };
        times.several_s = seconds(t);
        Ok((suitability, several, times))
    };
    let t = Instant::now();
    // Side by side only when there is a search or a map to make beside it.
    let ((balanced, complete_s), rest) = if options.gates > 1 || options.suitability {
        rayon::join(complete, rest)
    } else {
        (complete(), rest())
    };
    // A cancelled march gives a field cut short, so the steps after it may fail: the
    // cancellation is the error.
    check()?;
    let (suitability, mut several, rest_times) = rest?;
    let mut balanced = balanced;
    if let (Some(map), Some((b, fields))) = (&suitability, balanced.as_mut()) {
        let from = (&candidates[..], first);
        let gain = (objective_value, cell_value);
        if let Some(better) = map_best_gate(&domain, from, map, &b.search, material, gain) {
            let old = b.search.value;
            let value = better.search.value;
            *b = BalancedFill {
                improvement_pct: 100.0 * (1.0 - value / paper_value),
                is_paper_gate: false,
                search: Balanced {
                    runs: b.search.runs,
                    ..better.search
                },
                fill: better.fill,
            };
            *fields = Some(better.fields);
            warnings.push(format!(
                "the balanced search stopped unproven at its limit of runs with a gate of {} {unit}; the suitability map's best node is exact and no node's bound is lower (it scores {} {unit} from its cell's centre, {} {unit} from its surface point), so it is the balanced gate, proven by the map",
                options.objective.value_text(old),
                options.objective.value_text(better.map_score),
                options.objective.value_text(value),
                unit = options.objective.value_words().1,
            ));
        }
    }
    // A layout is measured against the best single gate the report gives: the balanced
    // gate (the paper gate when no candidate beats it by more than a cell), by the value
    // its fill reports, so that the gain can be checked from the numbers shown. A value
    // that is not finite and positive leaves nothing to compare with.
    let single = balanced
        .as_ref()
        .map_or(paper_value, |(b, _)| b.search.value);
    if let Some(layout) = several.as_mut() {
        layout.improvement_pct = if single.is_finite() && single > 0.0 {
            100.0 * (1.0 - layout.value() / single)
        } else {
            0.0
        };
    }
    if let Some(layout) = &several {
        // A layout over several bodies feeds bodies a single gate cannot: its gain is not
        // in its value alone.
        if layout.bodies <= 1 && layout.improvement_pct < SMALL_LAYOUT_GAIN_PCT {
            let (what, unit) = options.objective.value_words();
            // Close values: L_max to 0.01 mm, a fill time to three significant figures.
            let value = |x: f64| match options.objective {
                Objective::Length => format!("{x:.2}"),
                Objective::Resistance => crate::report::seconds_text(x),
            };
            let shares: Vec<String> = layout
                .gates
                .iter()
                .map(|g| format!("{:.1}", 100.0 * g.volume_share))
                .collect();
            // The search is local: a small gain may be the part's (a fill time set by a few
            // slow, thin places) or the search's (a layout it did not reach).
            warnings.push(format!(
                "the layout of {} gates found shortens the {what} by only {:.1} % against the balanced gate, {} against {} {unit} (shares of the volume {} %); the search is local and may miss a better layout: try your own gates with --gate-at",
                layout.gates.len(),
                layout.improvement_pct.max(0.0),
                value(layout.value()),
                value(single),
                shares.join(", "),
            ));
        }
        warnings.extend(idle_gates(layout));
        if !layout.redundant.is_empty() {
            warnings.push(redundant_warning(layout, options.objective));
        }
        // Each body the candidates lie on gets a gate while there are gates enough: on a
        // part of several bodies, say which get none, and whose volume the shares are of.
        if domain.bodies > 1 {
            let mut gated: Vec<u32> = layout.gates.iter().map(|g| g.body).collect();
            gated.sort_unstable();
            gated.dedup();
            let without: Vec<u32> = (0..domain.bodies as u32)
                .filter(|b| !gated.contains(b))
                .collect();
            if !without.is_empty() {
                let names = |bodies: &[u32]| {
                    bodies
                        .iter()
                        .map(|&b| body_name(b))
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                let share: f64 = gated.iter().map(|&b| domain.volume_share(b)).sum();
                let with_candidates = without
                    .iter()
                    .any(|&b| !in_body(&domain, &candidates, b).is_empty());
                warnings.push(format!(
                    "the layout of {} gates is on {} only ({:.1} % of the part's volume), and its shares are of that volume: {} {} none of its gates ({}; a gate per body is listed with the fill)",
                    layout.gates.len(),
                    names(&gated),
                    100.0 * share,
                    names(&without),
                    if without.len() == 1 { "gets" } else { "get" },
                    if with_candidates {
                        format!("ask for at least {} gates, one a body", gated.len() + without.len())
                    } else {
                        format!("no node qualifies on {}", if without.len() == 1 { "it" } else { "them" })
                    },
                ));
            }
        }
    }
    // The balanced gate's fill counts where it made the join longer than the rest.
    let rest_s = rest_times.suitability_s.unwrap_or(0.0) + rest_times.several_s;
    times.balanced_s += (seconds(t) - rest_s).clamp(0.0, complete_s);
    times.suitability_s = rest_times.suitability_s;
    times.several_s = rest_times.several_s;

    let t = Instant::now();
    let placed = match options.placed.as_slice() {
        [] => None,
        points => {
            let (mut fill, fields, shares) =
                fill_from_all(&domain, points, material).ok_or_else(|| {
                    let p = points
                        .iter()
                        .find(|&&p| domain.source(p).is_none())
                        .unwrap_or(&points[0]);
                    FillError::GateOffPart(p.x, p.y, p.z)
                })?;
            snap_places(&domain, mesh, &mut fill);
            let wall_across_mm = points
                .iter()
                .filter_map(|&p| domain.source(p))
                .map(|s| domain.wall_mm[s.cell as usize] as f64)
                .collect();
            Some((
                PlacedFill {
                    fill,
                    shares,
                    wall_across_mm,
                },
                fields,
            ))
        }
    };
    times.placed_s = seconds(t);

    let (answer, fields) = match (&options.strategy, &balanced) {
        (Strategy::Balanced, Some((b, Some(f)))) => (DVec3::from_array(b.fill.gate), f),
        _ => (gate, &paper_fields),
    };
    // The designer's gates, when placed, are what the pictures show.
    let (fields, several_pictured) = match &placed {
        Some((_, f)) => (f, None),
        None => (fields, several.as_ref()),
    };
    let answer_body = domain.body_at(answer);
    // The map scores a node by the fill of its own body: on a part of several bodies the
    // best node may be on a smaller body, not comparable with the answer's.
    let best_body = suitability
        .as_ref()
        .and_then(|m| m.best.map(|b| &m.nodes[b]))
        .and_then(|n| domain.body_at(DVec3::from_array(n.point)));
    if let (true, Some(best), Some(answer)) = (domain.bodies > 1, best_body, answer_body) {
        if best != answer {
            let share = domain.volume_share(best);
            warnings.push(format!(
                "the suitability map scores each node by the fill of its own body only: its best node is on {} ({:.1} % of the part's volume), not on the answer's {}; compare nodes within one body (the pictures colour each node against the best of its own body)",
                body_name(best),
                100.0 * share,
                body_name(answer)
            ));
        }
    }
    // Only the field the pictures show (a pass over the vertices each).
    let mut per_vertex = VertexFields::default();
    // The layout's fill whichever objective chose it, from all its gates at once: its
    // flow length and fill time are also the fields the pictures colour when the layout is
    // pictured.
    let (mut layout_summary, mut layout_fields) = match several.as_ref() {
        Some(m) => {
            let sources: Vec<Source> = m.gates.iter().map(|g| candidates[g.candidate]).collect();
            let points: Vec<DVec3> = sources.iter().map(|s| s.point).collect();
            let (mut summary, fields, _) = fill_from_sources(&domain, &points, &sources, material);
            snap_places(&domain, mesh, &mut summary);
            (Some(summary), Some(fields))
        }
        None => (None, None),
    };
    let layout_fill_time_s = layout_summary.as_ref().map(|f| f.fill_time_s);
    // The pictured field of the cells when it is a field of the fill: flow length or fill
    // time, from every pictured gate at once when there are several.
    let pictured_layout = several_pictured.and(layout_fields.take());
    let mut pictured_t: Option<(Vec<f64>, Kind)> = match options.colour_by {
        ColourBy::FlowLength => Some((
            match pictured_layout {
                Some(f) => f.length.t,
                None => fields.length.t.clone(),
            },
            Kind::Length,
        )),
        ColourBy::FillTime => Some((
            match pictured_layout {
                Some(f) => f.fill.t,
                None => fields.fill.t.clone(),
            },
            Kind::Fill,
        )),
        ColourBy::Wall | ColourBy::Height => None,
    };
    // A body the pictured gates (the designer's when placed, else the answer's) do not
    // reach is shown filled from its own gate (the gate per body), not as a body without a
    // value: each body of a file of several is moulded from its own gate. Its own field is
    // written over its cells as soon as it is marched, and let go: a part of many bodies
    // holds one pictured field, not one a body.
    let body_gates = if domain.bodies > 1 {
        let mut reached = vec![false; domain.bodies];
        match several_pictured {
            Some(m) => {
                for g in &m.gates {
                    reached[g.body as usize] = true;
                }
            }
            None => {
                for (c, x) in fields.length.t.iter().enumerate() {
                    if x.is_finite() {
                        reached[domain.body[c] as usize] = true;
                    }
                }
            }
        }
        gates_per_body(
            &domain,
            mesh,
            &bodies,
            analysis,
            material,
            answer_body,
            |b, own| {
                if reached[b as usize] {
                    return false;
                }
                if let Some((t, kind)) = pictured_t.as_mut() {
                    let own = match kind {
                        Kind::Length => &own.length.t,
                        _ => &own.fill.t,
                    };
                    for ((x, &body), &o) in t.iter_mut().zip(&domain.body).zip(own) {
                        if body == b {
                            *x = o;
                        }
                    }
                }
                true
            },
        )
    } else {
        Vec::new()
    };
    // The pictured field on the cells, in real units, kept for the pictures.
    let on_cells = |t: &[f64], scale: f64| -> Vec<f32> {
        t.par_iter()
            .map(|&x| {
                if x.is_finite() {
                    (x * scale) as f32
                } else {
                    f32::NAN
                }
            })
            .collect()
    };
    let cell_values = match (options.colour_by, pictured_t) {
        (ColourBy::FlowLength, Some((t, _))) => {
            per_vertex.flow_length_mm = per_vertex_of(&domain, mesh, &t, 1.0);
            Some(on_cells(&t, 1.0))
        }
        (ColourBy::FillTime, Some((t, _))) => {
            per_vertex.fill_time_s = per_vertex_of(&domain, mesh, &t, per_mm);
            Some(on_cells(&t, per_mm))
        }
        (ColourBy::Wall, _) => {
            per_vertex.wall_mm = per_vertex_of_cells(&domain, mesh, &domain.wall_mm);
            Some(domain.wall_mm.clone())
        }
        _ => None,
    };
    snap_places(&domain, mesh, &mut paper);
    let mut balanced = balanced.map(|(b, _)| b);
    if let Some(b) = &mut balanced {
        snap_places(&domain, mesh, &mut b.fill);
    }
    warnings.extend(seat_warnings(
        analysis,
        balanced.as_ref(),
        several.as_ref(),
        &body_gates,
    ));
    if let Some(b) = balanced.as_ref().filter(|b| !b.is_paper_gate) {
        warnings.extend(worse_by_other_measures(
            options.objective,
            analysis.options.mode,
            &paper,
            &b.fill,
        ));
    }
    if let Some(m) = &mut several {
        m.layout_fill_time_s = layout_fill_time_s;
        m.fill = layout_summary.take();
    }
    let placed = placed.map(|(p, _)| p);
    warnings.extend(flow_ratio_warnings(
        &paper,
        balanced.as_ref(),
        several.as_ref(),
        placed.as_ref(),
    ));
    warnings.extend(late_tail_warning(&paper, answer_name));
    if let Some(b) = &balanced {
        warnings.extend(slow_place_warning(&paper, b, options.objective, h));
    }
    check()?;
    Ok(FillAnalysis {
        cell_mm: h,
        cells: domain.voxels.len(),
        bodies: bodies.count,
        stray_bodies: bodies.stray,
        body_gates,
        nominal_wall_mm: nominal,
        wall_source,
        wall,
        objective: options.objective,
        strategy: options.strategy,
        pressure_mpa_per_mm: pressure_factor_mpa_per_mm(material, nominal),
        paper: Some(paper),
        balanced,
        several,
        placed,
        suitability,
        warnings,
        times,
        per_vertex,
        field_cells: cell_values.map(|v| {
            std::sync::Arc::new(crate::display::CellField::new(domain.voxels.into_grid(), v))
        }),
        answer: Some(answer),
    })
}

/// The gate of every body by the answer's rule on the body alone ([`BodyGateRule`]: the
/// paper's, its qualifying node nearest its centre of mass, or with `--aesthetic` the point
/// of its parting line nearest it), with its flow length and fill time over the body. Each
/// body's fields are handed to `pictured` as soon as they are marched (to draw a body the
/// pictured gates do not reach), which says whether the pictures show them, and are let go.
fn gates_per_body(
    domain: &Domain,
    mesh: &Mesh,
    bodies: &Bodies,
    analysis: &crate::gate::Analysis,
    material: &Material,
    answer_body: Option<u32>,
    mut pictured: impl FnMut(u32, &GateFields) -> bool,
) -> Vec<BodyGate> {
    // Summed once for every body (`Domain::volume_share` sums per call).
    let total: f64 = domain.body_volume_mm3.iter().sum();
    let per_mm = seconds_per_mm(material);
    let rule = match analysis.options.mode {
        crate::GateMode::Aesthetic => BodyGateRule::PartingLine,
        _ => BodyGateRule::Paper,
    };
    (0..domain.bodies as u32)
        .map(|b| {
            let centre = bodies
                .centre
                .get(b as usize)
                .copied()
                .unwrap_or(DVec3::ZERO);
            let gate = match rule {
                BodyGateRule::Paper => analysis
                    .qualifying_points
                    .iter()
                    .filter(|&&p| domain.body_at(p) == Some(b))
                    .min_by(|p, q| p.distance(centre).total_cmp(&q.distance(centre)))
                    .copied(),
                // As the answer's parting-line gate is found, on the body's own edges.
                BodyGateRule::PartingLine => analysis
                    .options
                    .parting_gate(&analysis.parting, mesh, &analysis.frame, centre, |p| {
                        domain.body_at(p) == Some(b)
                    })
                    .map(|g| g.point),
            };
            // The body's flow length and fill order from its gate, marched side by side: the
            // largest of each is what the body's gate reports (as a fill's summary finds
            // them), and the fields are what the pictures may show. Neither the pressure nor
            // the rest of a fill's summary is asked of a body's gate.
            let fill = gate.and_then(|g| domain.source(g)).map(|source| {
                let (length, fill) = rayon::join(
                    || march(&domain.voxels, &[source], Kind::Length.cost(domain)),
                    || march(&domain.voxels, &[source], Kind::Fill.cost(domain)),
                );
                let values = (argmax(&length.t).1, argmax(&fill.t).1 * per_mm);
                (values, GateFields { length, fill })
            });
            let (l_max_mm, fill_time_s) = fill.as_ref().map(|f| f.0).unzip();
            BodyGate {
                body: b,
                volume_share: domain.body_volume_mm3[b as usize] / total.max(f64::MIN_POSITIVE),
                centre_of_mass: centre.to_array(),
                gate: gate.map(|g| g.to_array()),
                rule,
                is_answer_body: answer_body == Some(b),
                pictured: fill.as_ref().is_some_and(|f| pictured(b, &f.1)),
                l_max_mm,
                fill_time_s,
                nominal_wall_mm: domain
                    .body_nominal_wall_mm
                    .get(b as usize)
                    .copied()
                    .unwrap_or(domain.nominal_wall_mm),
            }
        })
        .collect()
}

/// The point of the part's surface nearest cell `c`'s centre, on the cell's triangle (a
/// surface cell's own, an interior cell's nearest surface cell's).
fn on_surface(domain: &Domain, mesh: &Mesh, p: [f64; 3]) -> [f64; 3] {
    let p = DVec3::from_array(p);
    let snapped = domain
        .voxels
        .cell_near(p)
        .map(|c| domain.voxels.triangle[c as usize])
        .filter(|&t| (t as usize) < mesh.triangles.len())
        .map(|t| crate::thickness::nearest_on_triangle(mesh.corners(t as usize), p));
    snapped.unwrap_or(p).to_array()
}

/// Moves the places a fill reports (last to fill, farthest point, weld lines) onto the
/// part's surface.
fn snap_places(domain: &Domain, mesh: &Mesh, fill: &mut GateFill) {
    fill.farthest = on_surface(domain, mesh, fill.farthest);
    for q in &mut fill.last_to_fill {
        q.point = on_surface(domain, mesh, q.point);
    }
    for w in &mut fill.weld_lines {
        w.point = on_surface(domain, mesh, w.point);
    }
}

/// Statistics of the surface cells' walls: each surface cell is one sample, the value of its
/// triangle.
fn summarise_walls(voxels: &Voxels, per_triangle: &[f32], time_s: f64) -> WallSummary {
    let mut values: Vec<f32> = Vec::new();
    let mut samples = 0;
    for (&t, &s) in voxels.triangle.iter().zip(&voxels.surface) {
        if s {
            samples += 1;
            let v = per_triangle[t as usize];
            if v.is_finite() {
                values.push(v);
            }
        }
    }
    // The quantiles are the values of a sort at their ranks, found by selection (the
    // median first, then the others in its halves).
    let rank = |f: f64| ((values.len().max(1) - 1) as f64 * f).round() as usize;
    let (p05, p50, p95) = (rank(0.05), rank(0.5), rank(0.95));
    let (mut p05_mm, mut nominal_mm, mut p95_mm, mut max_mm) = (None, None, None, None);
    if !values.is_empty() {
        let (below, &mut median, above) = values.select_nth_unstable_by(p50, f32::total_cmp);
        let nth =
            |part: &mut [f32], k: usize| *part.select_nth_unstable_by(k, f32::total_cmp).1 as f64;
        nominal_mm = Some(median as f64);
        p05_mm = Some(if p05 < p50 {
            nth(below, p05)
        } else {
            median as f64
        });
        p95_mm = Some(if p95 > p50 {
            nth(above, p95 - p50 - 1)
        } else {
            median as f64
        });
        max_mm = Some(
            *above
                .iter()
                .max_by(|a, b| a.total_cmp(b))
                .unwrap_or(&median) as f64,
        );
    }
    let sliver = nominal_mm.map_or(0.0, |n| crate::thickness::SLIVER_OF_NOMINAL * n);
    // The least value that is not a sliver, as the sorted values' first past the slivers.
    let slivers = values.iter().filter(|&&v| (v as f64) < sliver).count();
    let min_mm = values
        .iter()
        .filter(|&&v| (v as f64) >= sliver)
        .min_by(|a, b| a.total_cmp(b))
        .map(|&v| v as f64);
    WallSummary {
        samples,
        min_mm,
        slivers,
        p05_mm,
        nominal_mm,
        p95_mm,
        max_mm,
        unknown_share: if samples == 0 {
            1.0
        } else {
            1.0 - values.len() as f64 / samples as f64
        },
        time_s,
    }
}

/// The nominal wall of each body: the median of its surface cells' walls, by the rule of
/// [`summarise_walls`] (so a part of one body gets the part's nominal wall exactly); NaN
/// for a body with no known sample.
fn body_nominal_walls(voxels: &Voxels, per_triangle: &[f32]) -> Vec<f64> {
    let bodies = voxels
        .body
        .iter()
        .map(|&b| b as usize + 1)
        .max()
        .unwrap_or(0);
    let mut values: Vec<Vec<f32>> = vec![Vec::new(); bodies];
    for ((&t, &s), &b) in voxels
        .triangle
        .iter()
        .zip(&voxels.surface)
        .zip(&voxels.body)
    {
        let v = per_triangle[t as usize];
        if s && v.is_finite() {
            values[b as usize].push(v);
        }
    }
    values
        .into_iter()
        .map(|mut v| {
            if v.is_empty() {
                return f64::NAN;
            }
            let middle = ((v.len() - 1) as f64 * 0.5).round() as usize;
            *v.select_nth_unstable_by(middle, f32::total_cmp).1 as f64
        })
        .collect()
}

fn nearest_candidate(candidates: &[Source], p: DVec3) -> Option<usize> {
    nearest_of(candidates, 0..candidates.len(), p)
}

/// The candidate of `pool` (indices into `candidates`) nearest `p` in a straight line, the
/// lowest index of equals.
fn nearest_of(
    candidates: &[Source],
    pool: impl IntoIterator<Item = usize>,
    p: DVec3,
) -> Option<usize> {
    pool.into_iter().min_by(|&a, &b| {
        candidates[a]
            .point
            .distance(p)
            .total_cmp(&candidates[b].point.distance(p))
            .then(a.cmp(&b))
    })
}

/// A field per mesh vertex in real units (`scale` times the field; NaN where the vertex's
/// cell is unreached).
fn per_vertex_of(domain: &Domain, mesh: &Mesh, t: &[f64], scale: f64) -> Vec<f32> {
    mesh.vertices
        .par_iter()
        .map(|&p| {
            domain
                .voxels
                .cell_near(p)
                .map(|c| t[c as usize])
                .filter(|x| x.is_finite())
                .map_or(f32::NAN, |x| (x * scale) as f32)
        })
        .collect()
}

/// A per-cell value per mesh vertex (NaN where no cell is near).
fn per_vertex_of_cells(domain: &Domain, mesh: &Mesh, values: &[f32]) -> Vec<f32> {
    mesh.vertices
        .par_iter()
        .map(|&p| {
            domain
                .voxels
                .cell_near(p)
                .map_or(f32::NAN, |c| values[c as usize])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GateMode;

    #[test]
    fn an_unproven_search_says_how_much_a_candidate_could_still_gain() {
        let search = |value: f64, lower_bound: f64, proven: bool| Balanced {
            candidate: 0,
            value,
            lower_bound,
            runs: 40,
            proven,
        };
        // No candidate's value is below the bound: 50 mm against a bound of 45 leaves 10 %.
        let open = search(50.0, 45.0, false);
        assert!((open.unproven_gap_pct().unwrap() - 10.0).abs() < 1e-12);
        assert_eq!(
            open.unproven_words(),
            "not proven optimal after 40 flow fields: a candidate could be up to 10.0 % lower"
        );
        // A proven search leaves nothing to say; one without usable numbers gives no figure.
        assert_eq!(search(50.0, 49.9, true).unproven_gap_pct(), None);
        assert_eq!(search(50.0, 49.9, true).unproven_words(), "");
        assert_eq!(search(0.0, 0.0, false).unproven_gap_pct(), None);
        assert_eq!(
            search(50.0, f64::NAN, false).unproven_words(),
            "not proven optimal after 40 flow fields"
        );
        // A bound below zero (it never is) counts as zero: at most the whole value.
        assert_eq!(search(50.0, -1.0, false).unproven_gap_pct(), Some(100.0));
    }

    /// The walls' summary by a whole sort: the oracle of [`summarise_walls`]'s selection.
    fn sorted_summary(voxels: &Voxels, per_triangle: &[f32]) -> [Option<f64>; 6] {
        let mut values: Vec<f32> = voxels
            .triangle
            .iter()
            .zip(&voxels.surface)
            .filter(|(_, &s)| s)
            .map(|(&t, _)| per_triangle[t as usize])
            .filter(|v| v.is_finite())
            .collect();
        values.sort_by(f32::total_cmp);
        let q = |f: f64| {
            (!values.is_empty())
                .then(|| values[((values.len() - 1) as f64 * f).round() as usize] as f64)
        };
        let sliver = q(0.5).map_or(0.0, |n| crate::thickness::SLIVER_OF_NOMINAL * n);
        let slivers = values.iter().take_while(|&&v| (v as f64) < sliver).count();
        [
            values.get(slivers).map(|&v| v as f64),
            Some(slivers as f64),
            q(0.05),
            q(0.5),
            q(0.95),
            q(1.0),
        ]
    }

    #[test]
    fn the_99_percent_time_is_the_value_of_its_rank_and_a_far_tail_is_warned() {
        // 1..=200 with unreached cells among them: rank ceil(0.99 * 200) = 198.
        let mut t: Vec<f64> = (1..=200).rev().map(f64::from).collect();
        t.extend([f64::INFINITY; 7]);
        assert_eq!(percentile_99(&t), 198.0);
        assert_eq!(percentile_99(&[5.0]), 5.0);
        assert_eq!(percentile_99(&[f64::INFINITY]), 0.0);
        // By a sort, on values with ties.
        let t: Vec<f64> = (0..1001).map(|i| f64::from(i % 37)).collect();
        let mut sorted = t.clone();
        sorted.sort_by(f64::total_cmp);
        assert_eq!(
            percentile_99(&t),
            sorted[(1001 * 99usize).div_ceil(100) - 1]
        );
        let fill = |last: f64, most: f64| GateFill {
            gate: [0.0; 3],
            body: 0,
            reached_share: 1.0,
            wall_across_mm: 2.0,
            l_max_mm: 10.0,
            l_mean_mm: 5.0,
            farthest: [0.0; 3],
            fill_time_s: last,
            fill_time_99_s: most,
            flow_ratio: 5.0,
            flow_ratio_limit: None,
            exceeds_flow_ratio: false,
            pressure_mpa: 1.0,
            last_to_fill: Vec::new(),
            weld_lines: Vec::new(),
        };
        assert!(
            late_tail_warning(&fill(0.02, 0.01), "paper gate").is_none(),
            "twice is not far"
        );
        let w = late_tail_warning(&fill(0.0344, 0.0161), "paper gate").expect("over twice");
        assert!(w.contains("0.0344 s") && w.contains("0.0161 s"), "{w}");
        assert!(late_tail_warning(&fill(0.01, 0.0), "paper gate").is_none());
        let w = late_tail_warning(&fill(0.0344, 0.0161), "aesthetic gate").expect("over twice");
        assert!(
            w.contains("the aesthetic gate's fill time is 0.0344 s"),
            "{w}"
        );
    }

    /// Under the resistance objective, one thin place that fills last from the paper gate
    /// and from the balanced gate alike, with the balanced gate moved next to it, is said
    /// (the deskhop case's floor: 13.3 mm of flow path from it, L_max 61.2 -> 96.8 mm); a
    /// different last place, a gate still far from it or the length objective is not.
    #[test]
    fn a_slow_place_that_chose_the_balanced_gate_is_said() {
        let gate_fill = |l_max: f64, last: [f64; 3], to_last: f64| GateFill {
            gate: [0.0; 3],
            body: 0,
            reached_share: 1.0,
            wall_across_mm: 2.0,
            l_max_mm: l_max,
            l_mean_mm: l_max / 2.0,
            farthest: [0.0; 3],
            fill_time_s: 0.03,
            fill_time_99_s: 0.02,
            flow_ratio: 5.0,
            flow_ratio_limit: None,
            exceeds_flow_ratio: false,
            pressure_mpa: 1.0,
            last_to_fill: vec![PointValue {
                point: last,
                flow_length_mm: to_last,
                fill_time_s: 0.03,
            }],
            weld_lines: Vec::new(),
        };
        let balanced = |fill: GateFill| BalancedFill {
            fill,
            search: Balanced {
                candidate: 0,
                value: 0.02,
                lower_bound: 0.02,
                runs: 3,
                proven: true,
            },
            improvement_pct: 40.0,
            is_paper_gate: false,
        };
        let paper = gate_fill(61.2, [32.3, -96.2, 10.6], 49.8);
        let near = balanced(gate_fill(96.8, [32.5, -96.0, 10.6], 13.3));
        let w = slow_place_warning(&paper, &near, Objective::Resistance, 0.9).expect("said");
        assert!(
            w.contains(
                "moved from 49.8 to 13.3 mm of flow path from it, at the cost of L_max 61.2 -> 96.8 mm"
            ),
            "{w}"
        );
        assert!(slow_place_warning(&paper, &near, Objective::Length, 0.9).is_none());
        let elsewhere = balanced(gate_fill(96.8, [60.0, -96.0, 10.6], 13.3));
        assert!(slow_place_warning(&paper, &elsewhere, Objective::Resistance, 0.9).is_none());
        let far = balanced(gate_fill(96.8, [32.5, -96.0, 10.6], 60.0));
        assert!(slow_place_warning(&paper, &far, Objective::Resistance, 0.9).is_none());
        // The paper gate already near the place (the watchy top's 14.9 against 11.6 mm): the
        // balanced gate did not move to it.
        let near_paper = gate_fill(61.2, [32.3, -96.2, 10.6], 14.9);
        let close = balanced(gate_fill(63.9, [32.5, -96.0, 10.6], 11.6));
        assert!(slow_place_warning(&near_paper, &close, Objective::Resistance, 0.9).is_none());
    }

    #[test]
    fn the_walls_quantiles_by_selection_are_those_of_a_sort() {
        let mesh = crate::samples::sample("cover").expect("sample");
        let voxels = Voxels::new(&mesh, 1.0);
        let n = mesh.triangles.len();
        let mut x = 0.137f64;
        let mut next = || {
            x = (x * 7919.0 + 0.71).rem_euclid(1.0);
            x
        };
        // Walls with ties, slivers, unknowns, and as few known values as 0 to 3.
        for round in 0..60 {
            let known = match round {
                0..=3 => round as f64 / n as f64,
                _ => next(),
            };
            let walls: Vec<f32> = (0..n)
                .map(|i| match next() {
                    _ if round <= 3 && i >= round => f32::NAN,
                    r if r > known.max(0.05) && round > 3 => f32::NAN,
                    r if r < 0.1 => 0.001,
                    r if r < 0.3 => 2.0,
                    _ => (next() * 4.0) as f32,
                })
                .collect();
            let got = summarise_walls(&voxels, &walls, 0.0);
            let want = sorted_summary(&voxels, &walls);
            assert_eq!(
                [
                    got.min_mm,
                    Some(got.slivers as f64),
                    got.p05_mm,
                    got.nominal_mm,
                    got.p95_mm,
                    got.max_mm
                ],
                want,
                "round {round}"
            );
            let bodies = body_nominal_walls(&voxels, &walls);
            assert_eq!(bodies[0].is_nan(), want[3].is_none(), "round {round}");
            if let Some(median) = want[3] {
                assert_eq!(bodies[0], median, "round {round}");
            }
        }
    }

    #[test]
    fn bodies_known_to_be_one_are_the_union_s() {
        let same = |a: &Bodies, b: &Bodies| {
            assert_eq!(a.of_triangle, b.of_triangle);
            assert_eq!((a.count, a.stray), (b.count, b.stray));
            assert_eq!(a.volume_mm3, b.volume_mm3);
            assert_eq!(a.centre, b.centre);
        };
        for info in crate::samples::SAMPLES {
            let mesh = crate::samples::sample(info.name).expect("sample");
            let counted = crate::mesh::Topology::new(&mesh).bodies;
            same(
                &Bodies::of_counted(&mesh, Some(counted)),
                &Bodies::of(&mesh),
            );
        }
        // A facet collapsed to a vertex of its own: a body to the union, none to the count.
        let mut mesh = crate::samples::sample("plate").expect("sample");
        let alone = mesh.vertices.len() as u32;
        mesh.vertices.push(crate::math::DVec3::new(100.0, 0.0, 0.0));
        mesh.triangles.push([alone; 3]);
        let counted = crate::mesh::Topology::new(&mesh).bodies;
        assert_eq!(counted, 1);
        let union = Bodies::of(&mesh);
        assert_eq!(union.stray, 1);
        same(&Bodies::of_counted(&mesh, Some(counted)), &union);
    }

    #[test]
    fn the_bodies_sums_give_the_limits_of_their_kept_triangles() {
        let close = |a: f64, b: f64, what: &str| {
            assert!(
                (a - b).abs() <= 1e-12 * a.abs().max(b.abs()),
                "{what}: {a} {b}"
            );
        };
        // Every sample, and one with a stray facet far off (a body of its own, left out).
        let mut parts: Vec<Mesh> = crate::samples::SAMPLES
            .iter()
            .map(|info| crate::samples::sample(info.name).expect("sample"))
            .collect();
        let mut stray = crate::samples::sample("plate").expect("sample");
        let n = stray.vertices.len() as u32;
        stray.vertices.extend([
            DVec3::new(500.0, 0.0, 0.0),
            DVec3::new(500.1, 0.0, 0.0),
            DVec3::new(500.0, 0.1, 0.0),
        ]);
        stray.triangles.push([n, n + 1, n + 2]);
        parts.push(stray);
        for mesh in &parts {
            let bodies = Bodies::of(mesh);
            let keep: Vec<bool> = bodies.of_triangle.iter().map(|&b| b != u32::MAX).collect();
            let kept = bodies.kept;
            // Against a plain pass over the kept triangles.
            let (mut volume, mut area) = (0.0, 0.0);
            for t in (0..mesh.triangles.len()).filter(|&t| keep[t]) {
                let [p, q, r] = mesh.corners(t);
                volume += p.dot(q.cross(r)) / 6.0;
                area += 0.5 * (q - p).cross(r - p).length();
            }
            close(kept.volume, volume, "volume");
            close(kept.area, area, "area");
            assert_eq!(kept.triangles, keep.iter().filter(|&&k| k).count() as f64);
            // The same sums from the parallel pass that `cell_size` makes.
            let of = LimitSums::of(mesh, &bodies.of_triangle);
            close(of.volume, kept.volume, "volume of");
            close(of.side2, kept.side2, "side2 of");
            let diagonal = mesh.bounds().diagonal();
            for h in [diagonal / 300.0, diagonal / 31.0, diagonal / 2.0] {
                let bound = kept.samples_bound(h);
                close(bound, voxel::samples_bound(mesh, h, Some(&keep)), "bound");
                assert!(bound >= voxel::samples_for(mesh, h, Some(&keep)));
            }
        }
    }

    /// The balanced search as it was before its runs from far points stopped early (every
    /// run whole): the oracle of [`balanced_search`].
    fn reference_balanced(
        domain: &Domain,
        candidates: &[Source],
        objective: Objective,
        first: Source,
        start: &Field,
        tolerance: f64,
    ) -> Option<Balanced> {
        let cost = domain.cost(objective);
        let v = &domain.voxels;
        let body = domain.body[first.cell as usize];
        let pool = in_body(domain, candidates, body);
        if pool.is_empty() {
            return None;
        }
        let mut runs = 1;
        let mut far = far_points(v, &start.t, FAR_POINTS);
        let mut bound = vec![0.0f64; candidates.len()];
        let mut seen: Option<(f64, usize)> = None;
        let centred = |c: u32| Source {
            point: v.centre(c),
            cell: c,
        };
        loop {
            for &f in &far {
                let field = march(v, &[centred(f)], cost);
                runs += 1;
                for &i in &pool {
                    bound[i] = bound[i].max(field.t[candidates[i].cell as usize]);
                }
            }
            let &best = pool
                .iter()
                .min_by(|&&a, &&b| bound[a].total_cmp(&bound[b]).then(a.cmp(&b)))
                .expect("non-empty pool");
            let field = march(v, &[centred(candidates[best].cell)], cost);
            runs += 1;
            let value = argmax(&field.t).1;
            if seen.is_none_or(|(v, _)| value < v) {
                seen = Some((value, best));
            }
            let proven = value <= bound[best] + tolerance;
            if proven || runs >= 40 {
                let (value, candidate) = if proven {
                    (value, best)
                } else {
                    seen.expect("one run")
                };
                return Some(Balanced {
                    candidate,
                    value,
                    lower_bound: bound[best],
                    runs,
                    proven,
                });
            }
            far = far_points(v, &field.t, FAR_POINTS);
        }
    }

    #[test]
    fn a_layout_s_given_field_takes_the_place_of_its_kind() {
        use crate::samples::sample;
        let pp = Material::builtin("PP").expect("PP");
        let mesh = sample("bracket").expect("sample");
        let domain = Domain::new(&mesh, 1.0, None, 2.0, &pp);
        // Costs that differ from cell to cell and from each other, so that a field in the
        // wrong place shows.
        let n = domain.voxels.len();
        let domain = Domain {
            fill_cost: (0..n).map(|i| 1.0 + (i % 5) as f32 * 0.3).collect(),
            pressure_cost: (0..n).map(|i| 1.0 + (i % 3) as f32 * 0.7).collect(),
            ..domain
        };
        let sources = [Source {
            point: domain.voxels.centre(7),
            cell: 7,
        }];
        let bits = |f: &Field| f.t.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
        let whole = march_layout(&domain, &sources, [None, None, None]);
        for kind in Kind::ALL {
            let mut given = [None, None, None];
            given[kind as usize] = Some(march(&domain.voxels, &sources, kind.cost(&domain)));
            let layout = march_layout(&domain, &sources, given);
            for (a, b) in layout.iter().zip(&whole) {
                assert_eq!(bits(a), bits(b), "{kind:?}");
            }
        }
        assert_ne!(bits(&whole[0]), bits(&whole[1]));
        assert_ne!(bits(&whole[1]), bits(&whole[2]));
        for objective in [Objective::Length, Objective::Resistance] {
            assert_eq!(Kind::of(objective).cost(&domain), domain.cost(objective));
        }
    }

    /// The candidates of a layout's gates, in order.
    fn layout_gates(m: &MultiGate) -> Vec<usize> {
        m.gates.iter().map(|g| g.candidate).collect()
    }

    /// A balanced gate worse than the paper gate by a measure it did not minimise is warned,
    /// with both values; one better or equal by every other measure (or worse by less than
    /// [`OTHER_MEASURE_WORSE_SHARE`]) is not.
    #[test]
    fn a_balanced_gate_worse_by_another_measure_is_warned() {
        let fill = |l_max_mm: f64, fill_time_s: f64, pressure_mpa: f64| GateFill {
            gate: [0.0; 3],
            body: 0,
            reached_share: 1.0,
            wall_across_mm: 2.0,
            l_max_mm,
            l_mean_mm: 0.5 * l_max_mm,
            farthest: [0.0; 3],
            fill_time_s,
            fill_time_99_s: fill_time_s,
            flow_ratio: l_max_mm / 2.0,
            flow_ratio_limit: None,
            exceeds_flow_ratio: false,
            pressure_mpa,
            last_to_fill: Vec::new(),
            weld_lines: Vec::new(),
        };
        let paper = fill(37.8, 0.0358, 4.15);
        // Watchy's bottom by fill time: shorter, but a longer path at a higher pressure.
        let w = worse_by_other_measures(
            Objective::Resistance,
            GateMode::Paper,
            &paper,
            &fill(61.7, 0.0277, 6.89),
        )
        .expect("worse by two measures");
        assert_eq!(
            w,
            "the balanced gate minimises the fill time only: against the paper gate it is worse in longest flow path L_max 37.8 -> 61.7 mm (+63 %), pressure 4.15 -> 6.89 MPa (+66 %) (paper -> balanced); --objective length minimises the longest flow path L_max instead"
        );
        // By length: the fill time counts, the L_max does not.
        let w = worse_by_other_measures(
            Objective::Length,
            GateMode::Aesthetic,
            &paper,
            &fill(35.0, 0.0369, 4.0),
        )
        .expect("worse by the fill time");
        // Compared with the answer's gate, here the aesthetic one.
        assert!(
            w.contains("against the aesthetic gate it is worse in fill time 0.0358 -> 0.0369 s (+3 %) (aesthetic -> balanced)"),
            "{w}"
        );
        assert!(!w.contains("pressure") && !w.contains("L_max 37.8"), "{w}");
        // Within 1 %, or better: nothing.
        let close = fill(37.8 * 1.009, 0.0358 * 1.009, 4.15 * 1.009);
        assert_eq!(
            worse_by_other_measures(Objective::Length, GateMode::Paper, &paper, &close),
            None
        );
        assert_eq!(
            worse_by_other_measures(Objective::Resistance, GateMode::Paper, &paper, &close),
            None
        );
    }

    /// The warning for gates a layout does without reads right for one, two and more, and
    /// for a layout of two.
    #[test]
    fn gates_a_layout_does_without_are_named_one_at_a_time() {
        let layout = |shares: &[f64], redundant: Vec<usize>| MultiGate {
            gates: shares
                .iter()
                .map(|&s| GateShare {
                    candidate: 0,
                    point: [0.0; 3],
                    body: 0,
                    volume_share: s,
                    l_max_mm: None,
                    fill_time_s: Some(0.01),
                })
                .collect(),
            l_max_mm: None,
            fill_time_s: Some(0.00621),
            layout_fill_time_s: Some(0.00621),
            fill: None,
            improvement_pct: 5.5,
            balance: 0.1,
            runs: 1,
            redundant,
            bodies: 1,
        };
        let w = redundant_warning(&layout(&[0.5, 0.3, 0.2], vec![2]), Objective::Resistance);
        assert!(w.starts_with("gate 3 of the layout of 3 (20.0 % of the volume) adds nothing to the layout's fill time: without it, the other 2 gates reach no place later than its 0.00621 s"), "{w}");
        assert!(
            w.contains(
                "so by this measure, which the slowest place alone sets, 2 gates do as well"
            ),
            "{w}"
        );
        let w = redundant_warning(
            &layout(&[0.4, 0.3, 0.2, 0.1], vec![0, 2, 3]),
            Objective::Resistance,
        );
        assert!(w.starts_with("gates 1, 3 and 4 of the layout of 4 (40.0, 20.0 and 10.0 % of the volume) each add nothing"), "{w}");
        assert!(
            w.contains("without any one of them (one at a time, not all), the other 3 gates reach"),
            "{w}"
        );
        let w = redundant_warning(&layout(&[0.6, 0.4], vec![0, 1]), Objective::Resistance);
        assert!(
            w.contains("without either one (one at a time, not both), the other gate reaches"),
            "{w}"
        );
        assert!(w.contains("one gate does as well"), "{w}");
    }

    /// Idle gates of a layout are warned; a sound layout is not.
    #[test]
    fn idle_layout_gates_are_warned() {
        let gate = |x: f64, share: f64| GateShare {
            candidate: 0,
            point: [x, 0.0, 0.0],
            body: 0,
            volume_share: share,
            l_max_mm: None,
            fill_time_s: None,
        };
        let layout = |gates: Vec<GateShare>| MultiGate {
            gates,
            l_max_mm: Some(10.0),
            fill_time_s: None,
            layout_fill_time_s: None,
            fill: None,
            improvement_pct: 1.0,
            balance: 0.0,
            runs: 1,
            redundant: Vec::new(),
            bodies: 1,
        };
        let sound = layout(vec![gate(0.0, 0.5), gate(10.0, 0.49), gate(20.0, 0.01)]);
        assert_eq!(idle_gates(&sound), None);
        let bad = layout(vec![
            gate(0.0, 0.497),
            gate(10.0, 0.048),
            gate(13.0, 0.0),
            gate(30.0, 0.454),
            gate(40.0, 0.001),
        ]);
        let w = idle_gates(&bad).expect("two idle gates");
        assert!(w.starts_with("2 of the layout of 5 gates fill less than 1 % of the volume each (gate 3 (0.0 %), gate 5 (0.1 %))"), "{w}");
        assert!(
            w.ends_with("a thicker wall there may serve better than a gate"),
            "{w}"
        );
    }

    /// The map's best node is the balanced gate only when the search is unproven, the node
    /// exact, and its gate better by more than a cell.
    #[test]
    fn the_map_s_best_exact_node_replaces_an_unproven_search_s_worse_gate() {
        let pp = Material::builtin("PP").expect("PP");
        let mesh = crate::samples::sample("plate").expect("sample");
        let domain = Domain::new(&mesh, 1.5, None, 2.0, &pp);
        let candidates: Vec<Source> = (0..domain.voxels.len() as u32)
            .step_by(37)
            .filter_map(|c| domain.source(domain.voxels.centre(c) + DVec3::new(0.11, -0.07, 0.05)))
            .collect();
        let value = |i: usize| argmax(&march(&domain.voxels, &[candidates[i]], None).t).1;
        let values: Vec<f64> = (0..candidates.len()).map(value).collect();
        let best = (0..values.len())
            .min_by(|&a, &b| values[a].total_cmp(&values[b]))
            .unwrap();
        let worst = (0..values.len())
            .max_by(|&a, &b| values[a].total_cmp(&values[b]))
            .unwrap();
        let h = domain.voxels.h;
        assert!(values[worst] - values[best] > 2.0 * h);
        let map = |node: usize, kind| suitability::Suitability {
            objective: Objective::Length,
            unit: "mm",
            tolerance: h,
            nodes: vec![suitability::NodeScore {
                node: 0,
                point: candidates[node].point.to_array(),
                body: 0,
                score: values[node],
                upper: Some(values[node]),
                kind,
            }],
            best: Some(0),
            best_per_body: vec![Some(0)],
            exact: 1,
            max_gap_pct: Some(0.0),
            median_gap_pct: Some(0.0),
            off_part: 0,
            runs: 1,
        };
        let search = |i: usize, proven| Balanced {
            candidate: i,
            value: values[i],
            lower_bound: 0.0,
            runs: 40,
            proven,
        };
        let value_of: fn(&GateFill) -> f64 = |f| f.l_max_mm;
        let first = candidates[worst];
        let take = |node: usize, kind, b: &Balanced| {
            let from = (&candidates[..], first);
            map_best_gate(&domain, from, &map(node, kind), b, &pp, (value_of, h))
        };
        let exact = suitability::ScoreKind::Exact;
        let got = take(best, exact, &search(worst, false)).expect("the map's node");
        assert_eq!(got.search.candidate, best);
        assert!(got.search.proven);
        assert!(got.search.value < values[worst] - h);
        assert_eq!(got.fill.gate, candidates[best].point.to_array());
        // A proven search, a node bounded only, or no gain of more than a cell: kept.
        assert!(take(best, exact, &search(worst, true)).is_none());
        let bounded = suitability::ScoreKind::LowerBound;
        assert!(take(best, bounded, &search(worst, false)).is_none());
        assert!(take(best, exact, &search(best, false)).is_none());
    }

    /// Five samples' domains (cells of 1.5 mm, PP) with every fifth cell a candidate,
    /// each a little off its cell's centre: the several-gate searches' test cases.
    fn sample_domains() -> Vec<(&'static str, Domain, Vec<Source>)> {
        let pp = Material::builtin("PP").expect("PP");
        ["plate", "bracket", "cover", "tray", "cap"]
            .into_iter()
            .map(|name| {
                let mesh = crate::samples::sample(name).expect("sample");
                let domain = Domain::new(&mesh, 1.5, None, 2.0, &pp);
                let candidates = (0..domain.voxels.len() as u32)
                    .step_by(5)
                    .map(|c| Source {
                        point: domain.voxels.centre(c) + DVec3::new(0.11, -0.07, 0.05),
                        cell: c,
                    })
                    .collect();
                (name, domain, candidates)
            })
            .collect()
    }

    /// The least distance between two gates in the layout tests: the diameter of PP's gate.
    const APART: f64 = 2.85;

    /// A search for `k` gates by `objective`, [`APART`] apart.
    fn ask(objective: Objective, k: usize) -> Ask {
        Ask {
            objective,
            k,
            min_distance_mm: APART,
        }
    }

    /// How many of the cases `case` counts: every sample of [`sample_domains`] with both
    /// objectives and each count of gates in `ks` (the case's name for its messages), the
    /// samples side by side.
    fn count_cases(
        ks: [usize; 2],
        case: impl Fn(&str, &Domain, &[Source], Objective, usize) -> bool + Sync,
    ) -> usize {
        sample_domains()
            .par_iter()
            .map(|(name, domain, candidates)| {
                let mut counted = 0;
                for objective in [Objective::Length, Objective::Resistance] {
                    for k in ks {
                        let what = format!("{name} {objective:?} k {k}");
                        counted += case(&what, domain, candidates, objective, k) as usize;
                    }
                }
                counted
            })
            .sum()
    }

    /// A stopped study's several-gate search gives up before its next march (each would
    /// make its arrays of every cell before it stopped), the clustered start before its
    /// next pass over the cells, and the test of redundant gates names none.
    #[test]
    fn a_stopped_several_gate_search_gives_up() {
        let (_, mut domain, candidates) = sample_domains().swap_remove(2);
        let pool: Vec<usize> = (0..candidates.len()).collect();
        let body = domain.body[candidates[0].cell as usize];
        let layout =
            several_gates(&domain, &candidates, Objective::Length, 0, 3, APART).expect("a layout");
        assert!(clustered_layout(&domain, &candidates, &pool, body, 3, APART).is_some());
        let token = crate::cancel::Cancel::new();
        token.cancel();
        domain.voxels.cancel = Some(token);
        assert!(several_gates_search(
            &domain,
            &candidates,
            ask(Objective::Length, 3),
            0,
            None,
            true,
            None
        )
        .is_none());
        assert!(clustered_layout(&domain, &candidates, &pool, body, 3, APART).is_none());
        assert!(redundant_gates(&domain, &candidates, Objective::Length, &layout, 0.0).is_empty());
    }

    #[test]
    fn the_layout_of_the_starts_is_the_best_of_them_and_never_worse_than_the_first() {
        let better = count_cases([2, 3], |what, domain, candidates, objective, k| {
            let both = several_gates(domain, candidates, objective, 0, k, APART).expect("k");
            let one =
                several_gates_search(domain, candidates, ask(objective, k), 0, None, true, None)
                    .expect("k");
            assert!(both.value() <= one.value(), "{what}");
            assert!(both.runs > one.runs, "{what}: every start's marches count");
            let better = both.value() < one.value();
            if !better {
                assert_eq!(
                    layout_gates(&both),
                    layout_gates(&one),
                    "{what}: the first start's kept"
                );
            }
            better
        });
        // The second start matters: it finds the better layout on some of these 20.
        assert!(better >= 3, "{better}");
    }

    #[test]
    fn several_gates_examined_ahead_are_those_examined_one_after_the_other() {
        let dropped = count_cases([3, 4], |what, domain, candidates, objective, k| {
            let run = |ahead| {
                several_gates_search(domain, candidates, ask(objective, k), 0, None, ahead, None)
                    .expect("enough candidates")
            };
            let (new, old) = (run(true), run(false));
            assert_eq!(layout_gates(&new), layout_gates(&old), "{what}");
            assert_eq!(new.value().to_bits(), old.value().to_bits(), "{what}");
            assert_eq!(new.balance.to_bits(), old.balance.to_bits(), "{what}");
            assert!(new.runs >= old.runs, "{what}");
            // Examinations made ahead and dropped (a move was kept) add runs.
            new.runs > old.runs
        });
        assert!(dropped > 2, "{dropped}");
    }

    #[test]
    fn the_balanced_search_with_runs_stopped_early_is_the_search_of_whole_runs() {
        use crate::samples::sample;
        let pp = Material::builtin("PP").expect("PP");
        let cases: Vec<(&str, f64)> = ["plate", "bracket", "cover", "tray", "cap"]
            .into_iter()
            .flat_map(|name| [(name, 1.0), (name, 1.5)])
            .collect();
        // The cases side by side.
        cases.par_iter().for_each(|&(name, h)| {
            let mesh = sample(name).expect("sample");
            let domain = Domain::new(&mesh, h, None, 2.0, &pp);
            let n = domain.voxels.len() as u32;
            // Candidates spread over the cells, cell centres nudged off as surface
            // points are; the first gate one of them.
            let candidates: Vec<Source> = (0..n)
                .step_by(7)
                .map(|c| Source {
                    point: domain.voxels.centre(c) + DVec3::new(0.11, -0.07, 0.05),
                    cell: c,
                })
                .collect();
            let first = candidates[candidates.len() / 3];
            for objective in [Objective::Length, Objective::Resistance] {
                let start = march(&domain.voxels, &[first], domain.cost(objective));
                let old =
                    reference_balanced(&domain, &candidates, objective, first, &start, 0.5 * h)
                        .expect("a pool");
                // Reaches far too short (every run stopped, the bounds completed),
                // about the least bound, the one used, and one no run gets to.
                for far_reach in [0.3, 0.7, 0.95, FAR_REACH, 10.0] {
                    let new = balanced_search(
                        &domain,
                        &candidates,
                        objective,
                        first,
                        &start,
                        0.5 * h,
                        far_reach,
                        (SIDE_MARCH_ROUNDS, |c| c),
                    )
                    .expect("a pool");
                    let what = format!("{name} h {h} {objective:?} reach {far_reach}");
                    // What ran beside the chosen candidate's run is its own; it ran only
                    // where a thread was idle, so it may be missing.
                    let Searched {
                        found: new, aside, ..
                    } = new;
                    assert!(aside.is_none_or(|c| c == new.candidate), "{what}");
                    assert_eq!(new.candidate, old.candidate, "{what}");
                    assert_eq!(new.value.to_bits(), old.value.to_bits(), "{what}");
                    assert_eq!(
                        new.lower_bound.to_bits(),
                        old.lower_bound.to_bits(),
                        "{what}"
                    );
                    assert_eq!((new.runs, new.proven), (old.runs, old.proven), "{what}");
                }
            }
        });
    }

    #[test]
    fn the_balanced_search_works_beside_its_first_runs_only_on_an_idle_thread() {
        // On one thread nothing is idle: the work beside each run is never made (it would
        // be dropped for every candidate but the last), and the choice is the same as on
        // two threads, where an idle thread makes it for the runs it reaches in time, and
        // only in the first rounds asked for. The tray's search takes two rounds.
        let pp = Material::builtin("PP").expect("PP");
        let mesh = crate::samples::sample("tray").expect("sample");
        let domain = Domain::new(&mesh, 1.5, None, 2.0, &pp);
        let n = domain.voxels.len() as u32;
        let candidates: Vec<Source> = (0..n)
            .step_by(5)
            .map(|c| Source {
                point: domain.voxels.centre(c),
                cell: c,
            })
            .collect();
        let first = candidates[0];
        let start = march(&domain.voxels, &[first], None);
        let asked = std::sync::atomic::AtomicUsize::new(0);
        let on = |threads: usize, side_rounds: usize| {
            asked.store(0, std::sync::atomic::Ordering::Relaxed);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            let found = pool.install(|| {
                balanced_search(
                    &domain,
                    &candidates,
                    Objective::Length,
                    first,
                    &start,
                    0.75,
                    FAR_REACH,
                    (side_rounds, |c| {
                        asked.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        c
                    }),
                )
                .expect("a pool")
            });
            (found, asked.load(std::sync::atomic::Ordering::Relaxed))
        };
        let (one, beside) = on(1, usize::MAX);
        assert_eq!(
            (one.aside, beside),
            (None, 0),
            "one thread: nothing beside the runs"
        );
        assert!(one.found.runs > 1, "the search ran no candidate");
        assert!(one.rounds > 1, "{} rounds: too few to test", one.rounds);
        for side_rounds in [0, 1, 2, SIDE_MARCH_ROUNDS, usize::MAX] {
            let (two, beside) = on(2, side_rounds);
            let what = format!("beside the first {side_rounds} rounds");
            assert!(
                beside <= side_rounds.min(two.rounds),
                "{what}: {beside} asked"
            );
            assert!(two.aside.is_none_or(|c| c == two.found.candidate), "{what}");
            if two.rounds > side_rounds {
                assert_eq!(two.aside, None, "{what}: the last round had nothing beside");
            }
            assert_eq!(two.found.candidate, one.found.candidate, "{what}");
            assert_eq!(
                two.found.value.to_bits(),
                one.found.value.to_bits(),
                "{what}"
            );
            assert_eq!(
                (two.found.runs, two.found.proven, two.rounds),
                (one.found.runs, one.found.proven, one.rounds),
                "{what}"
            );
        }
    }
}
