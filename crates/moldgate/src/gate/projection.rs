//! Projection of grid points onto the part along the demolding direction.
//!
//! All rays are parallel, so instead of tracing each one through a hierarchy of boxes, every
//! triangle is drawn into the grid of rays like a rasteriser draws into pixels: a ray at
//! (u, w) hits a triangle exactly when (u, w) lies inside the triangle's projection, and the
//! hit height is the barycentric blend of the corner heights. Each ray keeps its two highest
//! hits: the first is where it meets the part, the second where it leaves the solid.
//!
//! **Edge convention.** A ray through the common edge or vertex of two triangles belongs to
//! exactly one of them (the top-left rule of rasterisers, on counter-clockwise projected
//! triangles), so no hit is counted twice and none is lost on a watertight mesh. The edge
//! function of an edge is always evaluated from its lexicographically smaller end, so both
//! triangles of a shared edge see bit-identical values and the rule holds in floating point.
//! On an outline edge, where both triangles fold onto the same side, a grazing ray belongs to
//! both or to neither; triangles seen exactly edge-on (zero projected area) are skipped.

use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::frame::Frame;
use crate::math::{orient2d, DVec2, DVec3};

/// The two highest hits of one ray; heights are along the demolding direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Height of the first (highest) hit, or `-inf` on a miss.
    pub first: f64,
    /// Height of the second hit, or `-inf` when there is none.
    pub second: f64,
    /// Triangle of the first hit (`u32::MAX` on a miss).
    pub triangle: u32,
}

impl Hit {
    /// No hit.
    pub const MISS: Hit = Hit {
        first: f64::NEG_INFINITY,
        second: f64::NEG_INFINITY,
        triangle: u32::MAX,
    };

    /// True when the ray met the part.
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.first > f64::NEG_INFINITY
    }

    /// Distance from the first hit to the second along the ray (the wall thickness along
    /// the demolding direction), or `None` when the ray never leaves the solid.
    #[inline]
    pub fn thickness(&self) -> Option<f64> {
        (self.second > f64::NEG_INFINITY).then_some(self.first - self.second)
    }

    /// Keeps the two highest heights; of several triangles at the highest, the one with the
    /// lowest index, so the result does not depend on the order the triangles come in.
    #[inline]
    fn add(&mut self, height: f64, triangle: u32) {
        if height > self.first || (height == self.first && triangle < self.triangle) {
            self.second = self.first;
            self.first = height;
            self.triangle = triangle;
        } else if height > self.second {
            self.second = height;
        }
    }
}

/// A regular lattice of parallel rays: ray (i, j) passes through `origin + spacing * (i, j)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayLattice {
    /// Position of ray (0, 0) in the projection plane.
    pub origin: DVec2,
    /// Distance between neighbouring rays.
    pub spacing: f64,
    /// Rays along u.
    pub n_u: usize,
    /// Rays along w.
    pub n_w: usize,
}

/// The two highest hits of a circle point's ray, in single precision relative to the
/// projection's base height: the circle rule needs only whether the ray met the part, the
/// height (against a flatness tolerance of a tenth of R) and the wall (against R). f32 keeps
/// them to a tenth of a micrometre on a part a metre deep, the precision of a binary STL's
/// own coordinates, in a third of the memory of a [`Hit`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircleHit {
    first: f32,
    second: f32,
}

/// A circle point's ray where it met the part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CirclePoint {
    /// Height of the first hit along the demolding direction.
    pub height: f64,
    /// Distance from the first hit to the second, or `None` when the ray never leaves the
    /// solid.
    pub thickness: Option<f64>,
}

/// How a ray keeps its hits: added one by one, and two partial records of the same ray
/// merged; the result depends on the set of triangles only, not on their order.
trait Record: Copy + Send {
    const MISS: Self;
    fn add(&mut self, height: f64, triangle: u32, base: f64);
    fn merge(&mut self, later: &Self);
}

impl Record for Hit {
    const MISS: Hit = Hit::MISS;

    #[inline]
    fn add(&mut self, height: f64, triangle: u32, _base: f64) {
        Hit::add(self, height, triangle);
    }

    #[inline]
    fn merge(&mut self, later: &Hit) {
        Hit::add(self, later.first, later.triangle);
        // Not above the merged first, so it can only become the second.
        if later.second > self.second {
            self.second = later.second;
        }
    }
}

impl Record for CircleHit {
    const MISS: CircleHit = CircleHit {
        first: f32::NEG_INFINITY,
        second: f32::NEG_INFINITY,
    };

    #[inline]
    fn add(&mut self, height: f64, _triangle: u32, base: f64) {
        self.keep((height - base) as f32);
    }

    #[inline]
    fn merge(&mut self, later: &CircleHit) {
        self.keep(later.first);
        self.keep(later.second);
    }
}

impl CircleHit {
    /// Keeps the two highest of the heights seen and `h`.
    #[inline]
    fn keep(&mut self, h: f32) {
        if h > self.first {
            self.second = self.first;
            self.first = h;
        } else if h > self.second {
            self.second = h;
        }
    }
}

/// What the rays of the node lattice and of the circle lattices met.
#[derive(Debug, Clone)]
pub struct Projection {
    /// The node lattice's hits, indexed `j * n_u + i`.
    pub nodes: Vec<Hit>,
    /// Per circle lattice, its rays' hits, indexed as the nodes.
    circles: Vec<Vec<CircleHit>>,
    /// The height the circle hits are measured from.
    base: f64,
}

impl Projection {
    /// Circle lattice `k`'s ray `i` where it met the part, or `None` on a miss.
    #[inline]
    pub fn circle(&self, k: usize, i: usize) -> Option<CirclePoint> {
        let h = self.circles[k][i];
        (h.first > f32::NEG_INFINITY).then(|| CirclePoint {
            height: self.base + f64::from(h.first),
            thickness: (h.second > f32::NEG_INFINITY)
                .then(|| f64::from(h.first) - f64::from(h.second)),
        })
    }

    /// The number of circle lattices.
    pub fn circle_count(&self) -> usize {
        self.circles.len()
    }
}

/// At most this many sets of hits are drawn apart and merged; each holds its own copy of
/// every lattice's hits.
pub const MAX_RUNS: usize = 4;

/// Triangles in a block of the projection's work queue.
const BLOCK: usize = 4096;

/// Casts every ray of the node lattice and of the circle lattices against the triangles.
///
/// All lattices share one spacing. Vertices are projected as they are read, to (u, w,
/// height) in `frame`: the same arithmetic for every use of a vertex, so shared edges stay
/// bit-identical, and no copy of the vertices is held (it would be the largest array of the
/// stage).
///
/// Each thread (at most [`MAX_RUNS`]) draws into its own set of hits, taking blocks of
/// consecutive triangles from a shared queue until none is left, so a thread slowed by a
/// dense part of the mesh (or by other work) leaves the rest to the others; the sets are
/// merged afterwards. A ray keeps its two highest hits and, at the highest, the lowest
/// triangle index, so the result is one pass's whoever drew what. Within a block a
/// triangle's corners are fetched and oriented once and tested against every lattice: a
/// cheap test on its bounding box skips the lattices where it covers no ray. Where threads
/// outnumber the sets of hits, the circle lattices are also split into groups, each with its
/// own queue.
pub fn cast(
    vertices: &[DVec3],
    frame: &Frame,
    triangles: &[[u32; 3]],
    nodes: &RayLattice,
    circles: &[RayLattice],
) -> Projection {
    cast_until(vertices, frame, triangles, nodes, circles, None)
}

/// [`cast`], drawing no more blocks of triangles once `cancel` is set: the hits are then
/// those of the triangles drawn before, and the caller must not use them (it checks the
/// token after the call).
pub fn cast_until(
    vertices: &[DVec3],
    frame: &Frame,
    triangles: &[[u32; 3]],
    nodes: &RayLattice,
    circles: &[RayLattice],
    cancel: Option<&crate::cancel::Cancel>,
) -> Projection {
    let base = vertices.first().map_or(0.0, |&p| frame.height(p));
    let threads = rayon::current_num_threads().max(1);
    let blocks = triangles.len().div_ceil(BLOCK);
    let runs = threads.min(MAX_RUNS).min(blocks).max(1);
    // Up to 63 circle lattices a group beside the node lattice (a 64-bit mask per triangle).
    let groups = (threads / runs)
        .max(circles.len().div_ceil(63))
        .clamp(1, circles.len().max(1));
    let per_group = circles.len().div_ceil(groups).max(1);
    // Made in parallel: first touching this memory is a good part of the stage's cost.
    let mut hits: Vec<(Vec<Hit>, Vec<Vec<CircleHit>>)> = (0..runs)
        .into_par_iter()
        .map(|_| {
            (
                vec![Hit::MISS; nodes.n_u * nodes.n_w],
                circles
                    .iter()
                    .map(|l| vec![CircleHit::MISS; l.n_u * l.n_w])
                    .collect(),
            )
        })
        .collect();
    // One queue of blocks per group, one task per set of hits and group; the node lattice
    // goes with each set's first group.
    let queues: Vec<AtomicUsize> = (0..groups).map(|_| AtomicUsize::new(0)).collect();
    let mut tasks = Vec::with_capacity(runs * groups);
    for (node_hits, circle_hits) in hits.iter_mut() {
        let mut node_hits = Some(node_hits);
        let mut g = 0;
        let mut rest: &mut [Vec<CircleHit>] = circle_hits;
        loop {
            let take = per_group.min(rest.len());
            let (group, tail) = rest.split_at_mut(take);
            rest = tail;
            let lattices = &circles[g * per_group..g * per_group + take];
            tasks.push((&queues[g], node_hits.take(), lattices, group));
            g += 1;
            if rest.is_empty() {
                break;
            }
        }
    }
    tasks
        .into_par_iter()
        .for_each(|(queue, node_hits, lattices, group)| {
            let node = node_hits.map(|h| (nodes, &mut h[..]));
            let next = || {
                if crate::cancel::is_set(cancel) {
                    return None;
                }
                let b = queue.fetch_add(1, Ordering::Relaxed);
                (b < blocks).then(|| b * BLOCK..((b + 1) * BLOCK).min(triangles.len()))
            };
            draw_blocks(
                vertices,
                frame,
                triangles,
                next,
                node,
                (lattices, group),
                base,
            );
        });
    let mut runs = hits.into_iter();
    let (mut node_hits, mut circle_hits) = runs.next().expect("at least one run");
    for (later_nodes, later_circles) in runs {
        rayon::join(
            || merge(&mut node_hits, &later_nodes),
            || {
                circle_hits
                    .par_iter_mut()
                    .zip(&later_circles)
                    .for_each(|(h, later)| merge(h, later))
            },
        );
    }
    Projection {
        nodes: node_hits,
        circles: circle_hits,
        base,
    }
}

fn merge<R: Record>(hits: &mut [R], later: &[R]) {
    for (h, l) in hits.iter_mut().zip(later) {
        h.merge(l);
    }
}

/// Draws the blocks of `triangles` that `next` hands out, until it has none left, into the
/// node lattice (when given) and the circle lattices of one group.
fn draw_blocks(
    vertices: &[DVec3],
    frame: &Frame,
    triangles: &[[u32; 3]],
    mut next: impl FnMut() -> Option<std::ops::Range<usize>>,
    mut node: Option<(&RayLattice, &mut [Hit])>,
    (circles, circle_hits): (&[RayLattice], &mut [Vec<CircleHit>]),
    base: f64,
) {
    // Bit 0 of a mask is the node lattice, bit k the (k-1)-th circle lattice of the group.
    let lattices: Vec<Option<&RayLattice>> = std::iter::once(node.as_ref().map(|n| n.0))
        .chain(circles.iter().map(Some))
        .collect();
    let Some(first) = lattices.iter().flatten().next() else {
        return;
    };
    // Positions are measured in spacings from the first lattice's origin; lattice k's rays
    // then sit at integers plus its fractional offset (fx[k], fy[k]). An absent node lattice
    // gets an offset all the same; its bit is cleared below.
    let origin = first.origin;
    let inv = 1.0 / first.spacing;
    let offset = |l: &Option<&RayLattice>, axis: fn(DVec2) -> f64| {
        l.map_or(0.0, |l| fraction(axis(l.origin - origin) * inv))
    };
    let fx: Vec<f64> = lattices.iter().map(|l| offset(l, |v| v.x)).collect();
    let fy: Vec<f64> = lattices.iter().map(|l| offset(l, |v| v.y)).collect();
    let (cover_x, cover_y) = (OffsetBuckets::new(&fx), OffsetBuckets::new(&fy));
    let present = if node.is_some() { u64::MAX } else { !1 };
    // Both axes of every lattice, by bit (an absent node lattice's are never read).
    let axes: Vec<[LatticeAxis; 2]> = lattices
        .iter()
        .map(|l| {
            let l = l.unwrap_or(first);
            [
                LatticeAxis::new(l.origin.x, l.n_u),
                LatticeAxis::new(l.origin.y, l.n_w),
            ]
        })
        .collect();
    // File order within a block: neighbouring triangles share vertices, so the corner reads
    // stay in cache.
    while let Some(block) = next() {
        for (t, tri) in triangles[block.clone()].iter().enumerate() {
            let t = (block.start + t) as u32;
            // Each corner written out: `tri.map` with a closure is not always inlined.
            let corner = |k: usize| uwh(frame, vertices[tri[k] as usize]);
            let (a, b, c) = (corner(0), corner(1), corner(2));
            let Some(triangle) = ProjectedTriangle::new(a, b, c) else {
                continue;
            };
            let lo = (triangle.lo - origin) * inv;
            let width = (triangle.hi - triangle.lo) * inv;
            // Which lattices the box may cover, as a bit mask, from two table look-ups per axis
            // instead of a test per lattice.
            let mut mask = cover_x.covering(fraction(lo.x), width.x)
                & cover_y.covering(fraction(lo.y), width.y)
                & present;
            if mask == 0 {
                continue;
            }
            let edges = triangle.edges();
            while mask != 0 {
                let k = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                match (k, &mut node) {
                    (0, Some((lattice, hits))) => {
                        triangle.draw(&edges, t, (lattice, &axes[0], inv), hits, base)
                    }
                    _ => {
                        let (lattice, hits) = (&circles[k - 1], &mut circle_hits[k - 1]);
                        triangle.draw(&edges, t, (lattice, &axes[k], inv), hits, base)
                    }
                }
            }
        }
    }
}

/// A ray of [`blocked`]: from a point straight up or down the demolding direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointRay {
    /// Start point, mm.
    pub origin: DVec3,
    /// The triangle the ray starts on: never a hit. Below 2^31.
    pub triangle: u32,
    /// Along +d (`true`) or -d (`false`).
    pub up: bool,
}

/// A ray that [`blocked_in_blocks`] found blocked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockedRay {
    /// Its number, counting the rays in the order the blocks give them.
    pub ray: u32,
    /// Its [`PointRay::triangle`].
    pub triangle: u32,
}

/// Where [`blocked_in_blocks`] takes the rays of a block: each in the plane as it comes, and
/// the box of their points.
pub struct RaySink<'a> {
    frame: &'a Frame,
    rays: Vec<PlacedRay>,
    lo: DVec2,
    hi: DVec2,
}

impl RaySink<'_> {
    /// Takes the next ray of the block.
    #[inline]
    pub fn push(&mut self, r: PointRay) {
        let at = self.frame.project(r.origin);
        if at.is_finite() {
            self.lo = self.lo.min(at);
            self.hi = self.hi.max(at);
        }
        self.rays.push(PlacedRay {
            at,
            height: self.frame.height(r.origin),
            triangle: r.triangle | if r.up { UP } else { 0 },
            ray: 0,
        });
    }
}

/// A [`PointRay`] in the plane, in the order of its cell: 32 bytes.
#[derive(Clone, Copy)]
struct PlacedRay {
    at: DVec2,
    height: f64,
    /// The triangle it starts on, with [`UP`] set for a ray along +d.
    triangle: u32,
    /// Its number.
    ray: u32,
}

impl PlacedRay {
    #[inline]
    fn up(&self) -> bool {
        self.triangle & UP != 0
    }
}

/// A cell of [`blocked_in_blocks`]: its rays going down `placed[from..split]` and going up
/// `placed[split..to]` (`to` is the next cell's `from`), with the highest start of those
/// going down and the lowest of those going up, rounded outwards to f32, and the order of
/// each part (`orders & 3` of the first, `orders >> 2` of the second: see [`ORDER_HEIGHT`]).
#[derive(Clone, Copy)]
struct Cell {
    up: f32,
    down: f32,
    from: u32,
    split: u32,
    orders: u8,
}

/// The rays of a part of a cell in the order of their start along the way they go
/// (nearest the triangles that may block them first: a triangle reads them until one
/// starts beyond its reach).
const ORDER_HEIGHT: u8 = 0;
/// ... by u (a crowded part, read by bisection of the triangle's box).
const ORDER_U: u8 = 1;
/// ... by w.
const ORDER_W: u8 = 2;

/// Cells per task when the cells are put in order.
const CELL_RUN: usize = 1024;

/// Orders the rays of one cell (the first at `from` in `placed`): those going down first,
/// each part as [`Cell::orders`] says; its bounds.
fn order_cell(from: u32, rays: &mut [PlacedRay]) -> Cell {
    // Those going down first, by a partition in place: the order within each part is set
    // by `order_part` (and which rays a triangle blocks does not depend on it).
    let mut split = 0;
    for k in 0..rays.len() {
        if !rays[k].up() {
            rays.swap(split, k);
            split += 1;
        }
    }
    let (down, up) = rays.split_at_mut(split);
    let order_down = order_part(down, |p, q| q.height.total_cmp(&p.height));
    let order_up = order_part(up, |p, q| p.height.total_cmp(&q.height));
    // A part in the order of height starts with its extreme.
    let lowest = |part: &[PlacedRay], order: u8| match (part.first(), order) {
        (Some(r), ORDER_HEIGHT) => r.height,
        _ => part.iter().fold(f64::INFINITY, |m, r| m.min(r.height)),
    };
    let highest = |part: &[PlacedRay], order: u8| match (part.first(), order) {
        (Some(r), ORDER_HEIGHT) => r.height,
        _ => part.iter().fold(f64::NEG_INFINITY, |m, r| m.max(r.height)),
    };
    Cell {
        up: match up.is_empty() {
            true => f32::INFINITY,
            false => f32_at_most(lowest(up, order_up)),
        },
        down: match down.is_empty() {
            true => f32::NEG_INFINITY,
            false => f32_at_least(highest(down, order_down)),
        },
        from,
        split: from + split as u32,
        orders: order_down | order_up << 2,
    }
}

/// Orders a part of a cell: a crowded one (the rays of faces nearly parallel to d fall in
/// thin strips, and so do those faces' triangles) across the strip, along the axis its rays
/// spread least on, so that a triangle tests only those in its box along it, found by
/// bisection; any other by `nearest_first`.
fn order_part(
    rays: &mut [PlacedRay],
    nearest_first: impl Fn(&PlacedRay, &PlacedRay) -> std::cmp::Ordering,
) -> u8 {
    if rays.len() <= CROWDED {
        if rays.len() > 1 {
            rays.sort_unstable_by(nearest_first);
        }
        return ORDER_HEIGHT;
    }
    let (lo, hi) = rays.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), r| (lo.min(r.at), hi.max(r.at)),
    );
    let spread = hi - lo;
    if spread.x >= spread.y {
        rays.sort_unstable_by(|p, q| p.at.y.total_cmp(&q.at.y));
        ORDER_W
    } else {
        rays.sort_unstable_by(|p, q| p.at.x.total_cmp(&q.at.x));
        ORDER_U
    }
}

/// A triangle of [`blocked_in_blocks`] as it tests the rays of cells.
struct PointTriangle {
    triangle: ProjectedTriangle,
    t: u32,
    top: f64,
    bottom: f64,
    min_hit: f64,
    /// Set up when a ray first needs them: most triangles reach no ray.
    edges: Option<[EdgeFn; 3]>,
}

impl PointTriangle {
    #[inline]
    fn new(triangle: ProjectedTriangle, t: u32, min_hit: f64) -> PointTriangle {
        let [ha, hb, hc] = triangle.h;
        PointTriangle {
            top: ha.max(hb).max(hc),
            bottom: ha.min(hb).min(hc),
            triangle,
            t,
            min_hit,
            edges: None,
        }
    }

    /// Marks in `hit` the rays of a part of a cell (all going up, or all down) that this
    /// triangle blocks; `order` is the part's.
    #[inline]
    fn test(&mut self, rays: &[PlacedRay], hit: &[AtomicBool], order: u8, up: bool) {
        let (lo, hi) = (self.triangle.lo, self.triangle.hi);
        let (first, last) = match order {
            ORDER_U => (
                rays.partition_point(|r| r.at.x < lo.x),
                rays.partition_point(|r| r.at.x <= hi.x),
            ),
            ORDER_W => (
                rays.partition_point(|r| r.at.y < lo.y),
                rays.partition_point(|r| r.at.y <= hi.y),
            ),
            _ => (0, rays.len()),
        };
        for k in first..last.max(first) {
            let r = &rays[k];
            let reaches = if up {
                self.top - r.height > self.min_hit
            } else {
                r.height - self.bottom > self.min_hit
            };
            if !reaches {
                if order == ORDER_HEIGHT {
                    // The rest start farther still.
                    break;
                }
                continue;
            }
            // Cheap rejections first: the triangle's box, its own ray, rays already
            // blocked.
            let s = r.at;
            if s.x < lo.x
                || s.x > hi.x
                || s.y < lo.y
                || s.y > hi.y
                || r.triangle & !UP == self.t
                || hit[k].load(Ordering::Relaxed)
            {
                continue;
            }
            let triangle = &self.triangle;
            let [bc, ca, ab] = self.edges.get_or_insert_with(|| triangle.edges());
            let inside = |e: f64, edge: &EdgeFn| (e > 0.0) | ((e == 0.0) & edge.owned);
            let (e_bc, e_ca, e_ab) = (bc.at(s), ca.at(s), ab.at(s));
            if inside(e_bc, bc) & inside(e_ca, ca) & inside(e_ab, ab) {
                let [ha, hb, hc] = triangle.h;
                let h = (e_bc * ha + e_ca * hb + e_ab * hc) / (e_bc + e_ca + e_ab);
                let along = if up { h - r.height } else { r.height - h };
                if along > self.min_hit {
                    hit[k].store(true, Ordering::Relaxed);
                }
            }
        }
    }
}

/// The largest f32 at most `x` (`x` itself when it is one; infinities stay).
#[inline]
fn f32_at_most(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) <= x || f.is_nan() {
        f
    } else if f == 0.0 {
        -f32::from_bits(1)
    } else if f > 0.0 {
        // The next f32 down (`f32::next_down`, which is newer than the crate's Rust).
        f32::from_bits(f.to_bits() - 1)
    } else {
        f32::from_bits(f.to_bits() + 1)
    }
}

/// The least f32 at least `x`.
#[inline]
fn f32_at_least(x: f64) -> f32 {
    -f32_at_most(-x)
}

/// The bit of [`PlacedRay::triangle`] that says the ray goes along +d.
const UP: u32 = 1 << 31;

/// The cell of a ray at a point that is not finite: no cell, never blocked.
const NO_CELL: u32 = u32::MAX;

/// Rays a cell of [`blocked_in_blocks`] holds on average over the rays' box: with about
/// one, a triangle visits twice as many cells for the rays it tests (the 352k-triangle
/// housing's choice takes 5 % more instructions, and more of the heap).
const RAYS_A_CELL: f64 = 4.0;

/// Parts of cells with more rays than this going one way are sorted along an axis: below
/// it, reading every ray costs less than finding the triangle's box in them by bisection
/// (the 352k housing's choice: 3 % less CPU time than at 8, paired).
const CROWDED: usize = 32;

/// Triangles per task of [`blocked`].
const POINT_BLOCK: usize = 2048;

/// Tasks a run of [`blocked_until`] is cut in at least, when that leaves each
/// [`POINT_BLOCK_LEAST`] triangles or more.
const POINT_TASKS: usize = 8;

/// Triangles per task of [`blocked_until`] at least.
const POINT_BLOCK_LEAST: usize = 256;

/// Rays per block of [`blocked`] (the slice handed to [`blocked_in_blocks`]).
const RAY_BLOCK: usize = 4096;

/// The ray-triangle tests that drawings of triangles into scattered rays ([`blocked_until`])
/// may make together, counted as they draw: a triangle takes [`RAYS_A_CELL`] tests for each
/// cell its projected box covers (the rays it may meet), charged before it is drawn. Once
/// the limit is passed every drawing sharing the budget stops at its next triangle, and
/// what they found is incomplete: the caller asks [`TestBudget::exceeded`] and refuses the
/// work. Whether the limit is passed does not depend on the threads: the tests charged
/// before it are those of the complete drawings, in whatever order they were made.
#[derive(Debug)]
pub struct TestBudget {
    limit: u64,
    used: AtomicU64,
    /// Once set, the drawings stop as past the limit ([`TestBudget::cancelled`]).
    cancel: Option<crate::cancel::Cancel>,
}

/// Tests a task charges to a [`TestBudget`] at once (fewer atomic operations; a task
/// passes the limit by at most this and one triangle's tests).
const CHARGE_BATCH: u64 = 1 << 16;

impl TestBudget {
    /// A budget of `limit` tests.
    pub fn new(limit: f64) -> TestBudget {
        TestBudget {
            limit: if limit >= u64::MAX as f64 {
                u64::MAX
            } else {
                limit.max(0.0) as u64
            },
            used: AtomicU64::new(0),
            cancel: None,
        }
    }

    /// This budget, stopped also when `cancel` is set.
    pub fn with_cancel(mut self, cancel: Option<&crate::cancel::Cancel>) -> TestBudget {
        self.cancel = cancel.cloned();
        self
    }

    /// Whether the drawings were stopped by the cancel token.
    pub fn cancelled(&self) -> bool {
        crate::cancel::is_set(self.cancel.as_ref())
    }

    /// Whether the drawings stop: past the limit, or cancelled.
    pub fn stopped(&self) -> bool {
        self.exceeded() || self.cancelled()
    }

    /// No limit.
    pub fn unlimited() -> TestBudget {
        TestBudget::new(f64::INFINITY)
    }

    /// The limit, in tests.
    pub fn limit(&self) -> f64 {
        self.limit as f64
    }

    /// The tests charged so far.
    pub fn used(&self) -> u64 {
        self.used.load(Ordering::Relaxed)
    }

    /// Whether the tests charged passed the limit.
    pub fn exceeded(&self) -> bool {
        self.used() > self.limit
    }

    /// Charges `tests`; whether the limit still holds.
    fn charge(&self, tests: u64) -> bool {
        let before = self.used.fetch_add(tests, Ordering::Relaxed);
        before.saturating_add(tests) <= self.limit && !self.cancelled()
    }
}

/// For every ray, whether it meets a triangle other than its own farther than `min_hit`
/// along it: [`blocked_in_blocks`] on rays held in a slice.
pub fn blocked(
    vertices: &[DVec3],
    frame: &Frame,
    triangles: &[[u32; 3]],
    rays: &[PointRay],
    min_hit: f64,
) -> Vec<bool> {
    let block = |b: usize| &rays[b * RAY_BLOCK..((b + 1) * RAY_BLOCK).min(rays.len())];
    let found = blocked_in_blocks(
        vertices,
        frame,
        triangles,
        rays.len().div_ceil(RAY_BLOCK),
        |b, sink| block(b).iter().for_each(|&r| sink.push(r)),
        min_hit,
    );
    let mut out = vec![false; rays.len()];
    for b in found {
        out[b.ray as usize] = true;
    }
    out
}

/// The rays that meet a triangle other than their own farther than `min_hit` along them,
/// in the order of their numbers: the any-hit test of rays that are all parallel to d,
/// answered like the lattice's rays are (see the module), only at scattered points.
///
/// The rays come in `blocks`: `rays(b, sink)` pushes the rays of block `b` in order
/// (the blocks are made in parallel, each once). Ray numbers count them block after block.
///
/// The rays' start points are sorted into a uniform grid of cells of the projection plane
/// (a few rays a cell); each triangle is tested against the rays of the cells its
/// projected box covers, with the same edge functions and top-left rule as the lattice, so a
/// ray through an edge shared by two triangles meets exactly one of them. Triangles are taken
/// in blocks on every thread; a ray is blocked when any triangle blocks it, so the answer
/// does not depend on the order or on the number of threads.
pub fn blocked_in_blocks<F>(
    vertices: &[DVec3],
    frame: &Frame,
    triangles: &[[u32; 3]],
    blocks: usize,
    rays: F,
    min_hit: f64,
) -> Vec<BlockedRay>
where
    F: Fn(usize, &mut RaySink) + Sync,
{
    blocked_until(
        vertices,
        frame,
        (triangles, 1),
        blocks,
        rays,
        min_hit,
        |_| false,
        &TestBudget::unlimited(),
    )
}

/// [`blocked_in_blocks`] that may stop before every triangle is drawn: the triangles are
/// drawn in `rounds` runs of consecutive ones, and after each run but the last `enough`
/// is asked with the rays blocked so far (in the order of their numbers); when it says so,
/// those are the answer. Every ray in it is blocked (by the triangles drawn), and which
/// rays are in it does not depend on the number of threads.
///
/// The tests are charged to `budget`; once it is exceeded the drawing stops and what it
/// returns is incomplete (see [`TestBudget`]).
///
/// The rays of a drawing of more than [`REMADE_ABOVE_BLOCKS`] blocks are made again where
/// they are placed in their cells rather than kept from their first making (they are made
/// three times: for their box, for the counts of their cells, and where they are placed),
/// so that the rays are not held twice at once (32 bytes a ray; on 8.1 million triangles,
/// the peak of the automatic direction 1.57 to 1.63 times the file's size rather than 1.98
/// to 2.08); drawn in one round, more than a quarter of [`BAND_RAYS`] of them are placed
/// and drawn in bands of rows of cells (on that file, 1.31 times the file's size). The same
/// rays either way, and the same answer.
#[allow(clippy::too_many_arguments)] // The drawing's inputs, each used once.
pub fn blocked_until<F>(
    vertices: &[DVec3],
    frame: &Frame,
    triangles: (&[[u32; 3]], usize),
    blocks: usize,
    rays: F,
    min_hit: f64,
    enough: impl FnMut(&[BlockedRay]) -> bool,
    budget: &TestBudget,
) -> Vec<BlockedRay>
where
    F: Fn(usize, &mut RaySink) + Sync,
{
    blocked_until_remade_above(
        vertices,
        frame,
        triangles,
        (blocks, REMADE_ABOVE_BLOCKS, BAND_RAYS),
        rays,
        min_hit,
        enough,
        budget,
    )
}

/// Blocks of rays above which [`blocked_until`] makes each block's rays again where it
/// places them (about two million facets of the automatic direction's rays): below it the
/// rays held twice are a few tens of megabytes, and making them again would cost (made
/// again at every size) the 352k-triangle housing's automatic direction 7 % more time;
/// on 8.1 million triangles the whole command takes 1.8 % more CPU time (paired runs).
pub const REMADE_ABOVE_BLOCKS: usize = 2048;

/// Blocks of rays made again at once, on all threads, by [`blocked_until`].
const REMADE_AT_ONCE: usize = 64;

/// Most rays [`blocked_until`] places at once in a drawing whose rays it makes again and
/// draws in one round (4.2 million rays, 134 MB). One of more than a quarter as many is
/// drawn in two or more bands of rows of cells of at most about as many rays each, every
/// triangle in each band its rows reach: on the housing's 8 copies (2.8 million triangles)
/// the automatic direction's whole drawing of 2.2 million rays is drawn in two bands, its
/// peak 1.4 times the file's size rather than 1.7 for 2 % more time; on 23 copies (8.1
/// million), 6.3 million rays in two bands (four would save a tenth of the peak for 10 %
/// more CPU time).
const BAND_RAYS: usize = 4 << 20;

/// [`blocked_until`] with the rays of more than `remade_above` blocks made again where they
/// are placed, and a drawing of them in one round of more than a quarter of `band_rays` rays
/// drawn in two or more bands of at most about `band_rays`.
#[allow(clippy::too_many_arguments)] // The drawing's inputs, each used once.
fn blocked_until_remade_above<F>(
    vertices: &[DVec3],
    frame: &Frame,
    (triangles, rounds): (&[[u32; 3]], usize),
    (blocks, remade_above, band_rays): (usize, usize, usize),
    rays: F,
    min_hit: f64,
    mut enough: impl FnMut(&[BlockedRay]) -> bool,
    budget: &TestBudget,
) -> Vec<BlockedRay>
where
    F: Fn(usize, &mut RaySink) + Sync,
{
    // Each block's rays in the plane (unless they are made again) and the box of their
    // points, on every thread (a minimum and a maximum do not depend on the order they are
    // taken in).
    let empty = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    let make = |b: usize| {
        let mut sink = RaySink {
            frame,
            rays: Vec::new(),
            lo: empty.0,
            hi: empty.1,
        };
        rays(b, &mut sink);
        sink
    };
    let remade = blocks > remade_above;
    let mut made: Vec<(Vec<PlacedRay>, usize, DVec2, DVec2)> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let sink = make(b);
            let n = sink.rays.len();
            let kept = if remade { Vec::new() } else { sink.rays };
            (kept, n, sink.lo, sink.hi)
        })
        .collect();
    let count: usize = made.iter().map(|m| m.1).sum();
    let (lo, hi) = made
        .iter()
        .fold(empty, |(lo, hi), &(_, _, l, h)| (lo.min(l), hi.max(h)));
    if !(lo.x <= hi.x && lo.y <= hi.y) {
        return Vec::new();
    }
    // About [`RAYS_A_CELL`] rays a cell, at most 4096 cells a side.
    let size = hi - lo;
    let area = (size.x * size.y).max(f64::MIN_POSITIVE);
    let mut cell = (area * RAYS_A_CELL / count as f64).sqrt();
    let longest = size.x.max(size.y);
    if !(cell.is_finite() && cell > 0.0) || longest / cell > 4096.0 {
        cell = (longest / 4096.0).max(f64::MIN_POSITIVE);
    }
    let inv = 1.0 / cell;
    let n_u = ((size.x * inv) as usize + 1).min(4097);
    let n_w = ((size.y * inv) as usize + 1).min(4097);
    let n_cells = n_u * n_w;
    let (last_u, last_w) = ((n_u - 1) as f64, (n_w - 1) as f64);
    let cell_of = |q: DVec2| -> u32 {
        if !q.is_finite() {
            return NO_CELL;
        }
        // As `cell_range` finds them.
        let i = ((q.x - lo.x) * inv).min(last_u) as u32;
        let j = ((q.y - lo.y) * inv).min(last_w) as u32;
        j * n_u as u32 + i
    };
    // Counting sort of the rays by cell: `start[c]` is first the count of cell c - 1, then
    // where cell c begins (each band places its rays from there, see below). The cell of a
    // kept ray is held in its `ray` until it is placed; rays made again are counted as they
    // are made (each count a sum, the same in any order), and their cells found again when
    // they are placed.
    let mut start = if remade {
        let counts: Vec<AtomicU32> = (0..n_cells + 1).map(|_| AtomicU32::new(0)).collect();
        (0..blocks).into_par_iter().for_each(|b| {
            for r in &make(b).rays {
                let cell = cell_of(r.at);
                if cell != NO_CELL {
                    counts[cell as usize + 1].fetch_add(1, Ordering::Relaxed);
                }
            }
        });
        counts.into_iter().map(AtomicU32::into_inner).collect()
    } else {
        made.par_iter_mut().for_each(|(block, ..)| {
            for r in block {
                r.ray = cell_of(r.at);
            }
        });
        let mut start = vec![0u32; n_cells + 1];
        for r in made.iter().flat_map(|m| &m.0) {
            if r.ray != NO_CELL {
                start[r.ray as usize + 1] += 1;
            }
        }
        start
    };
    for c in 0..n_cells {
        start[c + 1] += start[c];
    }
    // The rows of cells drawn at once: all of them, or, for a large drawing drawn whole (one
    // round, its rays made again, more than a quarter of `band_rays`), two or more bands of
    // rows of at most about `band_rays` rays each, so that no more rays than a band's are
    // placed at once; every triangle is drawn in each band its rows reach. The same tests of
    // the same rays: the same answer.
    let total = start[n_cells] as usize;
    let mut bands = vec![(0, n_w)];
    if remade && rounds == 1 && total > band_rays / 4 {
        let share = total.div_ceil(total.div_ceil(band_rays).max(2));
        bands.clear();
        let mut first = 0;
        for j in 0..n_w {
            let rays = (start[(j + 1) * n_u] - start[first * n_u]) as usize;
            if rays >= share || j + 1 == n_w {
                bands.push((first, j + 1));
                first = j + 1;
            }
        }
    }
    let mut all_found: Vec<BlockedRay> = Vec::new();
    for &(ja, jb) in &bands {
        let (a, b) = (ja * n_u, jb * n_u);
        let base = start[a];
        let placed_len = (start[b] - base) as usize;
        let mut placed = vec![
            PlacedRay {
                at: DVec2::ZERO,
                height: 0.0,
                triangle: 0,
                ray: 0,
            };
            placed_len
        ];
        // Each ray of the band into the next slot of its cell, in the order of the rays'
        // numbers (`next` holds where each cell of the band begins, then where its rays
        // placed so far end).
        let mut next: Vec<u32> = start[a..b].to_vec();
        let mut number = 0u32;
        let mut place = |r: &PlacedRay, cell: u32| {
            if cell != NO_CELL && (a..b).contains(&(cell as usize)) {
                let slot = &mut next[cell as usize - a];
                placed[(*slot - base) as usize] = PlacedRay { ray: number, ..*r };
                *slot += 1;
            }
            number += 1;
        };
        if remade {
            for first in (0..blocks).step_by(REMADE_AT_ONCE) {
                let last = (first + REMADE_AT_ONCE).min(blocks);
                let again: Vec<Vec<PlacedRay>> = (first..last)
                    .into_par_iter()
                    .map(|b| make(b).rays)
                    .collect();
                for (b, rays) in (first..last).zip(again) {
                    debug_assert_eq!(rays.len(), made[b].1, "the same rays made again");
                    for r in &rays {
                        place(r, cell_of(r.at));
                    }
                }
            }
        } else {
            for r in made.iter().flat_map(|m| &m.0) {
                place(r, r.ray);
            }
            made = Vec::new();
        }
        drop(next);
        // Each cell's rays going down first, then those going up, each part in the order a
        // triangle reads it (see `Order`), cells taken in parallel in runs.
        let from_of = |c: usize| start[c] - base;
        let mut cells: Vec<Cell> = Vec::with_capacity(b - a + 1);
        {
            let mut rest: &mut [PlacedRay] = &mut placed;
            let mut runs: Vec<(usize, &mut [PlacedRay])> = Vec::new();
            for first in (a..b).step_by(CELL_RUN) {
                let last = (first + CELL_RUN).min(b);
                let len = (from_of(last) - from_of(first)) as usize;
                let (run, tail) = rest.split_at_mut(len);
                rest = tail;
                runs.push((first, run));
            }
            let made: Vec<Vec<Cell>> = runs
                .into_par_iter()
                .map(|(first, run)| {
                    let run_base = from_of(first);
                    (first..(first + CELL_RUN).min(b))
                        .map(|c| {
                            let (from, to) = (from_of(c), from_of(c + 1));
                            let rays =
                                &mut run[(from - run_base) as usize..(to - run_base) as usize];
                            order_cell(from, rays)
                        })
                        .collect()
                })
                .collect();
            for run in made {
                cells.extend(run);
            }
        }
        // A last cell that only ends the one before.
        cells.push(Cell {
            up: f32::INFINITY,
            down: f32::NEG_INFINITY,
            from: placed_len as u32,
            split: placed_len as u32,
            orders: 0,
        });
        let hit: Vec<AtomicBool> = (0..placed_len).map(|_| AtomicBool::new(false)).collect();
        // Draws the triangles `offset..offset + part.len()` against the band's rows.
        let draw = |offset: usize, part: &[[u32; 3]]| {
            // A run of a stopped bound is a few thousand triangles: in tasks of fewer, so
            // that both threads draw it (which rays are blocked does not depend on the tasks).
            let task = POINT_BLOCK.min(part.len().div_ceil(POINT_TASKS).max(POINT_BLOCK_LEAST));
            part.par_chunks(task).enumerate().for_each(|(b, block)| {
                if budget.stopped() {
                    return;
                }
                // Tests counted here, charged to the budget in batches.
                let mut owed = 0u64;
                for (k, tri) in block.iter().enumerate() {
                    let t = (offset + b * task + k) as u32;
                    // Each corner written out: `tri.map` with a closure is not always
                    // inlined (a tenth more instructions in this loop when it is not).
                    let corner = |k: usize| uwh(frame, vertices[tri[k] as usize]);
                    let (a, bb, c) = (corner(0), corner(1), corner(2));
                    let Some(triangle) = ProjectedTriangle::new(a, bb, c) else {
                        continue;
                    };
                    let Some((j0, j1)) =
                        cell_range(lo.y, hi.y, inv, n_w, triangle.lo.y, triangle.hi.y)
                    else {
                        continue;
                    };
                    // The rows of this band only.
                    let (j0, j1) = (j0.max(ja), j1.min(jb - 1));
                    if j0 > j1 {
                        continue;
                    }
                    let Some((i0, i1)) =
                        cell_range(lo.x, hi.x, inv, n_u, triangle.lo.x, triangle.hi.x)
                    else {
                        continue;
                    };
                    owed += ((i1 - i0 + 1) * (j1 - j0 + 1)) as u64 * RAYS_A_CELL as u64;
                    if owed >= CHARGE_BATCH {
                        if !budget.charge(owed) {
                            return;
                        }
                        owed = 0;
                    }
                    let mut drawn = PointTriangle::new(triangle, t, min_hit);
                    for j in j0..=j1 {
                        let row = (j - ja) * n_u;
                        // Each cell with the next, which ends it.
                        for pair in cells[row + i0..=row + i1 + 1].windows(2) {
                            let cell = &pair[0];
                            // The rays going up that start below the triangle's top, and
                            // those going down that start above its bottom (the cell's
                            // bounds are rounded outwards, so no ray the exact test keeps is
                            // left out).
                            if drawn.top - f64::from(cell.up) > min_hit {
                                let (from, to) = (cell.split as usize, pair[1].from as usize);
                                drawn.test(
                                    &placed[from..to],
                                    &hit[from..to],
                                    cell.orders >> 2,
                                    true,
                                );
                            }
                            if f64::from(cell.down) - drawn.bottom > min_hit {
                                let (from, to) = (cell.from as usize, cell.split as usize);
                                drawn.test(
                                    &placed[from..to],
                                    &hit[from..to],
                                    cell.orders & 3,
                                    false,
                                );
                            }
                        }
                    }
                }
                budget.charge(owed);
            });
        };
        // The band's rays blocked so far, in the order of their numbers.
        let found = || {
            let mut found: Vec<BlockedRay> = placed
                .iter()
                .zip(&hit)
                .filter(|(_, h)| h.load(Ordering::Relaxed))
                .map(|(r, _)| BlockedRay {
                    ray: r.ray,
                    triangle: r.triangle & !UP,
                })
                .collect();
            found.sort_unstable_by_key(|b| b.ray);
            found
        };
        // Drawn in rounds only as one band (see above).
        let size = triangles.len().div_ceil(rounds.max(1)).max(1);
        for (r, part) in triangles.chunks(size).enumerate() {
            draw(r * size, part);
            if budget.stopped() {
                break;
            }
            if (r + 1) * size < triangles.len() {
                let so_far = found();
                if enough(&so_far) {
                    return so_far;
                }
            }
        }
        if bands.len() == 1 {
            return found();
        }
        all_found.extend(found());
        if budget.stopped() {
            break;
        }
    }
    all_found.sort_unstable_by_key(|b| b.ray);
    all_found
}

/// The cells `from..=to` of a row of `n` cells of width `1 / inv` from `lo` (the last one
/// reaching `hi`) that the interval [a, b] overlaps, by the arithmetic that put the rays in
/// their cells; `None` when it misses the row.
#[inline]
fn cell_range(lo: f64, hi: f64, inv: f64, n: usize, a: f64, b: f64) -> Option<(usize, usize)> {
    if !(a <= hi && b >= lo) {
        return None;
    }
    // The cell index clamped before it is made an integer (the same index, fewer
    // instructions than the saturating conversion to usize).
    let last = (n - 1) as f64;
    let cell = |x: f64| ((x.max(lo) - lo) * inv).min(last) as u32 as usize;
    Some((cell(a), cell(b)))
}

/// A vertex as (u, w, height along d).
#[inline]
fn uwh(frame: &Frame, p: DVec3) -> DVec3 {
    let q = frame.project(p);
    DVec3::new(q.x, q.y, frame.height(p))
}

/// `x - floor(x)`, in [0, 1), without a call to the C library's floor.
#[inline]
fn fraction(x: f64) -> f64 {
    let t = x as i64 as f64; // rounds towards zero (saturating, so it stays finite)
    let f = x - t;
    if f < 0.0 {
        f + 1.0
    } else {
        f
    }
}

/// Buckets of [0, 1) per spacing for the lattice offsets along one axis.
const BUCKETS: usize = 256;

/// The lattice offsets along one axis (each in [0, 1) spacings), sorted into [`BUCKETS`]
/// equal buckets, to find the lattices an interval may cover with two look-ups.
struct OffsetBuckets {
    /// `below[b]`: the lattices whose offset lies in a bucket below `b`, as a bit mask.
    below: [u64; BUCKETS + 1],
    /// Every lattice of the group.
    all: u64,
}

impl OffsetBuckets {
    fn new(offsets: &[f64]) -> OffsetBuckets {
        debug_assert!(offsets.len() <= 64);
        let mut below = [0u64; BUCKETS + 1];
        for (k, &f) in offsets.iter().enumerate() {
            // Exact: BUCKETS is a power of two and f is in [0, 1).
            let b = ((f * BUCKETS as f64) as usize).min(BUCKETS - 1);
            for m in &mut below[b + 1..] {
                *m |= 1 << k;
            }
        }
        OffsetBuckets {
            below,
            all: below[BUCKETS],
        }
    }

    /// A conservative test: the lattices whose offset may lie in the interval that starts
    /// `start` (in [0, 1)) past an integer and is `width` long, taken modulo 1. Widened by a
    /// millionth of a spacing and rounded out to whole buckets; [`ProjectedTriangle::draw`]
    /// decides exactly.
    #[inline]
    fn covering(&self, start: f64, width: f64) -> u64 {
        const MARGIN: f64 = 1e-6;
        // Also true for NaN: every lattice, and the exact test decides.
        if width.is_nan() || width + 2.0 * MARGIN >= 1.0 {
            return self.all;
        }
        let (scale, n) = (BUCKETS as f64, BUCKETS as i64);
        // start - MARGIN > -1 and start + width + MARGIN < 2, so both shifted values are
        // positive and the conversions round down. (Rounding in the shift can only lift a
        // bound by a bucket when it lies within 1e-13 of the bucket's edge, far inside the
        // margin.)
        let first = ((start - MARGIN) * scale + scale) as i64 - n;
        let last = ((start + width + MARGIN) * scale + scale) as i64 - n;
        let (lo, hi) = (first.rem_euclid(n) as usize, last.rem_euclid(n) as usize);
        let upto = self.below[hi + 1];
        let from = !self.below[lo];
        // The buckets lo..=hi, or lo..B and 0..=hi when the interval wraps past 1 (or covers
        // every bucket).
        if hi < lo || last - first >= n {
            (upto | from) & self.all
        } else {
            upto & from
        }
    }
}

/// A triangle seen along the demolding direction, counter-clockwise in (u, w).
struct ProjectedTriangle {
    p: [DVec2; 3],
    h: [f64; 3],
    lo: DVec2,
    hi: DVec2,
}

impl ProjectedTriangle {
    /// `None` for a triangle seen edge-on (zero projected area).
    #[inline]
    fn new(a: DVec3, b: DVec3, c: DVec3) -> Option<ProjectedTriangle> {
        let (pa, mut pb, mut pc) = (a.truncate(), b.truncate(), c.truncate());
        let (ha, mut hb, mut hc) = (a.z, b.z, c.z);
        let area2 = orient2d(pa, pb, pc);
        if area2 == 0.0 || area2.is_nan() {
            return None;
        }
        if area2 < 0.0 {
            std::mem::swap(&mut pb, &mut pc);
            std::mem::swap(&mut hb, &mut hc);
        }
        Some(ProjectedTriangle {
            p: [pa, pb, pc],
            h: [ha, hb, hc],
            lo: pa.min(pb).min(pc),
            hi: pa.max(pb).max(pc),
        })
    }

    /// The edge functions of the edges opposite a, b and c, set up once for every lattice
    /// the triangle is drawn into.
    #[inline]
    fn edges(&self) -> [EdgeFn; 3] {
        let [pa, pb, pc] = self.p;
        [
            EdgeFn::new(pb, pc),
            EdgeFn::new(pc, pa),
            EdgeFn::new(pa, pb),
        ]
    }

    /// Adds this triangle's height to every ray of `lattice` inside it; `edges` are its
    /// [`ProjectedTriangle::edges`].
    #[inline]
    fn draw<R: Record>(
        &self,
        [bc, ca, ab]: &[EdgeFn; 3],
        t: u32,
        (lattice, [along_u, along_w], inv): (&RayLattice, &[LatticeAxis; 2], f64),
        hits: &mut [R],
        base: f64,
    ) {
        let [ha, hb, hc] = self.h;
        let o = lattice.origin;
        let Some((i0, i1)) = along_u.range(inv, self.lo.x, self.hi.x) else {
            return;
        };
        let Some((j0, j1)) = along_w.range(inv, self.lo.y, self.hi.y) else {
            return;
        };
        let inside = |e: f64, edge: &EdgeFn| (e > 0.0) | ((e == 0.0) & edge.owned);
        if i0 == i1 && j0 == j1 {
            // One candidate ray, the common case (most triangles are smaller than a
            // spacing): the loops' work without the loops.
            let s = DVec2::new(
                o.x + i0 as f64 * lattice.spacing,
                o.y + j0 as f64 * lattice.spacing,
            );
            let (e_bc, e_ca, e_ab) = (bc.at(s), ca.at(s), ab.at(s));
            if inside(e_bc, bc) & inside(e_ca, ca) & inside(e_ab, ab) {
                let height = (e_bc * ha + e_ca * hb + e_ab * hc) / (e_bc + e_ca + e_ab);
                hits[j0 * lattice.n_u + i0].add(height, t, base);
            }
            return;
        }
        let wide = i1 - i0 > 2;
        for j in j0..=j1 {
            let y = o.y + j as f64 * lattice.spacing;
            let row = j * lattice.n_u;
            // On a wide triangle, only the columns near the row's span inside it are tested:
            // long thin triangles would otherwise test every ray of their bounding box.
            let (from, to) = if wide {
                match [bc, ca, ab]
                    .iter()
                    .try_fold((i0 as f64, i1 as f64), |span, e| {
                        e.row_span(y, o.x, inv, span)
                    }) {
                    Some((a, b)) => ((a as usize).max(i0), (b as usize).min(i1)),
                    None => continue,
                }
            } else {
                (i0, i1)
            };
            for i in from..=to {
                let s = DVec2::new(o.x + i as f64 * lattice.spacing, y);
                let (e_bc, e_ca, e_ab) = (bc.at(s), ca.at(s), ab.at(s));
                if inside(e_bc, bc) & inside(e_ca, ca) & inside(e_ab, ab) {
                    let height = (e_bc * ha + e_ca * hb + e_ab * hc) / (e_bc + e_ca + e_ab);
                    hits[row + i].add(height, t, base);
                }
            }
        }
    }
}

/// The edge function of a triangle's edge p->q, set up once per triangle and lattice.
///
/// It is evaluated from the edge's lexicographically smaller end, so that the two triangles
/// sharing the edge get bit-identical magnitudes: `orient2d(p, q, s)` when p is the smaller
/// end, `-orient2d(q, p, s)` otherwise, with the same floating-point operations.
struct EdgeFn {
    from: DVec2,
    along: DVec2,
    sign: f64,
    /// Whether the triangle owns the rays exactly on this edge (the top-left rule).
    owned: bool,
}

impl EdgeFn {
    /// Without branches: which end is smaller is a coin toss from one triangle to the next,
    /// and mispredicted branches would cost more than the arithmetic.
    #[inline]
    fn new(p: DVec2, q: DVec2) -> EdgeFn {
        let p_first = (p.x < q.x) | ((p.x == q.x) & (p.y < q.y));
        let mask = glam::BVec2::splat(p_first);
        let from = DVec2::select(mask, p, q);
        let to = DVec2::select(mask, q, p);
        EdgeFn {
            from,
            along: to - from,
            sign: f64::from(u8::from(p_first)) * 2.0 - 1.0,
            owned: owns_edge(p, q),
        }
    }

    /// Narrows the column span `(a, b)` of a row at height `y` to the columns where this
    /// edge function may be non-negative, widened by one column on each side so that
    /// rounding in the division cannot drop a ray the exact test would keep. `None` when no
    /// column can be inside.
    #[inline]
    fn row_span(&self, y: f64, origin_x: f64, inv: f64, (a, b): (f64, f64)) -> Option<(f64, f64)> {
        // e(x) = c + slope * x along the row.
        let slope = -self.sign * self.along.y;
        let c = self.sign * (self.along.x * (y - self.from.y) + self.along.y * self.from.x);
        let (a, b) = if slope > 0.0 {
            let x = -c / slope;
            (a.max(((x - origin_x) * inv).floor() - 1.0), b)
        } else if slope < 0.0 {
            let x = -c / slope;
            (a, b.min(((x - origin_x) * inv).ceil() + 1.0))
        } else if c < 0.0 {
            return None;
        } else {
            (a, b)
        };
        (a <= b).then_some((a.max(0.0), b))
    }

    #[inline]
    fn at(&self, s: DVec2) -> f64 {
        self.sign * (self.along.x * (s.y - self.from.y) - self.along.y * (s.x - self.from.x))
    }
}

/// Whether a counter-clockwise triangle owns the points on its edge p->q: the top-left rule
/// (left edges go down, top edges go left, with w pointing up).
#[inline]
fn owns_edge(p: DVec2, q: DVec2) -> bool {
    (q.y < p.y) | ((q.y == p.y) & (q.x < p.x))
}

/// `floor(x)` for a finite `x` of moderate size, without a call to the C library.
#[inline]
fn floor_int(x: f64) -> i64 {
    let t = x as i64;
    t - i64::from(t as f64 > x)
}

/// `ceil(x)` for a finite `x` of moderate size, without a call to the C library.
#[inline]
fn ceil_int(x: f64) -> i64 {
    let t = x as i64;
    t + i64::from((t as f64) < x)
}

/// One axis of a lattice: its origin and size, with the size also as the numbers the range
/// of [`LatticeAxis::range`] is clamped to, made once per lattice rather than per triangle.
#[derive(Debug, Clone, Copy)]
struct LatticeAxis {
    origin: f64,
    /// The number of rays along the axis.
    top: f64,
    /// The last ray's index.
    last: i64,
}

impl LatticeAxis {
    fn new(origin: f64, n: usize) -> LatticeAxis {
        LatticeAxis {
            origin,
            top: n as f64,
            last: n as i64 - 1,
        }
    }

    /// A range of lattice indices that holds every index whose coordinate `origin + i *
    /// spacing` lies in [lo, hi], and at most the neighbours within a billionth of a
    /// spacing: a superset is enough, since the exact edge test decides each ray.
    #[inline]
    fn range(&self, inv_spacing: f64, lo: f64, hi: f64) -> Option<(usize, usize)> {
        const SLACK: f64 = 1e-9;
        // Clamped first, so that the conversions to integers cannot saturate.
        let i0 = ceil_int(((lo - self.origin) * inv_spacing - SLACK).clamp(-1.0, self.top)).max(0);
        let i1 = floor_int(((hi - self.origin) * inv_spacing + SLACK).clamp(-1.0, self.top))
            .min(self.last);
        (i0 <= i1).then_some((i0 as usize, i1 as usize))
    }
}

/// [`LatticeAxis::range`] of the axis with `origin` and `n` rays.
#[cfg(test)]
fn index_range(
    origin: f64,
    inv_spacing: f64,
    n: usize,
    lo: f64,
    hi: f64,
) -> Option<(usize, usize)> {
    LatticeAxis::new(origin, n).range(inv_spacing, lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The edge function written out directly, as the reference for [`EdgeFn`].
    fn edge_function(p: DVec2, q: DVec2, s: DVec2) -> f64 {
        if (p.x, p.y) < (q.x, q.y) {
            orient2d(p, q, s)
        } else {
            -orient2d(q, p, s)
        }
    }

    #[test]
    fn row_spans_keep_every_ray_of_long_thin_triangles() {
        // Slivers at many angles over a lattice whose rays they graze: drawing with row spans
        // must give exactly the hits of testing every ray of the bounding box.
        let l = RayLattice {
            origin: DVec2::new(-0.3, 0.2),
            spacing: 0.1,
            n_u: 120,
            n_w: 90,
        };
        for k in 0..200 {
            let a = k as f64 * 0.0317;
            let dir = DVec2::new(a.cos(), a.sin());
            let normal = DVec2::new(-dir.y, dir.x) * (0.001 + 0.002 * (k % 7) as f64);
            let start = DVec2::new(0.4 + 0.01 * (k % 13) as f64, 4.1);
            let (p, q, r) = (start - dir * 5.0, start + dir * 6.0, start + normal);
            let Some(tri) = ProjectedTriangle::new(p.extend(1.0), q.extend(2.0), r.extend(3.0))
            else {
                continue;
            };
            let mut drawn = vec![Hit::MISS; l.n_u * l.n_w];
            let axes = [
                LatticeAxis::new(l.origin.x, l.n_u),
                LatticeAxis::new(l.origin.y, l.n_w),
            ];
            tri.draw(
                &tri.edges(),
                k,
                (&l, &axes, 1.0 / l.spacing),
                &mut drawn,
                0.0,
            );
            let mut every = vec![Hit::MISS; l.n_u * l.n_w];
            let [pa, pb, pc] = tri.p;
            let edges = [
                EdgeFn::new(pb, pc),
                EdgeFn::new(pc, pa),
                EdgeFn::new(pa, pb),
            ];
            for j in 0..l.n_w {
                for i in 0..l.n_u {
                    let s = l.origin + DVec2::new(i as f64, j as f64) * l.spacing;
                    let e = edges.each_ref().map(|edge| edge.at(s));
                    let inside = (0..3).all(|m| e[m] > 0.0 || (e[m] == 0.0 && edges[m].owned));
                    if inside {
                        let h = (e[0] * tri.h[0] + e[1] * tri.h[1] + e[2] * tri.h[2])
                            / (e[0] + e[1] + e[2]);
                        every[j * l.n_u + i].add(h, k);
                    }
                }
            }
            assert_eq!(drawn, every, "sliver {k}");
        }
    }

    /// A small deterministic generator of numbers in [0, 1) (xorshift): no dependency
    /// needed.
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn offset_buckets_hold_every_covered_lattice_and_little_more() {
        let mut next = uniform(0x9E37_79B9_7F4A_7C15);
        // Offsets on and next to bucket edges as well as random ones.
        let mut offsets: Vec<f64> = (0..40).map(|_| next()).collect();
        offsets.extend([
            0.0,
            0.5,
            0.25,
            1.0 - 1e-12,
            3.0 / 256.0,
            3.0 / 256.0 - 1e-12,
        ]);
        let buckets = OffsetBuckets::new(&offsets);
        assert_eq!(buckets.all, (1u64 << offsets.len()) - 1);
        // Distance from a to b going up, modulo 1.
        let ahead = |a: f64, b: f64| (b - a).rem_euclid(1.0);
        for case in 0..20_000 {
            let start = if case % 5 == 0 {
                offsets[case % offsets.len()]
            } else {
                next()
            };
            let width = match case % 4 {
                0 => 0.0,
                1 => next() * 0.05,
                2 => next(),
                _ => next() * 3.0,
            };
            let mask = buckets.covering(start, width);
            for (k, &f) in offsets.iter().enumerate() {
                let inside = width >= 1.0 || ahead(start, f) <= width;
                let near = width + 2.0 / 256.0 + 2e-6 >= 1.0
                    || ahead(start - 1.0 / 256.0 - 1e-6, f) <= width + 2.0 / 256.0 + 2e-6;
                let got = mask >> k & 1 == 1;
                assert!(!inside || got, "case {case}: lattice {k} at {f} lost");
                assert!(near || !got, "case {case}: lattice {k} at {f} far away");
            }
        }
        assert_eq!(buckets.covering(0.3, f64::NAN), buckets.all);
    }

    #[test]
    fn hoisted_edge_functions_are_bit_identical_and_antisymmetric() {
        let mut unit = uniform(0x2545_F491_4F6C_DD1D);
        let mut next = || unit() * 200.0 - 100.0;
        for _ in 0..10_000 {
            let (p, q, s) = (
                DVec2::new(next(), next()),
                DVec2::new(next(), next()),
                DVec2::new(next(), next()),
            );
            let e = EdgeFn::new(p, q).at(s);
            assert_eq!(e.to_bits(), edge_function(p, q, s).to_bits());
            assert_eq!(e, -EdgeFn::new(q, p).at(s));
        }
    }

    fn lattice(n: usize, spacing: f64) -> RayLattice {
        RayLattice {
            origin: DVec2::ZERO,
            spacing,
            n_u: n,
            n_w: n,
        }
    }

    /// A unit square split along its diagonal, at height 1: every ray on the shared edge and
    /// at the shared corners must be counted exactly once.
    #[test]
    fn shared_edges_are_counted_once() {
        let v = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(4.0, 0.0, 1.0),
            DVec3::new(4.0, 4.0, 1.0),
            DVec3::new(0.0, 4.0, 1.0),
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(4.0, 0.0, 0.0),
            DVec3::new(4.0, 4.0, 0.0),
            DVec3::new(0.0, 4.0, 0.0),
        ];
        // Top (counter-clockwise) and bottom (clockwise seen from above) of a slab, split
        // along opposite diagonals so the shared edges differ.
        let tris = [[0, 1, 2], [0, 2, 3], [5, 4, 7], [5, 7, 6]];
        let hits = &cast(
            &v,
            &Frame::new(crate::frame::Direction::PLUS_Z),
            &tris,
            &lattice(9, 0.5),
            &[],
        )
        .nodes;
        let mut count = 0;
        for (k, h) in hits.iter().enumerate() {
            let (i, j) = (k % 9, k / 9);
            if (1..8).contains(&i) && (1..8).contains(&j) {
                // Interior rays, diagonals included: enter at 1, leave at 0, one hit each.
                assert_eq!((h.first, h.second), (1.0, 0.0), "ray ({i}, {j})");
                count += 1;
            }
        }
        assert_eq!(count, 49);
    }

    #[test]
    fn heights_interpolate_a_tilted_plane() {
        let v = [
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(10.0, -1.0, 11.0),
            DVec3::new(-1.0, 10.0, 22.0),
        ];
        let hits = &cast(
            &v,
            &Frame::new(crate::frame::Direction::PLUS_Z),
            &[[0, 1, 2]],
            &lattice(5, 1.0),
            &[],
        )
        .nodes;
        for (k, h) in hits.iter().enumerate() {
            let (x, y) = ((k % 5) as f64, (k / 5) as f64);
            let z = (x + 1.0) + 2.0 * (y + 1.0);
            assert!((h.first - z).abs() < 1e-12, "{x} {y}: {}", h.first);
            assert_eq!(h.thickness(), None);
        }
    }

    #[test]
    fn coincident_faces_give_the_lowest_triangle_in_any_order() {
        // Three hits at heights 2, 2 and 1 by triangles 7, 3 and 9, added and merged in
        // every order: always first 2 by triangle 3, second 2.
        let hits = [(2.0, 7), (2.0, 3), (1.0, 9)];
        for order in [[0, 1, 2], [1, 0, 2], [2, 1, 0], [2, 0, 1]] {
            let mut one = Hit::MISS;
            for &i in &order {
                Hit::add(&mut one, hits[i].0, hits[i].1);
            }
            let (mut a, mut b) = (Hit::MISS, Hit::MISS);
            Hit::add(&mut a, hits[order[0]].0, hits[order[0]].1);
            for &i in &order[1..] {
                Hit::add(&mut b, hits[i].0, hits[i].1);
            }
            Record::merge(&mut b, &a);
            for h in [one, b] {
                assert_eq!((h.first, h.second, h.triangle), (2.0, 2.0, 3), "{order:?}");
            }
        }
    }

    /// Every triangle of a mesh seen along one line, each projected once: the brute force
    /// that [`blocked_in_blocks`] must agree with.
    struct EveryTriangle(Vec<Option<(ProjectedTriangle, [EdgeFn; 3])>>);

    impl EveryTriangle {
        fn new(vertices: &[DVec3], frame: &Frame, triangles: &[[u32; 3]]) -> EveryTriangle {
            EveryTriangle(
                triangles
                    .iter()
                    .map(|tri| {
                        let [a, b, c] = tri.map(|v| uwh(frame, vertices[v as usize]));
                        ProjectedTriangle::new(a, b, c).map(|t| {
                            let edges = t.edges();
                            (t, edges)
                        })
                    })
                    .collect(),
            )
        }

        /// Whether `ray` meets a triangle other than its own farther than `min_hit` along
        /// it, by testing every triangle: the definition [`blocked_in_blocks`] answers with
        /// its grid of cells.
        fn block(&self, frame: &Frame, ray: PointRay, min_hit: f64) -> bool {
            self.first_blocking(frame, ray, min_hit).is_some()
        }

        /// The first triangle, in the mesh's order, that blocks `ray` (see [`Self::block`]).
        fn first_blocking(&self, frame: &Frame, ray: PointRay, min_hit: f64) -> Option<usize> {
            let s = frame.project(ray.origin);
            let height = frame.height(ray.origin);
            self.0.iter().enumerate().position(|(t, projected)| {
                let Some((triangle, edges)) = projected else {
                    return false;
                };
                let e = edges.each_ref().map(|edge| edge.at(s));
                let inside = (0..3).all(|m| e[m] > 0.0 || (e[m] == 0.0 && edges[m].owned));
                let [ha, hb, hc] = triangle.h;
                let h = (e[0] * ha + e[1] * hb + e[2] * hc) / (e[0] + e[1] + e[2]);
                let along = if ray.up { h - height } else { height - h };
                t as u32 != ray.triangle && inside && along > min_hit
            })
        }
    }

    #[test]
    fn blocked_rays_are_those_of_testing_every_triangle() {
        // The bracket (walls along every axis: along an axis their rays and triangles fall
        // in strips, so crowded cells) and the cap, along axes and tilted lines; rays from
        // every facet's centroid, from its corners (rays through shared vertices and edges,
        // where the top-left rule decides) and from random points of the box, some going
        // up and some down, handed over in blocks of uneven sizes (some empty), on 1 and 3
        // threads, and made again where they are placed.
        let mut next = uniform(0x2545_F491_4F6C_DD1D);
        for name in ["bracket", "cap"] {
            let mesh = crate::samples::sample(name).unwrap().subdivided();
            let bounds = mesh.bounds();
            let min_hit = 1e-6 * bounds.diagonal();
            let mut rays = Vec::new();
            for (t, tri) in mesh.triangles.iter().enumerate() {
                let [a, b, c] = mesh.corners(t);
                rays.push(PointRay {
                    origin: (a + b + c) / 3.0,
                    triangle: t as u32,
                    up: t % 3 != 0,
                });
                if t % 5 == 0 {
                    rays.push(PointRay {
                        origin: mesh.vertices[tri[t % 3] as usize],
                        triangle: t as u32,
                        up: t % 2 == 0,
                    });
                }
            }
            // Crowds of rays on the corners and edges of some triangles (parts of cells
            // read by bisection, with rays exactly on the triangles' box edges).
            for t in (0..mesh.triangles.len()).step_by(mesh.triangles.len() / 12) {
                let [a, b, c] = mesh.corners(t);
                for k in 0..48 {
                    let (p, q) = [(a, b), (b, c), (c, a)][k % 3];
                    let along = if k < 6 { 0.0 } else { next() };
                    rays.push(PointRay {
                        origin: p + (q - p) * along,
                        triangle: t as u32,
                        up: k % 4 != 0,
                    });
                }
            }
            for k in 0..500 {
                let p = bounds.min + (bounds.max - bounds.min) * DVec3::new(next(), next(), next());
                rays.push(PointRay {
                    origin: p,
                    triangle: u32::MAX >> 1,
                    up: k % 2 == 0,
                });
            }
            for d in [
                DVec3::Z,
                DVec3::X,
                DVec3::new(0.3, -0.2, 0.9),
                DVec3::new(1.0, 1e-3, -2e-3),
            ] {
                let frame = Frame::new(crate::frame::Direction::new(d).unwrap());
                let every = EveryTriangle::new(&mesh.vertices, &frame, &mesh.triangles);
                let expected: Vec<BlockedRay> = rays
                    .par_iter()
                    .enumerate()
                    .filter(|(_, &r)| every.block(&frame, r, min_hit))
                    .map(|(k, r)| BlockedRay {
                        ray: k as u32,
                        triangle: r.triangle,
                    })
                    .collect();
                assert!(expected.len() > 50, "{name} {d}: {}", expected.len());
                assert!(rays.len() - expected.len() > 50, "{name} {d}");
                // Blocks of 0 to 96 rays, the same at every call.
                let mut ends = vec![0];
                while ends[ends.len() - 1] < rays.len() {
                    let size = (ends.len() * 37) % 97;
                    ends.push((ends[ends.len() - 1] + size).min(rays.len()));
                }
                for threads in [1, 3] {
                    let found = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap()
                        .install(|| {
                            blocked_in_blocks(
                                &mesh.vertices,
                                &frame,
                                &mesh.triangles,
                                ends.len() - 1,
                                |b, sink| {
                                    rays[ends[b]..ends[b + 1]]
                                        .iter()
                                        .for_each(|&r| sink.push(r))
                                },
                                min_hit,
                            )
                        });
                    assert_eq!(found, expected, "{name} {d} {threads} threads");
                }
                // The rays made again where they are placed (as on a large mesh), placed all
                // at once, or in bands of rows of about 1, 7 or 200 rays, or in two bands (a
                // drawing of fewer rays than a band holds but more than a quarter of it): the
                // same rays blocked.
                for band_rays in [usize::MAX, 1, 7, 200, 2 * rays.len()] {
                    let remade = blocked_until_remade_above(
                        &mesh.vertices,
                        &frame,
                        (&mesh.triangles, 1),
                        (ends.len() - 1, 0, band_rays),
                        |b, sink| {
                            rays[ends[b]..ends[b + 1]]
                                .iter()
                                .for_each(|&r| sink.push(r))
                        },
                        min_hit,
                        |_| false,
                        &TestBudget::unlimited(),
                    );
                    assert_eq!(remade, expected, "{name} {d}: rays made again, {band_rays}");
                }
                let flags = blocked(&mesh.vertices, &frame, &mesh.triangles, &rays, min_hit);
                let from_flags: Vec<u32> = (0..rays.len() as u32)
                    .filter(|&k| flags[k as usize])
                    .collect();
                let from_found: Vec<u32> = expected.iter().map(|b| b.ray).collect();
                assert_eq!(from_flags, from_found, "{name} {d}");
            }
        }
    }

    #[test]
    fn triangles_drawn_in_small_tasks_block_the_rays_of_the_brute_force() {
        // The cap subdivided twice: few enough triangles that a run is cut in tasks of
        // fewer than `POINT_BLOCK`, on 1 and 3 threads, along a tilted line. Each ray starts
        // a little behind its triangle's centroid, so that its own triangle is in its way:
        // a triangle drawn under another's number would block it.
        let mesh = crate::samples::sample("cap")
            .unwrap()
            .subdivided()
            .subdivided();
        let n = mesh.triangles.len();
        assert!(
            n >= 2 * POINT_BLOCK_LEAST && n.div_ceil(POINT_TASKS) < POINT_BLOCK,
            "{n}"
        );
        let line = DVec3::new(0.2, 0.1, 1.0).normalize();
        let frame = Frame::new(crate::frame::Direction::new(line).unwrap());
        let min_hit = 1e-6 * mesh.bounds().diagonal();
        let behind = 1e-3 * mesh.bounds().diagonal();
        let rays: Vec<PointRay> = (0..n)
            .map(|t| {
                let [a, b, c] = mesh.corners(t);
                let way = if t % 2 == 0 { 1.0 } else { -1.0 };
                PointRay {
                    origin: (a + b + c) / 3.0 - line * (way * behind),
                    triangle: t as u32,
                    up: t % 2 == 0,
                }
            })
            .collect();
        let every = EveryTriangle::new(&mesh.vertices, &frame, &mesh.triangles);
        let expected: Vec<bool> = rays
            .par_iter()
            .map(|&r| every.block(&frame, r, min_hit))
            .collect();
        assert!(expected.iter().filter(|&&b| b).count() > 100);
        for threads in [1, 3] {
            let found = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| blocked(&mesh.vertices, &frame, &mesh.triangles, &rays, min_hit));
            assert_eq!(found, expected, "{threads} threads");
        }
    }

    #[test]
    fn drawing_stopped_after_a_run_gives_the_rays_of_the_triangles_drawn() {
        // The cap's facet centroids along a tilted line, drawn in 5 runs of triangles and
        // stopped once more than a given count of rays is blocked: the answer is the
        // brute force's over the triangles of the runs drawn, on 1 and 3 threads, and the
        // runs before did not reach the count.
        let mesh = crate::samples::sample("cap").unwrap().subdivided();
        let frame = Frame::new(crate::frame::Direction::new(DVec3::new(0.2, 0.1, 1.0)).unwrap());
        let min_hit = 1e-6 * mesh.bounds().diagonal();
        let rays: Vec<PointRay> = (0..mesh.triangles.len())
            .map(|t| {
                let [a, b, c] = mesh.corners(t);
                PointRay {
                    origin: (a + b + c) / 3.0,
                    triangle: t as u32,
                    up: t % 2 == 0,
                }
            })
            .collect();
        // The first triangle that blocks each ray, if any.
        let brute = EveryTriangle::new(&mesh.vertices, &frame, &mesh.triangles);
        let first: Vec<Option<usize>> = rays
            .par_iter()
            .map(|&r| brute.first_blocking(&frame, r, min_hit))
            .collect();
        let blocked_by = |count: usize| -> Vec<u32> {
            (0..rays.len() as u32)
                .filter(|&k| first[k as usize].is_some_and(|t| t < count))
                .collect()
        };
        let n = mesh.triangles.len();
        let every = blocked_by(n);
        assert!(every.len() > 100, "{}", every.len());
        let size = n.div_ceil(5);
        for wanted in [0, every.len() / 3, every.len() / 2, every.len()] {
            // The first run after which more than `wanted` are blocked (or the last).
            let runs = (1..=5)
                .find(|&r| blocked_by((r * size).min(n)).len() > wanted)
                .unwrap_or(5);
            let expected = blocked_by((runs * size).min(n));
            for threads in [1, 3] {
                let found = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| {
                        blocked_until(
                            &mesh.vertices,
                            &frame,
                            (&mesh.triangles, 5),
                            rays.len().div_ceil(100),
                            |b, sink| {
                                rays[b * 100..((b + 1) * 100).min(rays.len())]
                                    .iter()
                                    .for_each(|&r| sink.push(r))
                            },
                            min_hit,
                            |so_far| so_far.len() > wanted,
                            &TestBudget::unlimited(),
                        )
                    });
                let found: Vec<u32> = found.iter().map(|b| b.ray).collect();
                assert_eq!(found, expected, "more than {wanted}, {threads} threads");
            }
        }
    }

    #[test]
    fn f32_bounds_are_the_nearest_on_the_safe_side() {
        let mut next = uniform(0x1234_5678_9ABC_DEF1);
        let mut values = vec![0.0, -0.0, 1e-50, -1e-50, 1e300, -1e300, f64::INFINITY];
        values.push(f64::NEG_INFINITY);
        values.extend([
            f64::from(f32::MAX),
            f64::from(f32::MIN_POSITIVE),
            0.1,
            -0.1,
            3.0,
        ]);
        values.extend((0..2000).map(|k| (next() - 0.5) * 10f64.powi(k % 40 - 20)));
        for x in values {
            let (down, up) = (f32_at_most(x), f32_at_least(x));
            assert!(f64::from(down) <= x && f64::from(up) >= x, "{x}");
            // Nothing representable lies strictly between.
            if x.is_finite() && down != up {
                assert_eq!(f64::from(down) < x, f64::from(up) > x, "{x}");
                let gap = if down >= 0.0 {
                    f32::from_bits(down.to_bits() + 1)
                } else if down == -f32::from_bits(1) {
                    0.0
                } else {
                    f32::from_bits(down.to_bits() - 1)
                };
                assert_eq!(gap, up, "{x}: {down} {up}");
            }
        }
    }

    #[test]
    fn hits_do_not_depend_on_the_number_of_threads() {
        // The cap, subdivided to many blocks of triangles, along a tilted direction, with
        // circle lattices at uneven offsets; drawn by pools of 1, 2, 3 and 8 threads (1 to 4
        // sets of hits, 1 or 2 groups of circle lattices).
        let mesh = crate::samples::sample("cap")
            .unwrap()
            .subdivided()
            .subdivided()
            .subdivided();
        assert!(mesh.triangles.len() > 4 * BLOCK);
        let frame = Frame::new(crate::frame::Direction::new(DVec3::new(0.1, -0.2, 1.0)).unwrap());
        let node = RayLattice {
            origin: DVec2::new(-40.0, -40.0),
            spacing: 0.7,
            n_u: 115,
            n_w: 115,
        };
        let circles: Vec<RayLattice> = (0..16)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 16.0;
                RayLattice {
                    origin: node.origin + DVec2::new(a.cos(), a.sin()) * 1.43,
                    ..node
                }
            })
            .collect();
        let cast_with = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| cast(&mesh.vertices, &frame, &mesh.triangles, &node, &circles))
        };
        let one = cast_with(1);
        assert!(one.nodes.iter().filter(|h| h.is_hit()).count() > 1000);
        for threads in [2, 3, 8] {
            let many = cast_with(threads);
            assert_eq!(one.nodes, many.nodes, "{threads} threads");
            assert_eq!(one.circles, many.circles, "{threads} threads");
        }
    }

    #[test]
    fn index_range_holds_every_sample_in_the_interval() {
        assert_eq!(index_range(0.0, 4.0, 100, 0.75, 0.75), Some((3, 3)));
        // 3 * 0.1 rounds above 0.3; within the slack, sample 3 is kept for the exact test.
        assert_eq!(index_range(0.0, 10.0, 100, 0.3, 0.3), Some((3, 3)));
        assert_eq!(
            index_range(0.0, 10.0, 100, 3.0 * 0.1, 3.0 * 0.1),
            Some((3, 3))
        );
        assert_eq!(index_range(0.0, 10.0, 100, 0.31, 0.39), None);
        assert_eq!(index_range(0.0, 1.0, 10, -5.0, 50.0), Some((0, 9)));
        assert_eq!(index_range(0.0, 1.0, 10, 10.5, 50.0), None);
        assert_eq!(index_range(0.0, 1.0, 10, -5.0, -0.5), None);
        // Every sample of a random interval is in its range.
        for k in 0..1000 {
            let (lo, hi) = (k as f64 * 0.0137 - 1.0, k as f64 * 0.0137 - 1.0 + 0.05);
            let (origin, spacing) = (-0.31, 0.0123);
            let inside: Vec<usize> = (0..200)
                .filter(|&i| {
                    let x = origin + i as f64 * spacing;
                    lo <= x && x <= hi
                })
                .collect();
            if let (Some(&first), Some(&last)) = (inside.first(), inside.last()) {
                let (a, b) = index_range(origin, 1.0 / spacing, 200, lo, hi).unwrap();
                assert!(a <= first && last <= b && b - a <= last - first + 2, "{k}");
            }
        }
    }
}
