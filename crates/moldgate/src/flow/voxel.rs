//! The part as a set of solid voxels: the domain the melt flows through.
//!
//! A cell of side `h` is solid when
//! - its centre lies inside the closed surface (winding number along +Z columns: each column
//!   of cell centres crosses the triangles, entering through faces whose normal points down
//!   and leaving through faces whose normal points up; a column whose crossings do not sum
//!   to zero, as on an open mesh, fills nothing), or
//! - the surface passes through it (every triangle is covered by rows of samples parallel
//!   to its longest edge, rows and samples at most h/2 apart, and the cell of each sample is
//!   marked; the count grows with the triangle's area and perimeter, and is bounded before
//!   the work by [`samples_for`]).
//!
//! The surface cells keep walls thinner than a cell connected, and make an open mesh a
//! shell of cells the melt can still flow along.
//!
//! **Bodies.** Each cell belongs to one body of the mesh (a connected set of triangles,
//! [`crate::mesh::topology::body_of_triangle`]): a surface cell to the body of its triangle,
//! an interior cell to the body whose surface its column entered. Two cells of different
//! bodies are never neighbours, whatever the cell size: melt does not jump the air between
//! a lid and its box, even where they share a cell. (A cell crossed by two bodies' surfaces
//! goes to one of them.)
//!
//! **The triangle of a surface cell.** Of the triangles that pass through a cell, the cell
//! keeps the one whose centroid, where the fill measures its wall, is nearest the cell's
//! centre (of two at one distance, the larger by [`triangle_rank`]): a rule of the
//! triangles' corners alone, so that the same part gives the same cells and walls whatever
//! the order of its triangles in the file or of the corners in each, and one that samples
//! the wall where the cell is rather than at a large triangle's far centroid.
//!
//! The grid origin is shifted by a small irrational fraction of a cell so that cell centres
//! do not fall exactly on the axis-aligned faces and edges of CAD meshes.

use rayon::prelude::*;

use crate::math::{orient2d, Aabb, DVec2, DVec3};
use crate::mesh::Mesh;

/// Marker for "no solid cell here" in the dense index.
const EMPTY: u32 = u32::MAX;

/// The triangles `0..n` in blocks of 4096, in order, for a parallel pass whose results are
/// collected block by block.
/// The order in which triangles whose centroids lie at one distance from a cell's centre
/// give way to each other (the largest rank keeps the cell): the triangle's squared doubled area, rounded to `f32`, in the high
/// half, and a hash of its corners in the low half (equal areas are common: a CAD mesh of a
/// flat face is often a grid of equal triangles). Both are found from the corners sorted,
/// and the hash sums the corners' hashes, so the rank depends on neither the triangle's
/// place in the mesh nor the order of its corners.
fn triangle_rank(corners: [DVec3; 3]) -> u64 {
    let c = sorted_corners(corners);
    let area2 = (c[1] - c[0]).cross(c[2] - c[0]).length_squared() as f32;
    // A non-negative f32's bits order as the number (a NaN area ranks above all: its
    // triangle has no body and marks no cell).
    let area_bits = if area2 >= 0.0 {
        area2.to_bits()
    } else {
        u32::MAX
    };
    // splitmix64's finaliser over each corner's bits, summed.
    let mix = |mut x: u64| {
        x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        x ^ (x >> 31)
    };
    let hash = c.iter().fold(0u64, |h, p| {
        h.wrapping_add(mix(p.x.to_bits()
            ^ p.y.to_bits().rotate_left(21)
            ^ p.z.to_bits().rotate_left(42)))
    });
    (u64::from(area_bits) << 32) | (hash >> 32)
}

/// The cells a block of triangles marks, as (cell, triangle), and each mark's squared
/// distance from its cell's centre to its triangle's centroid (f32 bits).
type Marks = (Vec<(u32, u32)>, Vec<u32>);

/// The centroid of a triangle, the same to the last bit whatever the order of its corners:
/// each coordinate is summed least, middle, largest.
#[inline]
fn centroid([a, b, c]: [DVec3; 3]) -> DVec3 {
    let (least, most) = (a.min(b).min(c), a.max(b).max(c));
    let middle = a.min(b).max(a.max(b).min(c));
    (least + middle + most) / 3.0
}

/// The corners of a triangle in one order whatever the order given (by x, then y, then z),
/// so that what is computed from them rounds alike.
#[inline]
fn sorted_corners([a, b, c]: [DVec3; 3]) -> [DVec3; 3] {
    let after = |p: DVec3, q: DVec3| {
        p.x.total_cmp(&q.x)
            .then(p.y.total_cmp(&q.y))
            .then(p.z.total_cmp(&q.z))
            .is_gt()
    };
    // Three compare-and-swaps (a general sort's call costs more than the work).
    let (a, b) = if after(a, b) { (b, a) } else { (a, b) };
    let (b, c) = if after(b, c) { (c, b) } else { (b, c) };
    let (a, b) = if after(a, b) { (b, a) } else { (a, b) };
    [a, b, c]
}

fn chunks(n: usize) -> impl IndexedParallelIterator<Item = std::ops::Range<usize>> {
    const BLOCK: usize = 4096;
    (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(move |b| b * BLOCK..((b + 1) * BLOCK).min(n))
}

/// The 26 neighbours of each solid cell, in [`neighbour_offsets`] order.
#[derive(Debug, Clone)]
pub(crate) enum Neighbours {
    /// As offsets from the cell's own number, 0 where there is none: 52 bytes a cell
    /// against [`Neighbours::Far`]'s 104, taken whenever every offset fits in 16 bits
    /// (cells are numbered layer by layer, so about when a layer of the grid holds fewer
    /// than 32,000 solid cells), so that a march reads half the memory.
    Near(Vec<[i16; 26]>),
    /// As cell numbers, [`EMPTY`] where there is none.
    Far(Vec<[u32; 26]>),
}

impl Neighbours {
    /// The neighbours of cell `c`, [`EMPTY`] where there is none.
    #[inline]
    pub(crate) fn of(&self, c: u32) -> [u32; 26] {
        match self {
            Neighbours::Near(rows) => rows[c as usize].map(|o| match o {
                0 => EMPTY,
                o => (c as i32 + i32::from(o)) as u32,
            }),
            Neighbours::Far(rows) => rows[c as usize],
        }
    }
}

/// Solid cells of a part.
#[derive(Debug, Clone)]
pub struct Voxels {
    /// Centre of cell (0, 0, 0).
    pub origin: DVec3,
    /// Cell side, mm.
    pub h: f64,
    /// Cells along x, y, z.
    pub dims: [usize; 3],
    /// Dense grid: solid cell number or `EMPTY`.
    index: Vec<u32>,
    /// Grid coordinates of each solid cell, in dense order (z-major).
    pub cells: Vec<[u32; 3]>,
    /// Dense index of each solid cell.
    dense: Vec<u32>,
    /// The 26 neighbours of each solid cell (see [`Voxels::neighbour_table`]).
    pub(crate) table: Neighbours,
    /// For each solid cell, a triangle that passes through it or, for interior cells, the
    /// triangle of the nearest surface cell (by breadth-first steps).
    pub triangle: Vec<u32>,
    /// Whether the surface passes through each solid cell.
    pub surface: Vec<bool>,
    /// The body of each solid cell (the body of the triangle that made it); cells of
    /// different bodies are never neighbours.
    pub body: Vec<u32>,
    /// Cells whose centre is inside the surface (the rest are surface cells only).
    pub interior_cells: usize,
    /// Columns whose crossings did not close (open mesh), filled with surface cells only.
    pub open_columns: usize,
    /// Once set, every march through these cells stops within a few thousand cells (see
    /// [`super::march`]); the caller that set it discards what the marches gave.
    pub(crate) cancel: Option<crate::cancel::Cancel>,
}

/// Offsets of the 26 neighbours, with their lengths in cells.
pub(crate) fn neighbour_offsets() -> [([i32; 3], f64); 26] {
    let mut out = [([0; 3], 0.0); 26];
    let mut n = 0;
    for dz in -1..=1 {
        for dy in -1..=1 {
            for dx in -1..=1 {
                if (dx, dy, dz) != (0, 0, 0) {
                    let len = ((dx * dx + dy * dy + dz * dz) as f64).sqrt();
                    out[n] = ([dx, dy, dz], len);
                    n += 1;
                }
            }
        }
    }
    out
}

/// A column's crossing of the surface: ((column, body), z, +1 entering / -1 leaving,
/// triangle).
type Crossing = ((u32, u32), f64, i8, u32);

/// Smallest spacing of surface samples, in cells: every triangle is covered by rows at most
/// this far apart, with samples at most this far apart along each row.
const SAMPLE_STEP: f64 = 0.5;

/// The corners of triangle `t` as (base start, base end, apex), the base its longest edge.
fn base_and_apex(mesh: &Mesh, t: usize) -> (DVec3, DVec3, DVec3) {
    let [a, b, c] = mesh.corners(t);
    let (ab, bc, ca) = (a.distance(b), b.distance(c), c.distance(a));
    if ab >= bc && ab >= ca {
        (a, b, c)
    } else if bc >= ca {
        (b, c, a)
    } else {
        (c, a, b)
    }
}

/// Rows and samples per row (at most) that cover triangle `t` at spacing `step`: the rows
/// run parallel to the longest edge, so the count grows with the triangle's area and
/// perimeter, not with the square of its longest edge (a sliver 1e5 mm long and 0.1 mm
/// wide needs one row, not 1e10 samples).
fn sample_grid(mesh: &Mesh, t: usize, step: f64) -> (usize, usize) {
    let (_, rows, per_row) = sample_rows(mesh, t, step);
    (rows, per_row)
}

/// [`sample_grid`] with the corners it found, as [`base_and_apex`] orders them.
#[inline]
fn sample_rows(mesh: &Mesh, t: usize, step: f64) -> ((DVec3, DVec3, DVec3), usize, usize) {
    let (a, b, c) = base_and_apex(mesh, t);
    let base = a.distance(b);
    let height = if base > 0.0 {
        (b - a).cross(c - a).length() / base
    } else {
        0.0
    };
    // Both quotients are finite and not negative (the coordinates are bounded).
    let rows = ceil_index(height / step).clamp(1, 1e15 as usize);
    let per_row = ceil_index(base / step).clamp(1, 1e15 as usize) + 1;
    ((a, b, c), rows, per_row)
}

/// The grid coordinates of the cell holding `p` in the grid of cells of size `h` from
/// `origin`, `dims` cells along each axis (clamped into the grid).
#[inline]
fn cell_coordinates(p: DVec3, origin: DVec3, h: f64, dims: [usize; 3]) -> [usize; 3] {
    let q = (p - origin) / h + 0.5;
    [
        floor_index(q.x).min(dims[0] - 1),
        floor_index(q.y).min(dims[1] - 1),
        floor_index(q.z).min(dims[2] - 1),
    ]
}

/// The dense number of the cell of grid coordinates `c`.
#[inline]
fn dense_index(c: [usize; 3], dims: [usize; 3]) -> usize {
    (c[2] * dims[1] + c[1]) * dims[0] + c[0]
}

/// `x.floor()` as an index, for `x >= 0` (a truncation, which is the floor there, with no
/// call into the maths library); 0 below.
#[inline]
fn floor_index(x: f64) -> usize {
    x.max(0.0) as usize
}

/// `x.ceil().max(0.0)` as an index.
#[inline]
fn ceil_index(x: f64) -> usize {
    let f = x.max(0.0) as usize;
    f.saturating_add(((f as f64) < x) as usize)
}

/// `x.floor()`, by truncation where `x` is positive and below 2^52 (no call into the
/// maths library there).
#[inline]
fn floor_value(x: f64) -> f64 {
    if x > 0.0 && x < 4.5e15 {
        (x as u64) as f64
    } else {
        x.floor()
    }
}

/// `x.floor()` as a signed index (truncation for `x >= 0`).
#[inline]
fn floor_signed(x: f64) -> isize {
    if x >= 0.0 {
        x as isize
    } else {
        x.floor() as isize
    }
}

/// Marks the cells of triangle `t`'s surface samples (rows at most `step` apart, samples
/// at most `step` apart along each row): `mark(cell)` with the grid coordinates of each
/// cell, once per run of samples in it.
#[inline]
fn mark_samples(
    mesh: &Mesh,
    t: usize,
    step: f64,
    cell_of: &impl Fn(DVec3) -> [usize; 3],
    mut mark: impl FnMut([usize; 3]),
) {
    let ((a, b, c), rows, per_row) = sample_rows(mesh, t, step);
    let mut last = [usize::MAX; 3];
    for r in 0..=rows {
        let s = r as f64 / rows as f64;
        let (p, q) = (a + (c - a) * s, b + (c - b) * s);
        let n = ceil_index((1.0 - s) * (per_row - 1) as f64).max(1);
        for j in 0..=n {
            let cell = cell_of(p + (q - p) * (j as f64 / n as f64));
            if cell != last {
                mark(cell);
                last = cell;
            }
        }
    }
}

/// Margin, in cells, by which a triangle's extreme corners must lie off the cell faces
/// for [`few_cells`]: far above the rounding of a sample's interpolated coordinates (about
/// 1e-15 of the part's size), so the samples fall where the corners do.
const CORNER_MARGIN: f64 = 1e-7;

/// The cells that triangle `t`'s surface samples mark, found from its box alone when the
/// box lies inside one cell, or inside two cells side by side with its lowest and highest
/// corners along their axis inside each (every corner clear of the faces by
/// [`CORNER_MARGIN`]): the samples lie in the box and include the corners, so they mark
/// exactly those cells (grid coordinates in the grid of [`Voxels::layout`]; the second the
/// same as the first when there is one). `None` for other triangles, which are sampled.
#[inline]
fn few_cells(
    mesh: &Mesh,
    t: usize,
    origin: DVec3,
    per_h: f64,
    dims: [usize; 3],
) -> Option<[[usize; 3]; 2]> {
    let [a, b, c] = mesh.corners(t);
    let lo = (a.min(b).min(c) - origin) * per_h + 0.5;
    let hi = (a.max(b).max(c) - origin) * per_h + 0.5;
    // Inside the grid and off its last layer, as every surface cell is (a spare cell on
    // each side), so the samples' clamp to the grid does not apply; the comparisons are
    // false for NaN.
    let last = DVec3::new(
        (dims[0] - 1) as f64,
        (dims[1] - 1) as f64,
        (dims[2] - 1) as f64,
    );
    if !((lo - CORNER_MARGIN).cmpge(DVec3::ZERO) & (hi + CORNER_MARGIN).cmplt(last)).all() {
        return None;
    }
    // Every coordinate is now from 0 to below the grid's size: its truncation is its floor.
    let first = (lo - CORNER_MARGIN).as_i64vec3();
    let second = (hi + CORNER_MARGIN).as_i64vec3();
    // At most one axis across two cells, each corner clear of the faces between (the
    // lowest and the highest corner, each off by the margin either way, in its own cell),
    // which on the other axes holds by the cell being one.
    let across = second - first;
    if across.element_sum() > 1
        || (lo + CORNER_MARGIN).as_i64vec3() != first
        || (hi - CORNER_MARGIN).as_i64vec3() != second
    {
        return None;
    }
    let coordinates = |c: glam::I64Vec3| [c.x as usize, c.y as usize, c.z as usize];
    Some([coordinates(first), coordinates(second)])
}

/// Upper bound of the surface samples a voxelisation at `h` takes over the triangles
/// `keep` marks (all when `None`), computed without sampling.
pub fn samples_for(mesh: &Mesh, h: f64, keep: Option<&[bool]>) -> f64 {
    (0..mesh.triangles.len())
        .into_par_iter()
        .filter(|&t| keep.is_none_or(|k| k[t]))
        .map(|t| {
            let (rows, per_row) = sample_grid(mesh, t, SAMPLE_STEP * h);
            (rows as f64 + 1.0) * per_row as f64
        })
        .sum()
}

/// An upper bound of [`samples_for`] from the triangles' boxes alone (no square roots): a
/// triangle's longest edge, and so its height, is at most the sum of its box's sides `s`,
/// so it takes at most (s / step + 2)^2 samples. Above the exact count by about a part in
/// a million more than the rounding of the sums; NaN when a coordinate is.
pub fn samples_bound(mesh: &Mesh, h: f64, keep: Option<&[bool]>) -> f64 {
    let step = SAMPLE_STEP * h;
    // Blocks of triangles summed in a plain loop each (and the blocks' sums in order), so
    // the sum is the same on any number of threads and the loop is compiled as one.
    const BLOCK: usize = 4096;
    let sums: Vec<f64> = mesh
        .triangles
        .par_chunks(BLOCK)
        .enumerate()
        .map(|(i, block)| {
            let mut sum = 0.0;
            for (j, tri) in block.iter().enumerate() {
                if keep.is_some_and(|k| !k[i * BLOCK + j]) {
                    continue;
                }
                let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
                let side = a.max(b).max(c) - a.min(b).min(c);
                let n = (side.x + side.y + side.z) / step + 2.0;
                sum += n * n;
            }
            sum
        })
        .collect();
    sums.iter().sum::<f64>() * (1.0 + 1e-6)
}

/// [`samples_bound`] from sums over the triangles of their box's sides `s` (`side`), of
/// `s^2` (`side2`) and their number: sum (s / step + 2)^2 expanded, so that the bound at any
/// cell side costs no pass over the triangles. The sums' rounding differs from
/// [`samples_bound`]'s by far less than the part in a million it adds.
pub(crate) fn samples_bound_of_sums(side: f64, side2: f64, triangles: f64, h: f64) -> f64 {
    let step = SAMPLE_STEP * h;
    (side2 / (step * step) + 4.0 * side / step + 4.0 * triangles) * (1.0 + 1e-6)
}

impl Voxels {
    /// Whether the study these cells belong to was stopped (their [`Voxels::cancel`] token).
    pub(crate) fn stopped(&self) -> bool {
        crate::cancel::is_set(self.cancel.as_ref())
    }

    /// Voxelises `mesh` with cells of side `h` mm, each body of the mesh its own. The caller keeps
    /// the work sane: [`Voxels::bounded`] checks the limits before it allocates.
    pub fn new(mesh: &Mesh, h: f64) -> Voxels {
        Self::build(
            mesh,
            h,
            &crate::mesh::topology::body_of_triangle(mesh),
            None,
        )
        .expect("no token to stop it")
    }

    /// Voxelises the triangles whose `body_of` is not `u32::MAX`, each cell labelled with
    /// the body whose triangle passes through it or whose inside holds its centre; cells of
    /// different bodies are never neighbours. Refuses, before allocating, a grid of more than
    /// `limits.max_cells` cells or more than `limits.max_samples` surface samples.
    pub fn bounded(
        mesh: &Mesh,
        h: f64,
        body_of: &[u32],
        limits: &super::FlowOptions,
    ) -> Result<Voxels, super::FillError> {
        let keep: Vec<bool> = body_of.iter().map(|&b| b != EMPTY).collect();
        let dense = Self::cells_for(&mesh.bounds(), h);
        if dense > limits.max_cells {
            return Err(super::FillError::too_large(
                "grid cells",
                dense,
                limits.max_cells,
                h,
                3.0,
            ));
        }
        let samples = samples_for(mesh, h, Some(&keep));
        if samples > limits.max_samples {
            return Err(super::FillError::too_large(
                "surface samples",
                samples,
                limits.max_samples,
                h,
                2.0,
            ));
        }
        Ok(Self::build(mesh, h, body_of, None).expect("no token to stop it"))
    }

    /// [`Voxels::bounded`] without the checks, for a caller that made them; `None` when
    /// `cancel` was set, checked between the build's steps (each a pass over the triangles
    /// or the grid: on a 352k-triangle part at 0.3 mm cells, tens of milliseconds).
    pub(crate) fn build(
        mesh: &Mesh,
        h: f64,
        body_of: &[u32],
        cancel: Option<&crate::cancel::Cancel>,
    ) -> Option<Voxels> {
        let go_on = || (!crate::cancel::is_set(cancel)).then_some(());
        let bounds = mesh.bounds();
        let (origin, dims) = Self::layout(&bounds, h);
        let n_cells = dims[0] * dims[1] * dims[2];
        let cell_of = |p: DVec3| cell_coordinates(p, origin, h, dims);

        // Surface cells: rows of samples at most h/2 apart over every triangle.
        let step = SAMPLE_STEP * h;
        // The cells of a triangle's box by a product, not three quotients: within about
        // 1e-13 of a cell of them, far inside the margin [`few_cells`] keeps.
        let per_h = 1.0 / h;
        let mut owner = vec![EMPTY; n_cells];
        let marks: Vec<Marks> = chunks(mesh.triangles.len())
            .map(|ts| {
                // Most triangles mark one or two cells.
                let mut out = Vec::with_capacity(2 * ts.len());
                // Each mark's squared distance from its cell's centre to its triangle's
                // centroid, in cells, as f32 bits (the centre of the cell of grid
                // coordinates c lies c cells from the origin).
                let mut near = Vec::with_capacity(2 * ts.len());
                for t in ts {
                    if body_of[t] == EMPTY {
                        continue;
                    }
                    let centroid = (centroid(mesh.corners(t)) - origin) * per_h;
                    let mut mark = |cell: [usize; 3]| {
                        out.push((dense_index(cell, dims) as u32, t as u32));
                        let at = DVec3::new(cell[0] as f64, cell[1] as f64, cell[2] as f64);
                        near.push(((centroid - at).length_squared() as f32).to_bits());
                    };
                    // A triangle inside one cell or two (most triangles of a fine
                    // mesh) marks them from its box, without its samples.
                    match few_cells(mesh, t, origin, per_h, dims) {
                        Some([c0, c1]) => {
                            mark(c0);
                            if c1 != c0 {
                                mark(c1);
                            }
                        }
                        None => mark_samples(mesh, t, step, &cell_of, mark),
                    }
                }
                (out, near)
            })
            .collect();
        // The least distance of each cell so far (f32 bits: a non-negative f32's bits order
        // as the number), in the array that numbers the solid cells below.
        let mut nearest = vec![u32::MAX; n_cells];
        for (list, near) in &marks {
            for (&(cell, t), &d2) in list.iter().zip(near) {
                let (o, best) = (&mut owner[cell as usize], &mut nearest[cell as usize]);
                // The nearer centroid; of two at one distance, the triangle of larger rank,
                // then (for a 2^-32 chance of two ranks alike) the earlier triangle.
                let wins = *o == EMPTY
                    || d2 < *best
                    || (d2 == *best && {
                        let rank = |t: u32| triangle_rank(mesh.corners(t as usize));
                        (rank(t), *o) > (rank(*o), t)
                    });
                if wins {
                    (*o, *best) = (t, d2);
                }
            }
        }
        drop(marks);
        go_on()?;

        // Interior cells: winding number along +Z columns through the cell centres; each
        // holds the triangle the column entered its body through.
        let (inside, open_columns) = Self::interior(mesh, origin, h, dims, body_of);
        go_on()?;

        let mut index = nearest;
        index.fill(EMPTY);
        let mut cells = Vec::new();
        let mut dense = Vec::new();
        let mut triangle = Vec::new();
        let mut surface_flags = Vec::new();
        let mut body = Vec::new();
        let mut interior_cells = 0;
        for (i, slot) in index.iter_mut().enumerate() {
            let surface = owner[i] != EMPTY;
            let entered = inside[i];
            if surface || entered != EMPTY {
                *slot = cells.len() as u32;
                let x = i % dims[0];
                let y = (i / dims[0]) % dims[1];
                let z = i / (dims[0] * dims[1]);
                cells.push([x as u32, y as u32, z as u32]);
                dense.push(i as u32);
                triangle.push(owner[i]);
                surface_flags.push(surface);
                body.push(body_of[if surface { owner[i] } else { entered } as usize]);
                interior_cells += (entered != EMPTY) as usize;
            }
        }
        drop(inside);
        drop(owner);
        go_on()?;
        let mut voxels = Voxels {
            origin,
            h,
            dims,
            index,
            cells,
            dense,
            table: Neighbours::Far(Vec::new()),
            triangle,
            surface: surface_flags,
            body,
            interior_cells,
            open_columns,
            cancel: None,
        };
        voxels.table = voxels.neighbours();
        go_on()?;
        voxels.spread_triangles();
        Some(voxels)
    }

    /// Number of grid cells (solid or not) a voxelisation at `h` would allocate.
    pub fn cells_for(bounds: &Aabb, h: f64) -> f64 {
        let s = bounds.size() / h + 3.0;
        s.x * s.y * s.z
    }

    fn layout(bounds: &Aabb, h: f64) -> (DVec3, [usize; 3]) {
        // One spare cell on each side, and a shift that keeps centres off round coordinates.
        let shift = DVec3::new(0.1234567, 0.2345678, 0.3456789) * h;
        let origin = bounds.min - DVec3::splat(h) + shift;
        let span = bounds.max - origin;
        let dims = [
            (span.x / h).ceil() as usize + 2,
            (span.y / h).ceil() as usize + 2,
            (span.z / h).ceil() as usize + 2,
        ];
        (origin, dims)
    }

    /// For each grid cell whose centre is inside the surface, the triangle its column
    /// entered through (`EMPTY` elsewhere), and the count of open columns. Each body's
    /// columns close on their own, so bodies that overlap or nest are filled each by its own
    /// crossings.
    fn interior(
        mesh: &Mesh,
        origin: DVec3,
        h: f64,
        dims: [usize; 3],
        body_of: &[u32],
    ) -> (Vec<u32>, usize) {
        let [nx, ny, nz] = dims;
        // Crossings (column and body, z, +1 entering / -1 leaving, triangle), per triangle.
        let crossings: Vec<Vec<Crossing>> = chunks(mesh.triangles.len())
            .map(|ts| {
                let mut out = Vec::new();
                for t in ts {
                    if body_of[t] == EMPTY {
                        continue;
                    }
                    let tri = mesh.triangles[t];
                    let p = tri.map(|v| mesh.vertices[v as usize]);
                    let q = p.map(|v| DVec2::new(v.x, v.y));
                    let area = orient2d(q[0], q[1], q[2]);
                    if area == 0.0 {
                        continue;
                    }
                    // Entering (going up) through a face whose normal points down.
                    let sign: i8 = if area < 0.0 { 1 } else { -1 };
                    let lo = q[0].min(q[1]).min(q[2]);
                    let hi = q[0].max(q[1]).max(q[2]);
                    let i0 = ceil_index((lo.x - origin.x) / h);
                    let i1 = floor_signed((hi.x - origin.x) / h).min(nx as isize - 1);
                    let j0 = ceil_index((lo.y - origin.y) / h);
                    let j1 = floor_signed((hi.y - origin.y) / h).min(ny as isize - 1);
                    for j in j0 as isize..=j1 {
                        for i in i0 as isize..=i1 {
                            let c = DVec2::new(origin.x + i as f64 * h, origin.y + j as f64 * h);
                            let w0 = orient2d(q[1], q[2], c);
                            let w1 = orient2d(q[2], q[0], c);
                            let w2 = orient2d(q[0], q[1], c);
                            let inside = if area > 0.0 {
                                w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0
                            } else {
                                w0 <= 0.0 && w1 <= 0.0 && w2 <= 0.0
                            };
                            if inside {
                                let z = (w0 * p[0].z + w1 * p[1].z + w2 * p[2].z) / area;
                                let col = (j as usize * nx + i as usize) as u32;
                                out.push(((col, body_of[t]), z, sign, t as u32));
                            }
                        }
                    }
                }
                out
            })
            .collect();
        let mut all: Vec<Crossing> = crossings.into_iter().flatten().collect();
        all.par_sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut inside = vec![EMPTY; nx * ny * nz];
        let mut open_columns = 0;
        let mut start = 0;
        while start < all.len() {
            let col = all[start].0;
            let mut end = start;
            while end < all.len() && all[end].0 == col {
                end += 1;
            }
            let run = &all[start..end];
            if run.iter().map(|c| c.2 as i32).sum::<i32>() != 0 {
                open_columns += 1;
            } else {
                let (i, j) = (col.0 as usize % nx, col.0 as usize / nx);
                let mut winding = 0i32;
                let mut run_triangle = EMPTY;
                for pair in run.windows(2) {
                    let entered = winding == 0;
                    winding += pair[0].2 as i32;
                    if entered && winding != 0 {
                        run_triangle = pair[0].3;
                    }
                    if winding != 0 {
                        let k0 = ceil_index((pair[0].1 - origin.z) / h);
                        let k1 = floor_signed((pair[1].1 - origin.z) / h);
                        if k1 >= 0 {
                            for k in k0..=(k1 as usize).min(nz - 1) {
                                inside[(k * ny + j) * nx + i] = run_triangle;
                            }
                        }
                    }
                }
            }
            start = end;
        }
        (inside, open_columns)
    }

    /// Gives every interior cell the triangle of its nearest surface cell (breadth-first over
    /// the 26 neighbours, in [`neighbour_offsets`] order, read from the neighbour table), so
    /// per-triangle data such as wall thickness reaches every cell.
    fn spread_triangles(&mut self) {
        let mut frontier: Vec<u32> = (0..self.cells.len() as u32)
            .filter(|&c| self.triangle[c as usize] != EMPTY)
            .collect();
        while !frontier.is_empty() {
            let mut next = Vec::new();
            for &c in &frontier {
                let t = self.triangle[c as usize];
                for n in self.table.of(c) {
                    if n != EMPTY && self.triangle[n as usize] == EMPTY {
                        self.triangle[n as usize] = t;
                        next.push(n);
                    }
                }
            }
            frontier = next;
        }
    }

    /// The neighbours of every solid cell, as offsets when they all fit in 16 bits (see
    /// [`Neighbours`]), else as [`Voxels::neighbour_table`].
    fn neighbours(&self) -> Neighbours {
        let strides = self.neighbour_strides();
        let near: Option<Vec<[i16; 26]>> = (0..self.len() as u32)
            .into_par_iter()
            .map(|c| {
                let mut row = [0i16; 26];
                for (o, n) in row.iter_mut().zip(self.neighbour_row(c, &strides)) {
                    if n != EMPTY {
                        *o = i16::try_from(i64::from(n) - i64::from(c)).ok()?;
                    }
                }
                Some(row)
            })
            .collect();
        match near {
            Some(rows) => Neighbours::Near(rows),
            None => Neighbours::Far(self.neighbour_table()),
        }
    }

    /// The 26 neighbours of every solid cell, in [`neighbour_offsets`] order (`u32::MAX`
    /// where the neighbour is not solid).
    pub fn neighbour_table(&self) -> Vec<[u32; 26]> {
        let strides = self.neighbour_strides();
        (0..self.len() as u32)
            .into_par_iter()
            .map(|c| self.neighbour_row(c, &strides))
            .collect()
    }

    /// The offsets in the dense grid of the 26 neighbours, in [`neighbour_offsets`] order.
    fn neighbour_strides(&self) -> [isize; 26] {
        let offsets = neighbour_offsets();
        std::array::from_fn(|k| self.stride(offsets[k].0))
    }

    /// The 26 neighbours of cell `c` in its body (`u32::MAX` where the neighbour is not
    /// solid or is of another body), `strides` from [`Voxels::neighbour_strides`].
    #[inline]
    fn neighbour_row(&self, c: u32, strides: &[isize; 26]) -> [u32; 26] {
        let (d, b) = (self.dense[c as usize], self.body[c as usize]);
        strides.map(|stride| {
            let n = self.index[(d as isize + stride) as usize];
            if n != EMPTY && self.body[n as usize] == b {
                n
            } else {
                EMPTY
            }
        })
    }

    /// Number of solid cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// True when no cell is solid.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Centre of solid cell `c`.
    pub fn centre(&self, c: u32) -> DVec3 {
        let [x, y, z] = self.cells[c as usize];
        self.origin + DVec3::new(x as f64, y as f64, z as f64) * self.h
    }

    /// The solid neighbour of `c` at offset `o` (each component -1, 0 or 1), if any.
    ///
    /// Solid cells never lie on the grid's outer layer (the layout keeps a spare cell on
    /// every side), so the neighbour's dense index is always inside the grid.
    #[inline]
    pub fn neighbour(&self, c: u32, o: [i32; 3]) -> Option<u32> {
        let i = self.dense[c as usize] as isize + self.stride(o);
        let n = self.index[i as usize];
        (n != EMPTY && self.body[n as usize] == self.body[c as usize]).then_some(n)
    }

    /// Offset in the dense grid of a step `o`.
    #[inline]
    pub fn stride(&self, o: [i32; 3]) -> isize {
        let (nx, ny) = (self.dims[0] as isize, self.dims[1] as isize);
        o[0] as isize + nx * (o[1] as isize + ny * o[2] as isize)
    }

    /// The solid neighbour of `c` at a dense offset from [`Voxels::stride`].
    #[inline]
    pub fn neighbour_at(&self, c: u32, stride: isize) -> Option<u32> {
        let n = self.index[(self.dense[c as usize] as isize + stride) as usize];
        (n != EMPTY && self.body[n as usize] == self.body[c as usize]).then_some(n)
    }

    /// The solid cell nearest `p`: the cell containing it if solid, else the nearest solid
    /// cell centre within two cells; `None` when there is none.
    pub fn cell_near(&self, p: DVec3) -> Option<u32> {
        cell_near(self.origin, self.h, self.dims, &self.index, &self.cells, p)
    }

    /// What [`Voxels::cell_near`] needs, kept after the rest of the cells is dropped: the
    /// lookup of a fill field's value at a point of the surface ([`crate::display`]).
    pub fn into_grid(self) -> CellGrid {
        CellGrid {
            origin: self.origin,
            h: self.h,
            dims: self.dims,
            index: self.index,
            cells: self.cells,
        }
    }

    /// Connected components of the solid cells (26-neighbour), numbered from 0 in cell order.
    pub fn components(&self) -> (Vec<u32>, usize) {
        let mut label = vec![EMPTY; self.len()];
        let offsets = neighbour_offsets();
        let mut count = 0u32;
        let mut stack = Vec::new();
        for start in 0..self.len() as u32 {
            if label[start as usize] != EMPTY {
                continue;
            }
            label[start as usize] = count;
            stack.push(start);
            while let Some(c) = stack.pop() {
                for &(o, _) in &offsets {
                    if let Some(n) = self.neighbour(c, o) {
                        if label[n as usize] == EMPTY {
                            label[n as usize] = count;
                            stack.push(n);
                        }
                    }
                }
            }
            count += 1;
        }
        (label, count as usize)
    }
}

/// The solid cells' lookup by position, without the rest of [`Voxels`]: made by
/// [`Voxels::into_grid`] once the fill is done.
#[derive(Debug, Clone, PartialEq)]
pub struct CellGrid {
    /// Centre of cell (0, 0, 0).
    pub origin: DVec3,
    /// Cell side, mm.
    pub h: f64,
    /// Cells along x, y, z.
    pub dims: [usize; 3],
    index: Vec<u32>,
    cells: Vec<[u32; 3]>,
}

impl CellGrid {
    /// Number of solid cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// True when no cell is solid.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// [`Voxels::cell_near`]: the same cell for the same point.
    pub fn cell_near(&self, p: DVec3) -> Option<u32> {
        cell_near(self.origin, self.h, self.dims, &self.index, &self.cells, p)
    }
}

/// The solid cell nearest `p` in a dense `index` of cells of side `h` from `origin`
/// (see [`Voxels::cell_near`]).
fn cell_near(
    origin: DVec3,
    h: f64,
    dims: [usize; 3],
    index: &[u32],
    cells: &[[u32; 3]],
    p: DVec3,
) -> Option<u32> {
    let centre = |i: u32| {
        let [x, y, z] = cells[i as usize];
        origin + DVec3::new(x as f64, y as f64, z as f64) * h
    };
    let q = ((p - origin) / h + 0.5).map(floor_value);
    if q.cmpge(DVec3::ZERO).all() {
        let (x, y, z) = (q.x as usize, q.y as usize, q.z as usize);
        if x < dims[0] && y < dims[1] && z < dims[2] {
            let i = index[(z * dims[1] + y) * dims[0] + x];
            if i != EMPTY {
                return Some(i);
            }
        }
    }
    let mut best: Option<(f64, u32)> = None;
    for dz in -2..=2i64 {
        for dy in -2..=2i64 {
            for dx in -2..=2i64 {
                let (x, y, z) = (q.x as i64 + dx, q.y as i64 + dy, q.z as i64 + dz);
                if x < 0 || y < 0 || z < 0 {
                    continue;
                }
                let (x, y, z) = (x as usize, y as usize, z as usize);
                if x >= dims[0] || y >= dims[1] || z >= dims[2] {
                    continue;
                }
                let i = index[(z * dims[1] + y) * dims[0] + x];
                if i != EMPTY {
                    let d = centre(i).distance_squared(p);
                    if best.is_none_or(|(bd, bi)| d < bd || (d == bd && i < bi)) {
                        best = Some((d, i));
                    }
                }
            }
        }
    }
    best.map(|(_, i)| i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples::sample;

    #[test]
    fn index_roundings_are_the_maths_library_s() {
        let mut values = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            2.0 - 1e-16,
            4.5e15,
            -4.5e15,
        ];
        values.extend([f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300]);
        let mut x = 0.123f64;
        for _ in 0..10_000 {
            x = (x * 7919.0 + 0.37).rem_euclid(2000.0);
            values.extend([x - 1000.0, (x - 1000.0).round(), x * 1e-3]);
        }
        for &v in &values {
            assert_eq!(floor_index(v), v.floor().max(0.0) as usize, "{v}");
            assert_eq!(ceil_index(v), v.ceil().max(0.0) as usize, "{v}");
            if v.is_finite() && v.abs() < 1e15 {
                assert_eq!(floor_signed(v), v.floor() as isize, "{v}");
            }
            assert_eq!(floor_value(v).to_bits(), v.floor().to_bits(), "{v}");
        }
    }

    #[test]
    fn centroid_and_rank_do_not_depend_on_the_order_of_the_corners() {
        // Coordinates whose sums round differently in different orders.
        let (a, b, c) = (
            DVec3::new(0.1, 1e16, -3.3),
            DVec3::new(0.2, 1.0, 7.7),
            DVec3::new(0.3, -1e16, 1e-9),
        );
        let orders = [
            [a, b, c],
            [b, c, a],
            [c, a, b],
            [a, c, b],
            [b, a, c],
            [c, b, a],
        ];
        let centres: Vec<[u64; 3]> = orders
            .iter()
            .map(|&o| centroid(o).to_array().map(f64::to_bits))
            .collect();
        assert!(centres.windows(2).all(|w| w[0] == w[1]), "{centres:?}");
        // A plain sum in the order given does round apart here: the test can tell.
        assert_ne!((a + b + c).x.to_bits(), (c + b + a).x.to_bits());
        let ranks: Vec<u64> = orders.iter().map(|&o| triangle_rank(o)).collect();
        assert!(ranks.windows(2).all(|w| w[0] == w[1]), "{ranks:?}");
        // A larger triangle ranks higher; two of one area rank apart by their corners.
        let small = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let large = [DVec3::ZERO, DVec3::X * 2.0, DVec3::Y];
        let moved = small.map(|p| p + DVec3::Z);
        assert!(triangle_rank(large) > triangle_rank(small));
        assert_ne!(triangle_rank(small), triangle_rank(moved));
        assert_eq!(triangle_rank(small) >> 32, triangle_rank(moved) >> 32);
    }

    #[test]
    fn a_triangle_in_one_or_two_cells_marks_the_cells_its_samples_mark() {
        let (mut one, mut two) = (0, 0);
        for name in ["plate", "cover", "cap", "tray", "bracket"] {
            let mesh = sample(name).unwrap();
            let diagonal = mesh.bounds().diagonal();
            for h in [diagonal / 300.0, diagonal / 97.3, diagonal / 31.0] {
                let (origin, dims) = Voxels::layout(&mesh.bounds(), h);
                let cell_of = |p: DVec3| cell_coordinates(p, origin, h, dims);
                for t in 0..mesh.triangles.len() {
                    let mut sampled = Vec::new();
                    mark_samples(&mesh, t, SAMPLE_STEP * h, &cell_of, |c| {
                        sampled.push(dense_index(c, dims))
                    });
                    sampled.sort_unstable();
                    sampled.dedup();
                    let [lo, hi] = (0..3).fold([[0.0; 3]; 2], |[mut lo, mut hi], k| {
                        let [a, b, c] = mesh.corners(t);
                        lo[k] = (a[k].min(b[k]).min(c[k]) - origin[k]) / h + 0.5;
                        hi[k] = (a[k].max(b[k]).max(c[k]) - origin[k]) / h + 0.5;
                        [lo, hi]
                    });
                    let near_face = |x: f64| (x - x.round()).abs() <= CORNER_MARGIN;
                    let spans: Vec<f64> = (0..3).map(|k| hi[k].floor() - lo[k].floor()).collect();
                    let few = few_cells(&mesh, t, origin, 1.0 / h, dims);
                    match few.map(|c| c.map(|c| dense_index(c, dims))) {
                        Some([c0, c1]) if c0 == c1 => {
                            one += 1;
                            assert_eq!(sampled, [c0], "{name} {h} {t}");
                        }
                        Some([c0, c1]) => {
                            two += 1;
                            assert_eq!(sampled, [c0, c1], "{name} {h} {t}");
                        }
                        // Not taken only where the box reaches further, or a corner lies
                        // within the margin of a face.
                        None => assert!(
                            spans.iter().sum::<f64>() > 1.0
                                || (0..3).any(|k| near_face(lo[k]) || near_face(hi[k])),
                            "{name} {h} {t}"
                        ),
                    }
                }
            }
        }
        assert!(one > 100 && two > 100, "{one} {two}");
    }

    #[test]
    fn the_samples_bound_is_above_the_samples() {
        for name in ["plate", "cover", "cap", "tray", "bracket"] {
            let mesh = sample(name).unwrap();
            let diagonal = mesh.bounds().diagonal();
            for h in [
                diagonal / 300.0,
                diagonal / 97.3,
                diagonal / 31.0,
                diagonal / 2.0,
            ] {
                let exact = samples_for(&mesh, h, None);
                let bound = samples_bound(&mesh, h, None);
                assert!(
                    bound >= exact && bound < 40.0 * exact,
                    "{name} {h}: {bound} {exact}"
                );
                // Triangle by triangle, including slivers and points.
                for t in 0..mesh.triangles.len() {
                    let (rows, per_row) = sample_grid(&mesh, t, SAMPLE_STEP * h);
                    let [a, b, c] = mesh.corners(t);
                    let side = a.max(b).max(c) - a.min(b).min(c);
                    let n = (side.x + side.y + side.z) / (SAMPLE_STEP * h) + 2.0;
                    assert!(n * n >= ((rows + 1) * per_row) as f64, "{name} {h} {t}");
                }
            }
        }
        let mut sliver = sample("plate").unwrap();
        let v0 = sliver.triangles[0][0];
        sliver.triangles[1] = [v0, v0, v0];
        assert!(samples_bound(&sliver, 0.5, None) >= samples_for(&sliver, 0.5, None));
    }

    #[test]
    fn plate_fills_its_volume_to_within_a_layer_of_cells() {
        let mesh = sample("plate").unwrap();
        let h = 0.5;
        let v = Voxels::new(&mesh, h);
        assert_eq!(v.open_columns, 0);
        // 100 x 60 x 3 with an r8 hole: 18000 - pi 64 3 mm^3.
        let volume = 100.0 * 60.0 * 3.0 - std::f64::consts::PI * 64.0 * 3.0;
        let interior = v.interior_cells as f64 * h * h * h;
        assert!(
            (interior - volume).abs() / volume < 0.02,
            "{interior} vs {volume}"
        );
        // Surface cells add at most one layer around.
        let all = v.len() as f64 * h * h * h;
        assert!(all > interior && all < volume + 2.0 * 12960.0 * h, "{all}");
        assert_eq!(v.components().1, 1);
        // No cell in the hole (r 8 at (20, 0)).
        let hole = v.cell_near(DVec3::new(20.0, 0.0, 1.5));
        assert!(hole.is_none(), "{hole:?}");
    }

    #[test]
    fn open_mesh_keeps_its_surface_as_a_connected_shell() {
        let mut mesh = sample("plate").unwrap();
        // Remove a triangle of the top face, so columns through it do not close.
        let top = (0..mesh.triangles.len())
            .find(|&t| mesh.normal(t).z > 0.5)
            .unwrap();
        mesh.triangles.remove(top);
        let v = Voxels::new(&mesh, 0.5);
        assert!(v.open_columns > 0);
        assert_eq!(v.components().1, 1);
    }

    #[test]
    fn cells_stop_when_their_token_is_set() {
        let mesh = sample("cover").unwrap();
        let body_of = crate::mesh::topology::body_of_triangle(&mesh);
        let h = mesh.bounds().diagonal() / 80.0;
        let token = crate::cancel::Cancel::new();
        let whole = Voxels::build(&mesh, h, &body_of, Some(&token)).expect("not set");
        assert_eq!(whole.len(), Voxels::new(&mesh, h).len());
        token.cancel();
        assert!(Voxels::build(&mesh, h, &body_of, Some(&token)).is_none());
    }
}
