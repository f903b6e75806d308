//! Rays in any direction through a mesh: a bounding volume hierarchy (BVH) over its triangles.
//!
//! The projection of [`crate::gate`] casts only rays parallel to D and draws triangles into
//! them instead; the rays here go anywhere (along a facet's inverted normal for the wall
//! thickness, along ±D from every facet for undercuts), so they need a tree of boxes.
//!
//! The tree is built once per mesh with a binned surface-area heuristic (12 bins per axis,
//! leaves of at most 4 triangles; the top levels are built on both threads; the three axes
//! are binned in one pass over a node's triangles, a child's box comes from the union of its
//! parent's bins and the box of its triangles' centres from the partition, so each level
//! reads its triangles twice: bins, then partition). Boxes and triangles are stored in `f32`,
//! relative to the centre of the mesh's box, to halve the memory read per ray; queries take
//! and return `f64`. The tree knows only boxes and triangle numbers: what a hit means (wall,
//! undercut) is the caller's business. The finished tree keeps the two children of a node
//! side by side in one 64-byte cache line, so a step of the descent, which tests both boxes,
//! reads one line; each triangle carries its mesh index.
//!
//! A query that stays in a known ball (the short rays and nearest-point queries of the wall
//! thickness's cross-width check) can start from the few subtrees that hold every triangle
//! meeting that ball ([`Region`]) instead of descending from the root each time.
//!
//! **Robustness rules.** A triangle is hit when the ray crosses it with barycentric
//! coordinates within [`EDGE_TOLERANCE`] of its closed outline, so a ray through an edge
//! shared by two triangles never slips between them (it may hit both, at the same distance,
//! which is harmless for a first hit). Triangles seen edge-on (the ray parallel to their
//! plane) and triangles without area are never hit. A ray may skip one triangle (the one it
//! starts on) and ignores hits nearer than its `min_distance`.

use std::cmp::Ordering;
use std::ops::ControlFlow;

use glam::{BVec3A, BVec4A, Vec3, Vec3A, Vec4};
use rayon::join;
use rayon::prelude::*;

use crate::math::DVec3;
use crate::mesh::Mesh;

/// Slack on barycentric coordinates when testing a hit: a ray through a shared edge hits at
/// least one of the two triangles despite `f32` rounding.
pub const EDGE_TOLERANCE: f32 = 1e-5;

/// Direction components smaller than this are raised to it before they are inverted. The
/// inverse stays finite, so the slab test has no 0 x infinity; a ray parallel to a box face
/// then sees the face at a distance of at least 1e30 times its offset from the plane: a box
/// is entered by mistake only when the offset is below about 1e-26 mm (a wasted visit, the
/// triangle test is exact), and never missed (inside the slab the bounds keep their signs).
const TINY_COMPONENT: f32 = 1e-30;

/// Most triangles in a leaf.
const LEAF_SIZE: usize = 4;
/// Most triangles in a leaf of the Morton tree ([`Bvh::new_morton`]): three packets. Its
/// splits follow the curve, not a cost, so small leaves only add nodes; on the 352k
/// housing, leaves of 12 against 4 build the tree in 0.85 of the time and answer the fill's
/// wall samples in 0.9 (one thread, the same walls).
const MORTON_LEAF_SIZE: usize = 12;
const _: () = assert!(MORTON_LEAF_SIZE <= 4 * LEAF_PACKETS);
/// Bins per axis of the surface-area heuristic.
const BINS: usize = 12;
/// Subtrees with more triangles than this are built on another thread (the top levels only).
const PARALLEL_MIN: usize = 16_384;
/// Binary nodes in a subtree above which the four-wide collapse goes on in two threads
/// (the largest subtrees only: each split copies one side's nodes once).
const COLLAPSE_PARALLEL_MIN: usize = 32_768;

/// A ray: where it starts, where it goes, the part of it that counts, and a triangle to skip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Start point, mm.
    pub origin: DVec3,
    /// Unit direction.
    pub direction: DVec3,
    /// Hits nearer than this are ignored, mm (default 0).
    pub min_distance: f64,
    /// Hits farther than this are ignored, mm (default infinity).
    pub max_distance: f64,
    /// A triangle never hit, usually the one the ray starts on (default none).
    pub skip: Option<u32>,
}

impl Ray {
    /// The ray from `origin` along the unit vector `direction`, with no limits.
    pub fn new(origin: DVec3, direction: DVec3) -> Ray {
        Ray {
            origin,
            direction,
            min_distance: 0.0,
            max_distance: f64::INFINITY,
            skip: None,
        }
    }

    /// This ray, ignoring hits outside `min_distance..=max_distance`.
    pub fn within(self, min_distance: f64, max_distance: f64) -> Ray {
        Ray {
            min_distance,
            max_distance,
            ..self
        }
    }

    /// This ray, never hitting `triangle`.
    pub fn skipping(self, triangle: u32) -> Ray {
        Ray {
            skip: Some(triangle),
            ..self
        }
    }
}

/// The first triangle a ray hits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Index of the triangle in the mesh.
    pub triangle: u32,
    /// Distance from the ray's origin along its direction, mm.
    pub distance: f64,
}

/// One node of the tree: a box and either two children or a run of triangles.
#[derive(Debug, Clone, Copy)]
struct Node {
    min: [f32; 3],
    /// Interior: while building, index of the second child (the first follows the node);
    /// in the finished tree, the pair of its children (see [`Pair`]). Leaf: first triangle
    /// in leaf order.
    link: u32,
    max: [f32; 3],
    /// Triangles in the leaf; 0 for an interior node.
    count: u32,
}

/// Four children of the finished tree, their boxes lane by lane (lane k is child k), so that
/// one four-lane test takes all four boxes: a descent reads one node of two cache lines per
/// step and passes about two levels of the binary tree it was made from. A lane without a
/// child holds the point at infinity, which no test enters.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Node4 {
    /// Smallest x, y and z of each child's box.
    lo: [Vec4; 3],
    /// Largest x, y and z of each child's box.
    hi: [Vec4; 3],
    /// Each child: a [`Node4`]'s index, or a leaf (see [`leaf_ref`]), or [`NO_CHILD`].
    child: [u32; 4],
}

/// Up to four triangles of a leaf, lane by lane: a corner and the two edges from it, relative
/// to the tree's origin, so that one four-lane test takes all four. Lanes past the leaf's
/// triangles have no area (never hit) and the id [`NO_TRIANGLE`].
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Tri4 {
    a: [Vec4; 3],
    ab: [Vec4; 3],
    ac: [Vec4; 3],
    /// Smallest |determinant| of a hit, relative to the edges' lengths (see [`intersect4`]):
    /// kept here so that the test needs no square root.
    min_det: Vec4,
    /// Index of each triangle in the mesh.
    id: [u32; 4],
    /// Whether every lane's corner and edges are finite (see [`closest_distance2`]).
    finite: bool,
}

/// A child that is a leaf: this bit, the first of its [`Tri4`] packets shifted by
/// [`PACKET_SHIFT`], and the number of packets less one in the bits below.
const LEAF: u32 = 1 << 31;
const PACKET_SHIFT: u32 = 2;
/// Most packets of one leaf (leaves hold at most `4 * LEAF_PACKETS` triangles).
const LEAF_PACKETS: usize = 1 << PACKET_SHIFT;
/// A lane of a [`Node4`] without a child.
const NO_CHILD: u32 = u32::MAX;
/// A lane of a [`Tri4`] without a triangle.
const NO_TRIANGLE: u32 = u32::MAX;

/// The reference to a leaf whose triangles are the packets `first..first + packets`.
fn leaf_ref(first: usize, packets: usize) -> u32 {
    debug_assert!((1..=LEAF_PACKETS).contains(&packets));
    LEAF | (first as u32) << PACKET_SHIFT | (packets as u32 - 1)
}

/// The packets of a leaf reference.
#[inline]
fn leaf_packets(r: u32) -> std::ops::Range<usize> {
    let first = ((r & !LEAF) >> PACKET_SHIFT) as usize;
    first..first + (r & (LEAF_PACKETS as u32 - 1)) as usize + 1
}

/// A bounding volume hierarchy over the triangles of a mesh.
#[derive(Debug, Clone)]
pub struct Bvh {
    origin: DVec3,
    /// The four-wide nodes, the root's subtree in depth-first order.
    nodes: Vec<Node4>,
    /// The root: a node or a leaf reference.
    root: u32,
    /// The triangles in leaf order, four by four.
    packets: Vec<Tri4>,
    /// Mesh index of each triangle in leaf order.
    ids: Vec<u32>,
}

/// Per-triangle box and centroid during the build.
#[derive(Clone, Copy)]
struct Item {
    min: Vec3,
    max: Vec3,
    centre: Vec3,
    id: u32,
}

/// A box during the build, in four-lane vectors: the binning grows thousands of them per
/// level, and a four-lane min / max is one instruction where `f32::min` (with its NaN rule)
/// is several per lane. No NaN ever reaches one (see [`Bvh::new`]).
#[derive(Clone, Copy)]
struct Bounds {
    min: Vec3A,
    max: Vec3A,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };
    #[inline]
    fn grow(&mut self, min: Vec3A, max: Vec3A) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }
    fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3A::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// The binary tree over every triangle of `mesh`: the origin of its `f32` coordinates, its
/// nodes (each interior node followed by its first child, `link` naming its second; boxes
/// padded) and the mesh index of each triangle in leaf order.
fn binary_tree(mesh: &Mesh, how: Build) -> (DVec3, Vec<Node>, Vec<u32>) {
    let origin = mesh.bounds().centre();
    let origin = if origin.is_finite() {
        origin
    } else {
        DVec3::ZERO
    };
    let local = |v: DVec3| (v - origin).as_vec3();
    let (mut nodes, ids) = if mesh.triangles.is_empty() {
        let empty = Node {
            min: [f32::INFINITY; 3],
            link: 0,
            max: [f32::NEG_INFINITY; 3],
            count: 0,
        };
        (vec![empty], Vec::new())
    } else {
        match how {
            Build::SurfaceArea => {
                let mut items: Vec<Item> = (0..mesh.triangles.len())
                    .into_par_iter()
                    .map(|t| {
                        let (min, max) = triangle_box(mesh.corners(t).map(local));
                        Item {
                            min,
                            max,
                            // The centre of an empty box is the origin.
                            centre: box_centre((min, max)).unwrap_or(Vec3::ZERO),
                            id: t as u32,
                        }
                    })
                    .collect();
                let nodes = build(&mut items, 0, None);
                (nodes, items.iter().map(|i| i.id).collect())
            }
            Build::Morton => {
                let boxes: Vec<(Vec3, Vec3)> = (0..mesh.triangles.len())
                    .into_par_iter()
                    .map(|t| triangle_box(mesh.corners(t).map(local)))
                    .collect();
                build_morton(&boxes)
            }
        }
    };
    // Pad every box: a ray through the face of a flat box (a triangle in an axis plane)
    // must not be lost to the rounding of the slab test, and the edge slack of the
    // triangle test reaches slightly beyond a triangle's own box.
    let reach = nodes[0].min.iter().chain(&nodes[0].max).fold(0f32, |m, v| {
        if v.is_finite() {
            m.max(v.abs())
        } else {
            m
        }
    });
    let pad = 2.0 * EDGE_TOLERANCE * reach;
    for n in &mut nodes {
        for k in 0..3 {
            n.min[k] -= pad;
            n.max[k] += pad;
        }
    }
    (origin, nodes, ids)
}

/// The `f32` box of a triangle's corners (relative to the tree's origin); a corner that is
/// not finite gives the empty box (infinity to minus infinity): such a triangle can never
/// be hit (its test gives NaN), and an empty box keeps NaN and infinity out of the boxes'
/// unions.
fn triangle_box([a, b, c]: [Vec3; 3]) -> (Vec3, Vec3) {
    let min = a.min(b).min(c);
    let max = a.max(b).max(c);
    if min.is_finite() && max.is_finite() {
        (min, max)
    } else {
        (Vec3::INFINITY, Vec3::NEG_INFINITY)
    }
}

/// The centre of a triangle's box; `None` for the empty box of [`triangle_box`].
fn box_centre((min, max): (Vec3, Vec3)) -> Option<Vec3> {
    (min.x <= max.x).then(|| (min + max) * 0.5)
}

/// How the binary tree is split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Build {
    /// The binned surface-area heuristic (the fastest queries).
    SurfaceArea,
    /// The triangles sorted along a Morton curve of their centres and split where the
    /// codes' highest differing bit changes (see [`build_morton`]).
    Morton,
}

impl Bvh {
    /// Builds the tree over every triangle of `mesh`.
    pub fn new(mesh: &Mesh) -> Bvh {
        Self::built(mesh, Build::SurfaceArea)
    }

    /// A tree over every triangle of `mesh` built by sorting the triangles along a Morton
    /// curve of their centres (a linear bounding volume hierarchy): about a fifth of the
    /// instructions of [`Bvh::new`], for queries that cost about a fifth more (its boxes
    /// overlap more). For a tree that serves few queries. Every query gives the hits of
    /// [`Bvh::new`]'s tree (the box tests only cull, and the triangle tests are the same
    /// arithmetic on the same coordinates), but for which of two triangles at one `f32`
    /// distance a ray names; a nearest-point query names the same triangle as well
    /// ([`Bvh::nearest_within`]).
    pub fn new_morton(mesh: &Mesh) -> Bvh {
        Self::built(mesh, Build::Morton)
    }

    fn built(mesh: &Mesh, how: Build) -> Bvh {
        let (origin, nodes, ids) = binary_tree(mesh, how);
        let Collapse {
            nodes: mut wide_nodes,
            leaves,
            packets: n_packets,
            root,
            ..
        } = Collapse::of(&nodes, COLLAPSE_PARALLEL_MIN);
        // Room was made for a third of the binary nodes; less than half of it is used.
        wide_nodes.shrink_to_fit();
        // The binary tree is let go before the packets are made: on large meshes its nodes
        // (32 bytes each, about 0.64 a triangle) would otherwise be held at the build's peak,
        // beside the packets (about 60 bytes a triangle).
        drop(nodes);
        // Each leaf's triangles, four by four, in leaf order (the order of `ids`): the first
        // triangle and the count of each packet, then the packets in parallel.
        let mut fours: Vec<(u32, u32)> = Vec::with_capacity(n_packets);
        for &(first, count) in &leaves {
            fours.extend(
                (first..first + count)
                    .step_by(4)
                    .map(|f| (f, (first + count - f).min(4))),
            );
        }
        drop(leaves);
        let packets = fours
            .par_iter()
            .with_min_len(1024)
            .map(|&(first, count)| {
                packet(mesh, origin, &ids[first as usize..(first + count) as usize])
            })
            .collect();
        Bvh {
            origin,
            nodes: wide_nodes,
            root,
            packets,
            ids,
        }
    }

    /// Number of triangles in the tree.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// The triangles in the order of the tree's leaves: neighbours in this order lie near
    /// each other, so rays cast in it find the same boxes in the cache.
    pub fn leaf_order(&self) -> &[u32] {
        &self.ids
    }

    /// Whether the tree holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The subtrees that hold every triangle meeting the ball of `radius` around `centre`:
    /// queries that stay inside that ball can start from them instead of the root (see
    /// [`Region`]). The descent stops at a node whose box is at most four radii across, so
    /// the subtrees are few; when they would be more than [`Region`] holds, the region is
    /// the whole tree.
    pub fn region(&self, centre: DVec3, radius: f64) -> Region {
        if self.ids.is_empty()
            || self.root & LEAF != 0
            || !centre.is_finite()
            || !radius.is_finite()
        {
            return Region::WHOLE;
        }
        let c = Point4::splat((centre - self.origin).as_vec3());
        let r = radius as f32;
        let (r2, size) = (Vec4::splat(r * r), Vec4::splat(4.0 * r));
        // The subtrees found, as (node, lane) of the node that holds their box.
        let mut found = [(0u32, 0u8); 4 * REGION_GROUPS];
        let mut len = 0;
        let mut stack = Stack::new();
        stack.push((self.root, 0.0));
        while let Some((r, _)) = stack.pop() {
            let node = &self.nodes[r as usize];
            let meets = box_distance2(node, &c).cmple(r2).bitmask();
            let extent = (node.hi[0] - node.lo[0])
                .max(node.hi[1] - node.lo[1])
                .max(node.hi[2] - node.lo[2]);
            let small = extent.cmple(size).bitmask();
            for k in lanes(meets) {
                if node.child[k] & LEAF != 0 || small & (1 << k) != 0 {
                    if len == found.len() {
                        return Region::WHOLE;
                    }
                    found[len] = (r, k as u8);
                    len += 1;
                } else {
                    stack.push((node.child[k], 0.0));
                }
            }
        }
        let mut groups = Region::WHOLE.groups;
        for (group, four) in groups.iter_mut().zip(found[..len].chunks(4)) {
            let (mut lo, mut hi) = ([[f32::INFINITY; 4]; 3], [[f32::INFINITY; 4]; 3]);
            for (lane, &(n, k)) in four.iter().enumerate() {
                let (node, k) = (&self.nodes[n as usize], k as usize);
                for axis in 0..3 {
                    lo[axis][lane] = node.lo[axis][k];
                    hi[axis][lane] = node.hi[axis][k];
                }
                group.child[lane] = node.child[k];
            }
            group.lo = lo.map(Vec4::from_array);
            group.hi = hi.map(Vec4::from_array);
        }
        Region { groups, len }
    }

    /// The tree's surface-area cost: the boxes a ray through the root's box meets, on
    /// average over rays in every direction, each weighted by its work (a node 1, a leaf its
    /// triangles): each box counts its surface area over the root's. A mesh whose surface a
    /// ray crosses a few times has a cost of tens; a soup of long random triangles, whose
    /// boxes overlap across the whole part, a cost growing with its triangles.
    pub fn area_cost(&self) -> f64 {
        let area = |lo: [f32; 3], hi: [f32; 3]| {
            let d = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]].map(|v| f64::from(v.max(0.0)));
            2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
        };
        let lane = |n: &Node4, k: usize| {
            (
                [
                    n.lo[0].to_array()[k],
                    n.lo[1].to_array()[k],
                    n.lo[2].to_array()[k],
                ],
                [
                    n.hi[0].to_array()[k],
                    n.hi[1].to_array()[k],
                    n.hi[2].to_array()[k],
                ],
            )
        };
        if self.root & LEAF != 0 {
            return self.ids.len() as f64;
        }
        let root = &self.nodes[self.root as usize];
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for k in 0..4 {
            if root.child[k] == NO_CHILD {
                continue;
            }
            let (l, h) = lane(root, k);
            for i in 0..3 {
                lo[i] = lo[i].min(l[i]);
                hi[i] = hi[i].max(h[i]);
            }
        }
        let whole = area(lo, hi).max(f64::MIN_POSITIVE);
        let mut cost = 1.0;
        for n in &self.nodes {
            for k in 0..4 {
                let c = n.child[k];
                if c == NO_CHILD {
                    continue;
                }
                let (l, h) = lane(n, k);
                let work = if c & LEAF != 0 {
                    (4 * leaf_packets(c).len()) as f64
                } else {
                    1.0
                };
                cost += work * area(l, h) / whole;
            }
        }
        cost
    }

    /// The nearest hit of `ray`, or `None` when it hits nothing within its limits.
    pub fn first_hit(&self, ray: &Ray) -> Option<Hit> {
        self.first_hit_in(ray, &Region::WHOLE)
    }

    /// [`Bvh::first_hit`] among the triangles of `region` only: the same hit when every
    /// point of `ray` within its limits lies in the ball the region was made for (but for
    /// which of two triangles at one distance is named).
    pub fn first_hit_in(&self, ray: &Ray, region: &Region) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        self.traverse(ray, region, |hit| {
            best = Some(hit);
            // Shorten the ray: only nearer hits matter from now on.
            Some(hit.distance)
        });
        best
    }

    /// Whether `ray` hits anything within its limits (stops at the first hit found).
    pub fn any_hit(&self, ray: &Ray) -> bool {
        let mut found = false;
        self.traverse(ray, &Region::WHOLE, |_| {
            found = true;
            None
        });
        found
    }

    /// Calls `f` with every hit of `ray` within its limits, in no particular order, until `f`
    /// returns `false`.
    pub fn for_each_hit(&self, ray: &Ray, mut f: impl FnMut(Hit) -> bool) {
        let limit = ray.max_distance;
        self.traverse(ray, &Region::WHOLE, |hit| f(hit).then_some(limit));
    }

    /// Walks the subtrees of `region` nearest box first. `on_hit` gets every hit nearer than
    /// the current limit and returns the new limit, or `None` to stop.
    fn traverse(&self, ray: &Ray, region: &Region, mut on_hit: impl FnMut(Hit) -> Option<f64>) {
        if self.ids.is_empty()
            || !(ray.origin.is_finite() && ray.direction.is_finite())
            || ray.min_distance > ray.max_distance
        {
            return;
        }
        let o = (ray.origin - self.origin).as_vec3();
        let d = ray.direction.as_vec3();
        // Components too small to invert are raised to TINY_COMPONENT, so that the inverse is
        // finite and the slab test never meets 0 x infinity (see `slab`).
        let tiny = d.abs().cmplt(Vec3::splat(TINY_COMPONENT));
        let inv = Vec3::ONE / Vec3::select(tiny, Vec3::splat(TINY_COMPONENT), d);
        let (o4, d4, inv4) = (Point4::splat(o), Point4::splat(d), Point4::splat(inv));
        let t_min = ray.min_distance as f32;
        let mut t_max = ray.max_distance.min(f32::MAX as f64) as f32;
        // Subtrees still to search, with the distance at which the ray enters their box.
        let mut stack = Stack::new();
        // The region's subtrees that the ray enters wait on the stack, nearest on top.
        if region.len == 0 {
            stack.push((self.root, 0.0));
        }
        for group in region.groups().iter().rev() {
            let (hits, near) = slab(group, &o4, &inv4, t_min, t_max);
            if let Some(first) = descend(hits, near, &group.child, &mut stack) {
                stack.push((first, 0.0));
            }
        }
        'pop: while let Some((mut r, entry)) = stack.pop() {
            // Skip a box the shortened ray no longer reaches.
            if entry > t_max {
                continue;
            }
            loop {
                if r & LEAF != 0 {
                    if r == NO_CHILD {
                        continue 'pop;
                    }
                    for packet in &self.packets[leaf_packets(r)] {
                        let (hits, t) = intersect(packet, &o4, &d4);
                        // In lane order, as the triangles of the leaf come.
                        for k in lanes(hits) {
                            let id = packet.id[k];
                            if ray.skip == Some(id) || !(t[k] >= t_min && t[k] <= t_max) {
                                continue;
                            }
                            match on_hit(Hit {
                                triangle: id,
                                distance: t[k] as f64,
                            }) {
                                Some(limit) => t_max = limit as f32,
                                None => return,
                            }
                        }
                    }
                    continue 'pop;
                }
                let node = &self.nodes[r as usize];
                let (hits, near) = slab(node, &o4, &inv4, t_min, t_max);
                match descend(hits, near, &node.child, &mut stack) {
                    Some(next) => r = next,
                    None => continue 'pop,
                }
            }
        }
    }

    /// The triangle nearest to `p` among those nearer than `radius`, with its distance; `None`
    /// when no triangle comes within `radius`. Of triangles at the same distance (a corner or
    /// an edge they share is nearest) the one of least index is named, whatever the tree's
    /// shape: trees built differently over one mesh name the same triangle.
    pub fn nearest_within(&self, p: DVec3, radius: f64) -> Option<Hit> {
        self.nearest_within_in(p, radius, &Region::WHOLE)
    }

    /// [`Bvh::nearest_within`] among the triangles of `region` only: the same distance when
    /// the ball of `radius` around `p` lies in the ball the region was made for.
    pub fn nearest_within_in(&self, p: DVec3, radius: f64, region: &Region) -> Option<Hit> {
        if self.ids.is_empty() || !p.is_finite() || radius.is_nan() || radius <= 0.0 {
            return None;
        }
        let q = (p - self.origin).as_vec3();
        let q4 = Point4::splat(q);
        let r = radius.min(f32::MAX as f64) as f32;
        let mut near = Nearest::new(q, r);
        // Subtrees still to search, with the squared distance to their box.
        let mut stack = Stack::new();
        if region.len == 0 {
            stack.push((self.root, 0.0));
        }
        for group in region.groups().iter().rev() {
            let d2 = box_distance2(group, &q4);
            let inside = d2.cmplt(Vec4::splat(near.cut2)).bitmask();
            if let Some(first) = descend(inside, d2, &group.child, &mut stack) {
                stack.push((first, 0.0));
            }
        }
        'pop: while let Some((mut r, d2)) = stack.pop() {
            if d2 >= near.cut2 {
                continue;
            }
            loop {
                if r & LEAF != 0 {
                    if r == NO_CHILD {
                        continue 'pop;
                    }
                    for packet in &self.packets[leaf_packets(r)] {
                        nearest_in_packet(packet, q, &q4, &mut near);
                    }
                    continue 'pop;
                }
                let node = &self.nodes[r as usize];
                let d2 = box_distance2(node, &q4);
                let inside = d2.cmplt(Vec4::splat(near.cut2)).bitmask();
                match descend(inside, d2, &node.child, &mut stack) {
                    Some(next) => r = next,
                    None => continue 'pop,
                }
            }
        }
        let best2 = near.best2;
        near.best.map(|triangle| Hit {
            triangle,
            distance: (best2 as f64).sqrt(),
        })
    }
}

/// The best triangle of a nearest-point search so far: the least squared distance, and of
/// equal ones the least index, so that the answer does not hang on the order the tree is
/// searched in.
struct Nearest {
    /// Squared distance of the best triangle, or the squared radius while there is none.
    best2: f32,
    best: Option<u32>,
    /// Boxes and planes at least this far (squared) hold no triangle that can be the best:
    /// the best distance plus [`Nearest::slack`]. The bounds and the triangles' distances are
    /// rounded apart in `f32`, so a triangle at the best's distance may sit in a box whose
    /// rounded distance is a few units in the last place farther; without the slack the tree
    /// searched first would decide the tie.
    cut2: f32,
    /// Some sixteen units in the last place of the coordinates the search reads, mm.
    slack: f32,
}

impl Nearest {
    fn new(q: Vec3, radius: f32) -> Nearest {
        let slack = 16.0 * f32::EPSILON * (q.abs().max_element() + radius);
        let mut near = Nearest {
            best2: radius * radius,
            best: None,
            cut2: 0.0,
            slack,
        };
        near.cut2 = near.cut_of(near.best2);
        near
    }

    fn cut_of(&self, best2: f32) -> f32 {
        let reach = best2.sqrt() + self.slack;
        reach * reach
    }

    /// Takes triangle `id` at squared distance `d2` if it is nearer than the best, or as near
    /// with a lesser index.
    #[inline(always)]
    fn offer(&mut self, id: u32, d2: f32) {
        let better = match self.best {
            None => d2 < self.best2,
            Some(best) => d2 < self.best2 || (d2 == self.best2 && id < best),
        };
        if better {
            if d2 != self.best2 {
                self.cut2 = self.cut_of(d2);
            }
            self.best2 = d2;
            self.best = Some(id);
        }
    }
}

/// The nearest-point search's step over one packet for the point `q`: each triangle nearer
/// than the best (or as near, of lesser index) becomes the best.
#[inline(always)]
fn nearest_in_packet(tri: &Tri4, q: Vec3, q4: &Point4, near: &mut Nearest) {
    // A triangle whose plane is no nearer than the best so far (and the slack) cannot be
    // nearer itself: most are ruled out so, without the full search (lanes set in `maybe`;
    // the test is made again with the best as it shrinks, in the scalar arithmetic).
    let (h, nn) = plane_distance(tri, q4);
    let far = nn.cmpgt(Vec4::ZERO) & (h * h).cmpge(nn * near.cut2);
    let maybe = (!far).bitmask();
    if maybe == 0 {
        return;
    }
    let (h, nn) = (h.to_array(), nn.to_array());
    let (d2, scalar) = closest_distance2(tri, q4);
    // The best only shrinks, so a lane farther than it now is never taken below: only the
    // lanes as near or nearer, and those left to the scalar function, go through the loop.
    let nearer = d2.cmple(Vec4::splat(near.best2)).bitmask() | scalar;
    let d2 = d2.to_array();
    for k in lanes(maybe & nearer) {
        let id = tri.id[k];
        if id == NO_TRIANGLE || (nn[k] > 0.0 && h[k] * h[k] >= near.cut2 * nn[k]) {
            continue;
        }
        let d2 = if scalar & (1 << k) == 0 {
            d2[k]
        } else {
            let [a, ab, ac] = [tri.a, tri.ab, tri.ac].map(|v| Vec3::new(v[0][k], v[1][k], v[2][k]));
            closest_on_triangle(a, ab, ac, q).distance_squared(q)
        };
        near.offer(id, d2);
    }
}

/// The squared distance from `q` to each of four triangles, lane by lane: each lane is
/// [`closest_on_triangle`]'s arithmetic for the case (Voronoi region) it falls in, so the
/// distance is that function's to the bit. Lanes it leaves to the scalar function are set in
/// the mask: the degenerate case (the triangle has no area, where the nearest corner is
/// chosen) and every lane of a packet with a corner or edge that is not finite.
#[inline(always)]
fn closest_distance2(tri: &Tri4, q: &Point4) -> (Vec4, u32) {
    let [a, b, c] = [tri.a, tri.ab, tri.ac];
    let dot = |u: [Vec4; 3], v: [Vec4; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let sub = |u: [Vec4; 3], v: [Vec4; 3]| [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
    let ap = sub(q.0, a);
    let (d1, d2) = (dot(b, ap), dot(c, ap));
    let bp = sub(ap, b);
    let (d3, d4) = (dot(b, bp), dot(c, bp));
    let vc = d1 * d4 - d3 * d2;
    let cp = sub(ap, c);
    let (d5, d6) = (dot(b, cp), dot(c, cp));
    let vb = d5 * d2 - d1 * d6;
    let va = d3 * d6 - d5 * d4;
    let (zero, one) = (Vec4::ZERO, Vec4::ONE);
    // Each case's point as (a + ab s) + e t, in the scalar function's order of cases: the
    // last case first, each earlier one taking over the lanes where it holds.
    let denom = va + vb + vc;
    let (mut s, mut t, mut e) = (vb / denom, vc / denom, c);
    let degenerate = denom.cmpeq(zero) | !denom.abs().cmplt(Vec4::INFINITY);
    let (g, h) = (d4 - d3, d5 - d6);
    let on_bc = va.cmple(zero) & g.cmpge(zero) & h.cmpge(zero);
    s = Vec4::select(on_bc, one, s);
    t = Vec4::select(on_bc, g / (g + h), t);
    let cb = sub(c, b);
    e = [0, 1, 2].map(|k| Vec4::select(on_bc, cb[k], e[k]));
    let on_ac = vb.cmple(zero) & d2.cmpge(zero) & d6.cmple(zero);
    s = Vec4::select(on_ac, zero, s);
    t = Vec4::select(on_ac, d2 / (d2 - d6), t);
    let at_c = d6.cmpge(zero) & d5.cmple(d6);
    s = Vec4::select(at_c, zero, s);
    t = Vec4::select(at_c, one, t);
    let on_ab = vc.cmple(zero) & d1.cmpge(zero) & d3.cmple(zero);
    s = Vec4::select(on_ab, d1 / (d1 - d3), s);
    t = Vec4::select(on_ab, zero, t);
    let at_b = d3.cmpge(zero) & d4.cmple(d3);
    s = Vec4::select(at_b, one, s);
    t = Vec4::select(at_b, zero, t);
    // The cases of an edge, vertex or face other than at a take over `e` from the face
    // case: the edge bc's lanes already hold c - b, the others c.
    let not_bc = on_ac | at_c | on_ab | at_b;
    e = [0, 1, 2].map(|k| Vec4::select(not_bc, c[k], e[k]));
    let at_a = d1.cmple(zero) & d2.cmple(zero);
    let d = [0, 1, 2].map(|k| {
        let p = (a[k] + b[k] * s) + e[k] * t;
        Vec4::select(at_a, a[k], p) - q.0[k]
    });
    let named = at_a | at_b | on_ab | at_c | on_ac | on_bc;
    let scalar = if tri.finite {
        (degenerate & !named).bitmask()
    } else {
        0b1111
    };
    (dot(d, d), scalar)
}

/// Most subtrees of a [`Region`], in groups of four.
const REGION_GROUPS: usize = 4;

/// Subtrees of a [`Bvh`] that hold every triangle meeting a ball ([`Bvh::region`]): a query
/// that stays in the ball starts from them and is spared the descent from the root, which is
/// most of the cost of a short ray. The subtrees' boxes come along, four to a group, so that
/// a query tests them four at a time and enters only those it reaches.
#[derive(Debug, Clone, Copy)]
pub struct Region {
    /// The subtrees as the children of nodes.
    groups: [Node4; REGION_GROUPS],
    /// Subtrees in the groups; 0 for the whole tree.
    len: usize,
}

impl Region {
    /// The whole tree (its root).
    pub const WHOLE: Region = Region {
        groups: [Node4 {
            lo: [Vec4::INFINITY; 3],
            hi: [Vec4::INFINITY; 3],
            child: [NO_CHILD; 4],
        }; REGION_GROUPS],
        len: 0,
    };

    /// The groups in use (none for the whole tree).
    #[inline]
    fn groups(&self) -> &[Node4] {
        &self.groups[..self.len.div_ceil(4)]
    }
}

/// How many points of a facet are tested: the centroid only, or a lattice fine enough that
/// no sample is farther apart than a spacing.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Sampling {
    /// One point per facet, its centroid (the default).
    #[default]
    Centroid,
    /// A facet whose longest edge is L gets k x k points with k = ceil(L / spacing), at most
    /// [`MAX_SUBDIVISION`] x [`MAX_SUBDIVISION`]: the centroids of the k^2 equal triangles of
    /// its regular subdivision. Spacing in mm.
    Spacing(f64),
}

/// Largest k of [`Sampling::Spacing`] (so at most 64 points per facet).
pub const MAX_SUBDIVISION: usize = 8;

impl Sampling {
    /// Subdivision k of a facet with these corners (1 for the centroid alone).
    pub fn subdivision(self, [a, b, c]: [DVec3; 3]) -> usize {
        match self {
            Sampling::Centroid => 1,
            Sampling::Spacing(h) => {
                let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
                let k = (longest / h).ceil();
                if k.is_finite() && k >= 1.0 {
                    (k as usize).min(MAX_SUBDIVISION)
                } else {
                    1
                }
            }
        }
    }

    /// Calls `f` with each sample point of the facet; the points are the centroids of equal
    /// triangles, so each stands for the same share of the facet's area.
    pub fn for_each(self, corners: [DVec3; 3], f: impl FnMut(DVec3)) {
        Self::for_each_k(corners, self.subdivision(corners), f);
    }

    /// [`Sampling::for_each`] with the subdivision `k` given (at least 1).
    pub fn for_each_k(corners: [DVec3; 3], k: usize, mut f: impl FnMut(DVec3)) {
        let [a, b, c] = corners;
        let k = k.max(1);
        if k == 1 {
            f((a + b + c) / 3.0);
            return;
        }
        let (ab, ac) = ((b - a) / k as f64, (c - a) / k as f64);
        for i in 0..k {
            for j in 0..k - i {
                // The triangle with corners (i, j), (i+1, j), (i, j+1) in steps along ab, ac.
                f(a + ab * (i as f64 + 1.0 / 3.0) + ac * (j as f64 + 1.0 / 3.0));
                if i + j + 2 <= k {
                    // Its upside-down neighbour (i+1, j), (i, j+1), (i+1, j+1).
                    f(a + ab * (i as f64 + 2.0 / 3.0) + ac * (j as f64 + 2.0 / 3.0));
                }
            }
        }
    }
}

/// Entries of a query's stack kept in place: a descent pushes at most three a level, and the
/// four-wide tree of a real part is 8 to 10 levels deep. A deeper one (a degenerate mesh)
/// spills into a vector. Each query zeroes these entries first, and the wall thickness makes
/// about eight queries a facet: they are no more than a descent needs.
const STACK: usize = 32;

/// The subtrees a query has still to search, each with its key (the ray's entry distance,
/// or the squared distance to its box), last in first out.
struct Stack {
    items: [(u32, f32); STACK],
    top: usize,
    more: Vec<(u32, f32)>,
}

impl Stack {
    #[inline]
    fn new() -> Stack {
        Stack {
            items: [(0, 0.0); STACK],
            top: 0,
            more: Vec::new(),
        }
    }

    #[inline]
    fn push(&mut self, item: (u32, f32)) {
        if self.top == STACK {
            self.spill();
        }
        self.items[self.top] = item;
        self.top += 1;
    }

    #[inline]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if self.top == 0 && !self.refill() {
            return None;
        }
        self.top -= 1;
        Some(self.items[self.top])
    }

    /// Moves the older half of a full stack into the vector.
    #[cold]
    fn spill(&mut self) {
        self.more.extend_from_slice(&self.items[..STACK / 2]);
        self.items.copy_within(STACK / 2.., 0);
        self.top = STACK - STACK / 2;
    }

    /// Takes the newest entries of the vector back into an empty stack; false when none.
    #[cold]
    fn refill(&mut self) -> bool {
        let n = self.more.len().min(STACK / 2);
        let from = self.more.len() - n;
        self.items[..n].copy_from_slice(&self.more[from..]);
        self.more.truncate(from);
        self.top = n;
        n > 0
    }
}

/// A point or vector with each coordinate in all four lanes.
struct Point4([Vec4; 3]);

impl Point4 {
    #[inline]
    fn splat(v: Vec3) -> Point4 {
        Point4([Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)])
    }
}

/// The lanes set in a four-bit mask, in order.
#[inline]
fn lanes(mask: u32) -> impl Iterator<Item = usize> {
    let mut bits = mask;
    std::iter::from_fn(move || {
        (bits != 0).then(|| {
            let k = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            k
        })
    })
}

/// The next step of a descent into the children in `mask`, whose keys (entry distances) are
/// `key`: the nearest child (of equal keys, the lower lane), the others pushed on `stack` so
/// that they come off it nearest first; `None` when the mask is empty.
#[inline(always)]
fn descend(mask: u32, key: Vec4, child: &[u32; 4], stack: &mut Stack) -> Option<u32> {
    if mask & mask.wrapping_sub(1) == 0 {
        // None or one: the usual cases.
        return (mask != 0).then(|| child[mask.trailing_zeros() as usize]);
    }
    let key = key.to_array();
    let first = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    let second = rest.trailing_zeros() as usize;
    if rest & (rest - 1) == 0 {
        let (near, far) = if key[second] < key[first] {
            (second, first)
        } else {
            (first, second)
        };
        stack.push((child[far], key[far]));
        return Some(child[near]);
    }
    let mut order = [(0f32, 0u32); 4];
    let mut m = 0;
    for k in lanes(mask) {
        let item = (key[k], child[k]);
        let mut j = m;
        while j > 0 && order[j - 1].0 > item.0 {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = item;
        m += 1;
    }
    for &(key, child) in order[1..m].iter().rev() {
        stack.push((child, key));
    }
    Some(order[0].1)
}

/// Squared distance from `q` to each child's box (0 inside; infinity for a lane without a
/// child).
#[inline]
fn box_distance2(n: &Node4, q: &Point4) -> Vec4 {
    let mut d2 = Vec4::ZERO;
    for axis in 0..3 {
        let d = (n.lo[axis] - q.0[axis])
            .max(q.0[axis] - n.hi[axis])
            .max(Vec4::ZERO);
        d2 += d * d;
    }
    d2
}

/// The children whose box the ray enters before `t_max` (a bit per lane), and where it enters
/// each; `inv` is the inverse of the direction with tiny components raised (see
/// [`TINY_COMPONENT`]). A box left before `t_min` (the ray's `min_distance`) is passed as
/// well: it holds no hit that counts.
#[inline]
fn slab(n: &Node4, o: &Point4, inv: &Point4, t_min: f32, t_max: f32) -> (u32, Vec4) {
    // No operand is NaN (finite inverse, boxes finite or the point at infinity), so the
    // four-lane min / max need no NaN rule.
    let mut near = Vec4::ZERO;
    let mut far = Vec4::splat(t_max);
    for axis in 0..3 {
        let t1 = (n.lo[axis] - o.0[axis]) * inv.0[axis];
        let t2 = (n.hi[axis] - o.0[axis]) * inv.0[axis];
        near = near.max(t1.min(t2));
        far = far.min(t1.max(t2));
    }
    let hits = near.cmple(far) & far.cmpge(Vec4::splat(t_min));
    (hits.bitmask(), near)
}

/// Möller-Trumbore on four triangles at once with the barycentric slack of
/// [`EDGE_TOLERANCE`]: a bit per lane the ray crosses, and the distances along it. Each lane
/// is the scalar test's arithmetic in its order, so the distances are the scalar test's to
/// the bit. Triangles seen edge-on and without area are never hit.
#[inline]
fn intersect(tri: &Tri4, o: &Point4, d: &Point4) -> (u32, [f32; 4]) {
    let [dx, dy, dz] = d.0;
    let [abx, aby, abz] = tri.ab;
    let [acx, acy, acz] = tri.ac;
    let px = dy * acz - acy * dz;
    let py = dz * acx - acz * dx;
    let pz = dx * acy - acx * dy;
    let det = abx * px + aby * py + abz * pz;
    // Relative test: edge-on (or area-less) triangles are never hit.
    let mut hits: BVec4A = det.abs().cmpgt(tri.min_det);
    let inv = Vec4::ONE / det;
    let sx = o.0[0] - tri.a[0];
    let sy = o.0[1] - tri.a[1];
    let sz = o.0[2] - tri.a[2];
    let u = (sx * px + sy * py + sz * pz) * inv;
    hits &= u.cmpge(Vec4::splat(-EDGE_TOLERANCE)) & u.cmple(Vec4::splat(1.0 + EDGE_TOLERANCE));
    let qx = sy * abz - aby * sz;
    let qy = sz * abx - abz * sx;
    let qz = sx * aby - abx * sy;
    let v = (dx * qx + dy * qy + dz * qz) * inv;
    hits &=
        !v.cmplt(Vec4::splat(-EDGE_TOLERANCE)) & !(u + v).cmpgt(Vec4::splat(1.0 + EDGE_TOLERANCE));
    let t = (acx * qx + acy * qy + acz * qz) * inv;
    (hits.bitmask(), t.to_array())
}

/// For four triangles, the normal's dot product with `q` less a corner (the distance to the
/// plane times the normal's length) and the normal's squared length.
#[inline]
fn plane_distance(tri: &Tri4, q: &Point4) -> (Vec4, Vec4) {
    let [abx, aby, abz] = tri.ab;
    let [acx, acy, acz] = tri.ac;
    let nx = aby * acz - acy * abz;
    let ny = abz * acx - acz * abx;
    let nz = abx * acy - acx * aby;
    let wx = q.0[0] - tri.a[0];
    let wy = q.0[1] - tri.a[1];
    let wz = q.0[2] - tri.a[2];
    (nx * wx + ny * wy + nz * wz, nx * nx + ny * ny + nz * nz)
}

/// The point of the triangle nearest to `p` (Ericson, *Real-Time Collision Detection*, 5.1.5).
fn closest_on_triangle(a: Vec3, ab: Vec3, ac: Vec3, p: Vec3) -> Vec3 {
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = ap - ab;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return a + ab;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = ap - ac;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return a + ac;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return a + ab + (ac - ab) * w;
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // An area-less triangle: its nearest corner is good enough.
        return [a, a + ab, a + ac]
            .into_iter()
            .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
            .unwrap_or(a);
    }
    let v = vb / denom;
    let w = vc / denom;
    a + ab * v + ac * w
}

/// Builds the subtree over `items` (reordered in place into leaf order); node links are
/// relative to the returned vector, triangle links relative to `first`.
fn build(items: &mut [Item], first: usize, known: Option<Extent>) -> Vec<Node> {
    // About 0.64 nodes a triangle on the shared parts: room for that without growing.
    let mut nodes = Vec::with_capacity(items.len() * 3 / 4 + 16);
    build_into(items, first, &mut nodes, known);
    nodes
}

/// Bits of a Morton code per axis for a mesh of `n` triangles: a code and a mesh index make
/// one `u64`, so 13 (the index in the 25 bits left) below 2^25 triangles, and 10 above (the
/// index in 32 or more). The cells are cubes (see [`build_morton`]): on copies of the housing
/// side by side, 2.3 m along x, a cell of 13 bits is 0.28 mm, still finer than the
/// triangles, so that the codes sort them in space as on one copy.
fn morton_bits(n: usize) -> u32 {
    if n < 1 << 25 {
        13
    } else {
        10
    }
}

/// Bits of the mesh index below a code of `bits` bits an axis in one `u64` key.
fn index_bits(bits: u32) -> u32 {
    64 - 3 * bits
}

/// The 16 low bits of `x` spread to every third bit.
#[inline]
fn spread_bits(x: u32) -> u64 {
    let mut x = (x & 0xffff) as u64;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The binary tree of `items` (reordered in place into leaf order) by a Morton curve: each
/// item's centre quantised to [`morton_bits`] bits per axis in cubic cells over the box of
/// the centres (the same step along every axis, so that a long part is cut across its
/// length first, as its boxes are: steps scaled to each axis cut a part 40 times longer than
/// wide into slabs as long as the part, and the walls' queries through that tree slowed as
/// the part grew), the items sorted by code and then by mesh index (one key, so the order is
/// one whatever the threads), and each node split where its codes' highest differing bit
/// changes (in the middle when its codes are all one), down to leaves of at most
/// [`MORTON_LEAF_SIZE`]. Each node's box is the union of its children's, found as the
/// recursion comes back up.
fn build_morton(boxes: &[(Vec3, Vec3)]) -> (Vec<Node>, Vec<u32>) {
    // The empty box of a triangle without finite corners has no centre: it is left out of
    // the centres' bounds, and sorts first below.
    let centres = boxes
        .par_iter()
        .with_min_len(4096)
        .fold(
            || Bounds::EMPTY,
            |mut b, it| {
                if let Some(c) = box_centre(*it) {
                    let c = Vec3A::from(c);
                    b.grow(c, c);
                }
                b
            },
        )
        .reduce(
            || Bounds::EMPTY,
            |mut a, b| {
                a.grow(b.min, b.max);
                a
            },
        );
    let extent = (centres.max - centres.min).max(Vec3A::splat(f32::MIN_POSITIVE));
    let bits = morton_bits(boxes.len());
    let id_bits = index_bits(bits);
    let top = ((1u32 << bits) - 1) as f32;
    let scale = Vec3A::splat(top / extent.max_element());
    let mut keys: Vec<u64> = boxes
        .par_iter()
        .with_min_len(4096)
        .enumerate()
        .map(|(id, it)| {
            // A triangle without a box (a corner not finite) sorts first; it is never hit.
            let code = box_centre(*it).map_or(0, |c| {
                let q =
                    ((Vec3A::from(c) - centres.min) * scale).clamp(Vec3A::ZERO, Vec3A::splat(top));
                spread_bits(q.x as u32)
                    | spread_bits(q.y as u32) << 1
                    | spread_bits(q.z as u32) << 2
            });
            code << id_bits | id as u64
        })
        .collect();
    sort_by_code(&mut keys, bits);
    let id_mask = (1u64 << id_bits) - 1;
    let ids: Vec<u32> = keys.par_iter().map(|&k| (k & id_mask) as u32).collect();
    keys.par_iter_mut().for_each(|k| *k >>= id_bits);
    let codes = keys;
    let (count, mut lefts) = morton_count_noting(&codes, 0);
    lefts.sort_unstable();
    let mut nodes = vec![UNWRITTEN; count];
    morton_into(&ids, boxes, &codes, 0, &mut nodes, 0, &lefts);
    (nodes, ids)
}

/// Sorts keys `code << index_bits(bits) | index` given in the order of their indices, with
/// codes of `3 * bits` bits: three stable counting passes of `bits` bits over the codes, so
/// that equal codes keep their indices' order (the order of sorting the whole keys, for a
/// few passes over them instead of a comparison sort).
fn sort_by_code(keys: &mut Vec<u64>, bits: u32) {
    let buckets = 1usize << bits;
    let mut other = vec![0u64; keys.len()];
    let mut start = vec![0usize; buckets];
    for pass in 0..3 {
        let shift = index_bits(bits) + bits * pass;
        let bucket = |k: u64| (k >> shift) as usize & (buckets - 1);
        start.iter_mut().for_each(|s| *s = 0);
        for &k in keys.iter() {
            start[bucket(k)] += 1;
        }
        let mut sum = 0;
        for s in start.iter_mut() {
            (*s, sum) = (sum, sum + *s);
        }
        for &k in keys.iter() {
            let b = bucket(k);
            other[start[b]] = k;
            start[b] += 1;
        }
        std::mem::swap(keys, &mut other);
    }
}

/// Where the triangles of a node, whose codes are `codes`, split into its two children:
/// the first child's count, at the highest bit in which the codes differ (half way when
/// they are all equal); `None` for a leaf.
fn morton_split(codes: &[u64]) -> Option<usize> {
    if codes.len() <= MORTON_LEAF_SIZE {
        return None;
    }
    let (lo, hi) = (codes[0], codes[codes.len() - 1]);
    Some(if lo == hi {
        codes.len() / 2
    } else {
        let bit = 63 - (lo ^ hi).leading_zeros();
        codes.partition_point(|&c| c >> bit & 1 == 0)
    })
}

/// How many nodes the subtree of the triangles whose codes are `codes` has.
fn morton_count(codes: &[u64]) -> usize {
    match morton_split(codes) {
        None => 1,
        Some(mid) => {
            let (l, r) = codes.split_at(mid);
            if codes.len() > PARALLEL_MIN {
                let (a, b) = join(|| morton_count(l), || morton_count(r));
                1 + a + b
            } else {
                1 + morton_count(l) + morton_count(r)
            }
        }
    }
}

/// A large node, as (its first triangle, its triangle count), and the node count of its
/// first child's subtree.
type FirstSubtree = ((usize, usize), usize);

/// [`morton_count`] of the triangles whose codes are `codes` (the first of them triangle
/// `first` in the sorted order), with, for every node of more than [`PARALLEL_MIN`]
/// triangles, the node count of its first child's subtree, by the node's (first triangle,
/// triangle count): what [`morton_into`] needs to place the two subtrees it builds side by
/// side, counted once rather than again at each level.
fn morton_count_noting(codes: &[u64], first: usize) -> (usize, Vec<FirstSubtree>) {
    if codes.len() <= PARALLEL_MIN {
        return (morton_count(codes), Vec::new());
    }
    let mid = morton_split(codes).expect("a large node splits");
    let (l, r) = codes.split_at(mid);
    let ((left, mut noted), (right, more)) = join(
        || morton_count_noting(l, first),
        || morton_count_noting(r, first + mid),
    );
    noted.extend(more);
    noted.push(((first, codes.len()), left));
    (1 + left + right, noted)
}

impl Node {
    /// An interior node of box `b` whose second child is at `link`.
    fn interior(b: &Bounds, link: u32) -> Node {
        Node {
            min: b.min.to_array(),
            link,
            max: b.max.to_array(),
            count: 0,
        }
    }
}

/// A node slot before the build writes it.
const UNWRITTEN: Node = Node {
    min: [0.0; 3],
    link: 0,
    max: [0.0; 3],
    count: 0,
};

/// Builds the node of the triangles `ids` (whose codes are `codes`, boxes `boxes[id]`) and
/// its subtree into `out`, which holds exactly its nodes ([`morton_count`]): the node, then
/// its first child's subtree, then its second's; `at` is the index of `out[0]` in the whole
/// tree, triangle links are relative to `first`. Returns the node's box. The two subtrees of
/// a large node are built side by side, each into its own part of `out`, so nothing is
/// copied or grown; `lefts` holds the size of each large node's first subtree
/// ([`morton_count_noting`], sorted).
fn morton_into(
    ids: &[u32],
    boxes: &[(Vec3, Vec3)],
    codes: &[u64],
    first: usize,
    out: &mut [Node],
    at: usize,
    lefts: &[FirstSubtree],
) -> Bounds {
    if ids.len() <= PARALLEL_MIN {
        let mut next = 0;
        let b = morton_serial(ids, boxes, codes, first, out, at, &mut next);
        debug_assert_eq!(next, out.len());
        return b;
    }
    let mid = morton_split(codes).expect("a large node splits");
    let (left, right) = ids.split_at(mid);
    let (l_codes, r_codes) = codes.split_at(mid);
    let (me, rest) = out.split_first_mut().expect("a node's slot");
    let n_left = lefts
        .binary_search_by_key(&(first, ids.len()), |&(node, _)| node)
        .map(|i| lefts[i].1)
        .expect("every large node's first subtree is counted");
    debug_assert_eq!(n_left, morton_count(l_codes));
    let (l_out, r_out) = rest.split_at_mut(n_left);
    let (mut b, r) = join(
        || morton_into(left, boxes, l_codes, first, l_out, at + 1, lefts),
        || {
            morton_into(
                right,
                boxes,
                r_codes,
                first + mid,
                r_out,
                at + 1 + n_left,
                lefts,
            )
        },
    );
    b.grow(r.min, r.max);
    *me = Node::interior(&b, (at + 1 + n_left) as u32);
    b
}

/// [`morton_into`] on one thread: the nodes in the same order, written from `out[*next]` on
/// (`at` the index of `out[0]` in the whole tree).
fn morton_serial(
    ids: &[u32],
    boxes: &[(Vec3, Vec3)],
    codes: &[u64],
    first: usize,
    out: &mut [Node],
    at: usize,
    next: &mut usize,
) -> Bounds {
    let me = *next;
    *next += 1;
    let Some(mid) = morton_split(codes) else {
        let mut b = Bounds::EMPTY;
        for &id in ids {
            let (min, max) = boxes[id as usize];
            b.grow(Vec3A::from(min), Vec3A::from(max));
        }
        out[me] = Node {
            min: b.min.to_array(),
            link: first as u32,
            max: b.max.to_array(),
            count: ids.len() as u32,
        };
        return b;
    };
    let (left, right) = ids.split_at(mid);
    let (l_codes, r_codes) = codes.split_at(mid);
    let mut b = morton_serial(left, boxes, l_codes, first, out, at, next);
    let link = (at + *next) as u32;
    let r = morton_serial(right, boxes, r_codes, first + mid, out, at, next);
    b.grow(r.min, r.max);
    out[me] = Node::interior(&b, link);
    b
}

/// The box of some items and the box of their centres.
#[derive(Clone, Copy)]
struct Extent {
    bounds: Bounds,
    centres: Bounds,
}

impl Extent {
    const EMPTY: Extent = Extent {
        bounds: Bounds::EMPTY,
        centres: Bounds::EMPTY,
    };

    fn of(items: &[Item]) -> Extent {
        let mut e = Extent::EMPTY;
        for it in items {
            e.add(it);
        }
        e
    }

    #[inline]
    fn add(&mut self, it: &Item) {
        self.bounds.grow(Vec3A::from(it.min), Vec3A::from(it.max));
        let c = Vec3A::from(it.centre);
        self.centres.grow(c, c);
    }

    #[cfg(test)]
    fn join(&mut self, other: &Extent) {
        self.bounds.grow(other.bounds.min, other.bounds.max);
        self.centres.grow(other.centres.min, other.centres.max);
    }
}

/// Builds the node of `items` and its subtree; `known` is their extent when the parent's
/// split already found it (the union of its bins, exactly what a pass over them gives).
fn build_into(items: &mut [Item], first: usize, nodes: &mut Vec<Node>, known: Option<Extent>) {
    let Extent { bounds, centres } = known.unwrap_or_else(|| Extent::of(items));
    let me = nodes.len();
    nodes.push(Node {
        min: bounds.min.to_array(),
        link: first as u32,
        max: bounds.max.to_array(),
        count: items.len() as u32,
    });
    if items.len() <= LEAF_SIZE {
        return;
    }
    let answer = match split(items, &bounds, &centres) {
        // A leaf holds at most `LEAF_PACKETS` packets of four: a larger one (which the split
        // never asks for on a real part) is halved.
        None if items.len() > 4 * LEAF_PACKETS => Some((items.len() / 2, None)),
        answer => answer,
    };
    let Some((mid, sides)) = answer else {
        return;
    };
    let (l_known, r_known) = match sides {
        Some((l, r)) => (Some(l), Some(r)),
        None => (None, None),
    };
    let (left, right) = items.split_at_mut(mid);
    nodes[me].count = 0;
    if left.len() + right.len() > PARALLEL_MIN {
        // The left subtree goes on in `nodes` (it follows its parent); only the right one,
        // built on the other thread, is copied after it.
        let ((), r) = join(
            || build_into(left, first, nodes, l_known),
            || build(right, first + mid, r_known),
        );
        nodes[me].link = nodes.len() as u32;
        let base = nodes.len();
        append(nodes, r, base);
    } else {
        build_into(left, first, nodes, l_known);
        nodes[me].link = nodes.len() as u32;
        build_into(right, first + mid, nodes, r_known);
    }
}

/// The four-wide tree from the binary one (each interior node followed by its first child,
/// `link` naming its second): each node takes the children of its binary node, then opens
/// the interior child of largest surface area into its two children until it has four or
/// only leaves; a binary node of two leaves whose packets fit in one leaf is that leaf. The
/// leaves keep their left-to-right order, so the leaf order (and `ids`) is the binary
/// tree's; nodes are laid out depth first.
///
/// A node whose binary subtree has more than `parallel_min` nodes collapses its first
/// children here and its last ones on another thread into a collapse of their own, whose
/// nodes and leaves are then appended with their references moved: the tree one thread
/// makes.
struct Collapse<'a> {
    built: &'a [Node],
    parallel_min: usize,
    nodes: Vec<Node4>,
    /// Each leaf's first triangle in leaf order and its count, in the order of its packets.
    leaves: Vec<(u32, u32)>,
    /// Packets of the leaves so far.
    packets: usize,
    /// The reference to the root (see [`Collapse::of`]).
    root: u32,
}

impl<'a> Collapse<'a> {
    /// The four-wide tree of the whole binary tree `built`.
    fn of(built: &'a [Node], parallel_min: usize) -> Collapse<'a> {
        let mut wide = Collapse::empty(built, parallel_min, built.len());
        wide.root = wide.child(0, built.len());
        wide
    }

    /// A collapse with nothing made yet, with room for a binary subtree of `span` nodes.
    fn empty(built: &'a [Node], parallel_min: usize, span: usize) -> Collapse<'a> {
        Collapse {
            built,
            parallel_min,
            nodes: Vec::with_capacity(span / 3 + 1),
            leaves: Vec::with_capacity(span / 2 + 1),
            packets: 0,
            root: NO_CHILD,
        }
    }

    /// The reference to binary node `i` (its subtree is `built[i..end]`) in the four-wide
    /// tree, made with its subtree.
    fn child(&mut self, i: usize, end: usize) -> u32 {
        let n = self.built[i];
        // A leaf, or the empty tree's root (no triangle, no children).
        if n.count > 0 || self.built.len() == 1 {
            if n.count == 0 {
                return NO_CHILD;
            }
            return self.leaf(&[n]);
        }
        // A node of two leaves whose packets fit in one leaf: one leaf of both (their
        // triangles follow each other in leaf order, each leaf keeping its own packets)
        // rather than a node of two lanes. On 2.8 million triangles the surface-area tree
        // had 446,000 nodes of 3.0 lanes on average; now 253,000 of 3.8.
        let (a, b) = (self.built[i + 1], self.built[n.link as usize]);
        if a.count > 0 && b.count > 0 && packets_of(&a) + packets_of(&b) <= LEAF_PACKETS {
            return self.leaf(&[a, b]);
        }
        let (kids, m) = self.opened(i, end);
        let kids = &kids[..m];
        let me = self.nodes.len();
        self.nodes.push(Node4 {
            lo: [Vec4::INFINITY; 3],
            hi: [Vec4::INFINITY; 3],
            child: [NO_CHILD; 4],
        });
        let (mut lo, mut hi) = ([[f32::INFINITY; 4]; 3], [[f32::INFINITY; 4]; 3]);
        for (k, &(c, _)) in kids.iter().enumerate() {
            let b = self.built[c];
            // An empty box (triangles without finite corners) stays the point at infinity.
            if (0..3).all(|axis| b.min[axis] <= b.max[axis]) {
                for axis in 0..3 {
                    lo[axis][k] = b.min[axis];
                    hi[axis][k] = b.max[axis];
                }
            }
        }
        let mut child = [NO_CHILD; 4];
        if end - i > self.parallel_min {
            // The children split into a first and a last run of about equal binary nodes.
            let total = end - i;
            let h = (1..m)
                .min_by_key(|&h| (2 * (kids[h].0 - i)).abs_diff(total))
                .unwrap_or(m);
            let (here, there) = kids.split_at(h);
            let (built, parallel_min) = (self.built, self.parallel_min);
            let (mine, theirs) = child.split_at_mut(h);
            let ((), other) = join(
                || {
                    for (r, &(c, e)) in mine.iter_mut().zip(here) {
                        *r = self.child(c, e);
                    }
                },
                || {
                    let span = there.last().map_or(0, |l| l.1) - there.first().map_or(0, |f| f.0);
                    let mut other = Collapse::empty(built, parallel_min, span);
                    for (r, &(c, e)) in theirs.iter_mut().zip(there) {
                        *r = other.child(c, e);
                    }
                    other
                },
            );
            let (nodes, packets) = (self.nodes.len(), self.packets);
            let moved = |r: u32| moved(r, nodes, packets);
            for r in &mut child[h..m] {
                *r = moved(*r);
            }
            self.nodes.extend(other.nodes.into_iter().map(|n| Node4 {
                child: n.child.map(moved),
                ..n
            }));
            self.leaves.extend(other.leaves);
            self.packets += other.packets;
        } else {
            for (r, &(c, e)) in child.iter_mut().zip(kids) {
                *r = self.child(c, e);
            }
        }
        self.nodes[me] = Node4 {
            lo: lo.map(Vec4::from_array),
            hi: hi.map(Vec4::from_array),
            child,
        };
        me as u32
    }

    /// The reference to one leaf of the packets of binary leaves `parts`, which follow each
    /// other in leaf order; each part keeps packets of its own.
    fn leaf(&mut self, parts: &[Node]) -> u32 {
        let first = self.packets;
        for part in parts {
            self.leaves.push((part.link, part.count));
            self.packets += packets_of(part);
        }
        leaf_ref(first, self.packets - first)
    }

    /// The children of interior binary node `i` (its subtree `built[i..end]`) in the
    /// four-wide tree, each with the end of its subtree, and how many there are.
    fn opened(&self, i: usize, end: usize) -> ([(usize, usize); 4], usize) {
        let link = self.built[i].link as usize;
        let mut kids = [(i + 1, link), (link, end), (0, 0), (0, 0)];
        let mut m = 2;
        while m < 4 {
            let widest = kids[..m]
                .iter()
                .enumerate()
                .filter(|(_, &(c, _))| self.built[c].count == 0)
                .map(|(k, &(c, _))| (k, half_area_of(&self.built[c])))
                .fold(None, |best: Option<(usize, f32)>, (k, a)| match best {
                    Some((_, b)) if b >= a => best,
                    _ => Some((k, a)),
                });
            let Some((k, _)) = widest else {
                break;
            };
            let (c, e) = kids[k];
            let link = self.built[c].link as usize;
            kids.copy_within(k + 1..m, k + 2);
            kids[k] = (c + 1, link);
            kids[k + 1] = (link, e);
            m += 1;
        }
        (kids, m)
    }
}

/// A four-wide child reference made in a collapse of its own, moved to follow `nodes` nodes
/// and `packets` packets.
fn moved(r: u32, nodes: usize, packets: usize) -> u32 {
    if r == NO_CHILD {
        r
    } else if r & LEAF != 0 {
        r + ((packets as u32) << PACKET_SHIFT)
    } else {
        r + nodes as u32
    }
}

/// The packets of a binary leaf's triangles, four by four.
fn packets_of(leaf: &Node) -> usize {
    (leaf.count as usize).div_ceil(4)
}

/// Half the surface area of a node's box.
fn half_area_of(n: &Node) -> f32 {
    let d = [0, 1, 2].map(|k| (n.max[k] - n.min[k]).max(0.0));
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

/// The packet of up to four triangles `four` (mesh indices), relative to `origin`.
fn packet(mesh: &Mesh, origin: DVec3, four: &[u32]) -> Tri4 {
    let mut lanes = [[[0f32; 4]; 3]; 3];
    let mut min_det = [f32::INFINITY; 4];
    let mut id = [NO_TRIANGLE; 4];
    for (k, &t) in four.iter().enumerate() {
        let [a, b, c] = mesh.corners(t as usize).map(|v| (v - origin).as_vec3());
        let (ab, ac) = (b - a, c - a);
        for (lane, v) in lanes.iter_mut().zip([a, ab, ac]) {
            for axis in 0..3 {
                lane[axis][k] = v[axis];
            }
        }
        min_det[k] = 1e-7 * ab.length() * ac.length();
        id[k] = t;
    }
    let finite = lanes.iter().flatten().flatten().all(|v| v.is_finite());
    let [a, ab, ac] = lanes.map(|l| l.map(Vec4::from_array));
    Tri4 {
        a,
        ab,
        ac,
        min_det: Vec4::from_array(min_det),
        id,
        finite,
    }
}

/// Appends a subtree built on its own, moving its interior links by `base`.
fn append(nodes: &mut Vec<Node>, sub: Vec<Node>, base: usize) {
    nodes.extend(sub.into_iter().map(|mut n| {
        if n.count == 0 {
            n.link += base as u32;
        }
        n
    }));
}

/// Partitions `items` by the cheapest binned surface-area split; the size of the first part
/// and, when the split was binned, the extents of the two parts; or `None` when no split
/// beats a leaf and the leaf is small enough, or no split exists. The three axes are binned
/// in one pass over the items.
fn split(items: &mut [Item], bounds: &Bounds, centres: &Bounds) -> SplitAnswer {
    let extent = centres.max - centres.min;
    let (mut axes_of, mut n_axes) = ([0usize; 3], 0);
    for axis in 0..3 {
        if extent[axis].partial_cmp(&0.0) == Some(Ordering::Greater) {
            axes_of[n_axes] = axis;
            n_axes += 1;
        }
    }
    let axes = &axes_of[..n_axes];
    let lo = centres.min;
    let scale = Vec3A::splat(BINS as f32) / extent;
    if items.len() <= FEW_ITEMS {
        split_few(items, bounds, axes, lo, scale)
    } else {
        split_binned(items, bounds, axes, lo, scale)
    }
}

/// [`split`] by a full set of bins per axis.
fn split_binned(
    items: &mut [Item],
    bounds: &Bounds,
    axes: &[usize],
    lo: Vec3A,
    scale: Vec3A,
) -> SplitAnswer {
    let n_axes = axes.len();
    // Each bin's box of items (the centres' boxes of the two sides come from the
    // partition, which reads every item anyway, and only for the chosen axis).
    let mut bins = [[Bounds::EMPTY; BINS]; 3];
    let mut counts = [[0u32; BINS]; 3];
    if items.len() >= WIDE_BINNING && n_axes == 3 {
        // Neighbouring items mostly fall into the same bins, so one set of bins is a chain
        // of dependent minima through memory; two sets, one for the even and one for the
        // odd items, break it. Minima and maxima are exact, so their union is the one set.
        let mut odd = [[Bounds::EMPTY; BINS]; 3];
        let mut pairs = items.chunks_exact(2);
        for pair in &mut pairs {
            let (p, q) = (&pair[0], &pair[1]);
            let (bp, bq) = (bins_of(p, lo, scale), bins_of(q, lo, scale));
            let (p_min, p_max) = (Vec3A::from(p.min), Vec3A::from(p.max));
            let (q_min, q_max) = (Vec3A::from(q.min), Vec3A::from(q.max));
            for axis in 0..3 {
                bins[axis][bp[axis]].grow(p_min, p_max);
                odd[axis][bq[axis]].grow(q_min, q_max);
                counts[axis][bp[axis]] += 1;
                counts[axis][bq[axis]] += 1;
            }
        }
        for it in pairs.remainder() {
            let b = bins_of(it, lo, scale);
            for axis in 0..3 {
                bins[axis][b[axis]].grow(Vec3A::from(it.min), Vec3A::from(it.max));
                counts[axis][b[axis]] += 1;
            }
        }
        for (set, other) in bins.iter_mut().zip(&odd) {
            for (e, o) in set.iter_mut().zip(other) {
                e.grow(o.min, o.max);
            }
        }
    } else {
        for it in items.iter() {
            let b = bins_of(it, lo, scale);
            for &axis in axes {
                bins[axis][b[axis]].grow(Vec3A::from(it.min), Vec3A::from(it.max));
                counts[axis][b[axis]] += 1;
            }
        }
    }
    let mut best: Option<(f32, usize, f32)> = None; // (cost, axis, position)
    for &axis in axes {
        let (boxes, counts) = (&bins[axis], &counts[axis]);
        // Sweep from the right, then from the left, to price every plane between bins.
        let mut right_area = [0f32; BINS];
        let mut acc = Bounds::EMPTY;
        let mut n = 0u32;
        let mut right_count = [0u32; BINS];
        for b in (1..BINS).rev() {
            acc.grow(boxes[b].min, boxes[b].max);
            n += counts[b];
            right_area[b] = acc.half_area();
            right_count[b] = n;
        }
        let mut acc = Bounds::EMPTY;
        let mut n = 0u32;
        for b in 0..BINS - 1 {
            acc.grow(boxes[b].min, boxes[b].max);
            n += counts[b];
            let (nl, nr) = (n, right_count[b + 1]);
            if nl == 0 || nr == 0 {
                continue;
            }
            let cost = acc.half_area() * nl as f32 + right_area[b + 1] * nr as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                let plane = lo[axis] + (b + 1) as f32 / scale[axis];
                best = Some((cost, axis, plane));
            }
        }
    }
    let (axis, cut) = match chosen_cut(best, bounds, items.len(), lo, scale) {
        ControlFlow::Continue(chosen) => chosen,
        ControlFlow::Break(answer) => return answer,
    };
    // Partition in place by the chosen plane, with the binning's own arithmetic: an item
    // goes left when its bin is below `cut`, that is (its scaled offset being at least 0
    // and `cut` at most the last bin) when the offset itself is below `cut`.
    let (lo_axis, scale_axis, below) = (lo[axis], scale[axis], cut as f32);
    let (i, [l_centres, r_centres]) =
        partition(items, |it| (it.centre[axis] - lo_axis) * scale_axis < below);
    // The parts' boxes are the unions of the bins below and above the cut (min and max are
    // exact, so these are the boxes a pass over their items gives).
    let (mut l_bounds, mut r_bounds) = (Bounds::EMPTY, Bounds::EMPTY);
    for (b, e) in bins[axis].iter().enumerate() {
        let side = if b < cut {
            &mut l_bounds
        } else {
            &mut r_bounds
        };
        side.grow(e.min, e.max);
    }
    let left = Extent {
        bounds: l_bounds,
        centres: l_centres,
    };
    let right = Extent {
        bounds: r_bounds,
        centres: r_centres,
    };
    (i > 0 && i < items.len()).then_some((i, Some((left, right))))
}

/// A split's answer: where the items part (left count) and, when known, the two sides'
/// extents; `None` keeps the node a leaf.
type SplitAnswer = Option<(usize, Option<(Extent, Extent)>)>;

/// A split's decision once its planes are priced (`best`: cost, axis, plane, of `n` items
/// inside `bounds`): `Continue((axis, cut))`, the plane as the first bin of the right side, or
/// `Break` with the split's answer when there is no plane (centres all equal: halve the
/// list so that leaves stay small) or the node is cheaper as a leaf.
fn chosen_cut(
    best: Option<(f32, usize, f32)>,
    bounds: &Bounds,
    n: usize,
    lo: Vec3A,
    scale: Vec3A,
) -> ControlFlow<SplitAnswer, (usize, usize)> {
    let Some((cost, axis, plane)) = best else {
        return ControlFlow::Break((n > LEAF_SIZE).then_some((n / 2, None)));
    };
    let leaf_cost = bounds.half_area() * n as f32;
    if cost >= leaf_cost && n <= 4 * LEAF_SIZE {
        return ControlFlow::Break(None);
    }
    ControlFlow::Continue((axis, ((plane - lo[axis]) * scale[axis]).round() as usize))
}

/// Items up to which a split prices only the planes after its occupied bins (see
/// [`split_few`]): most nodes are this small, and for them emptying and sweeping every bin
/// costs far more than binning the items.
const FEW_ITEMS: usize = 32;

/// [`split`] for a few items, with the same answer: the same plane, the same partition and
/// the same extents, without a full set of bins.
///
/// Between two occupied bins every plane has the same cost (an empty bin changes neither
/// side's box nor its count), and the full sweep keeps the first of equal costs, which is
/// the plane just after an occupied bin. So pricing only those planes, in the same order
/// and with the same arithmetic (unions of the same boxes are exact), picks the same one.
fn split_few(
    items: &mut [Item],
    bounds: &Bounds,
    axes: &[usize],
    lo: Vec3A,
    scale: Vec3A,
) -> SplitAnswer {
    let n = items.len();
    let mut of_item = [[0u8; 3]; FEW_ITEMS];
    for (b, it) in of_item.iter_mut().zip(items.iter()) {
        *b = bins_of(it, lo, scale).map(|b| b as u8);
    }
    let mut best: Option<(f32, usize, f32)> = None; // (cost, axis, position)
    for &axis in axes {
        // Each bin's box and count, and a mask of the occupied bins; then the occupied
        // bins in order, as groups.
        let mut boxes = [Bounds::EMPTY; BINS];
        let mut counts = [0u32; BINS];
        let mut occupied = 0u32;
        for (b, it) in of_item[..n].iter().zip(items.iter()) {
            let b = b[axis] as usize;
            boxes[b].grow(Vec3A::from(it.min), Vec3A::from(it.max));
            counts[b] += 1;
            occupied |= 1 << b;
        }
        let mut groups = [(0u8, Bounds::EMPTY, 0u32); BINS];
        let mut m = 0;
        while occupied != 0 {
            let b = occupied.trailing_zeros() as usize;
            occupied &= occupied - 1;
            groups[m] = (b as u8, boxes[b], counts[b]);
            m += 1;
        }
        let groups = &groups[..m];
        let mut right_area = [0f32; BINS];
        let mut right_count = [0u32; BINS];
        let (mut acc, mut count) = (Bounds::EMPTY, 0u32);
        for g in (1..m).rev() {
            acc.grow(groups[g].1.min, groups[g].1.max);
            count += groups[g].2;
            right_area[g] = acc.half_area();
            right_count[g] = count;
        }
        let (mut acc, mut count) = (Bounds::EMPTY, 0u32);
        for g in 0..m.saturating_sub(1) {
            acc.grow(groups[g].1.min, groups[g].1.max);
            count += groups[g].2;
            let (nl, nr) = (count, right_count[g + 1]);
            let cost = acc.half_area() * nl as f32 + right_area[g + 1] * nr as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                let b = groups[g].0 as usize;
                let plane = lo[axis] + (b + 1) as f32 / scale[axis];
                best = Some((cost, axis, plane));
            }
        }
    }
    let (axis, cut) = match chosen_cut(best, bounds, n, lo, scale) {
        ControlFlow::Continue(chosen) => chosen,
        ControlFlow::Break(answer) => return answer,
    };
    // The sides by the bins already found (the same arithmetic as `split`'s partition).
    let mut goes_left = [false; FEW_ITEMS];
    for (g, b) in goes_left.iter_mut().zip(&of_item[..n]) {
        *g = (b[axis] as usize) < cut;
    }
    let (i, _) = partition_by(items, &goes_left[..n]);
    // The parts' extents: the union over their items is the union over their bins.
    let left = Extent::of(&items[..i]);
    let right = Extent::of(&items[i..]);
    (i > 0 && i < n).then_some((i, Some((left, right))))
}

/// Items from which a split bins into two sets of bins (see [`split`]): below this the
/// second set's emptying costs more than it saves.
const WIDE_BINNING: usize = 256;

/// The bins of an item's centre along the three axes: the whole part of its scaled offset
/// from `lo`, at most the last bin.
///
/// A centre lies at or above `lo` and at most a rounding above `lo + extent`, so the scaled
/// offset is in [0, BINS + 1), and its floor after the minimum is the truncation to an
/// integer the split was first written with (`as i32`, then the minimum), without the
/// conversion's range and NaN handling, which cost more than the rest of the binning. An axis
/// without extent gives NaN, which the minimum turns into the last bin (such an axis is never
/// binned). The floor plus 2^23 holds the bin in the low bits of its representation.
#[inline]
fn bins_of(it: &Item, lo: Vec3A, scale: Vec3A) -> [usize; 3] {
    let f = ((Vec3A::from(it.centre) - lo) * scale).min(Vec3A::splat((BINS - 1) as f32));
    let k = (f.floor() + Vec3A::splat(8_388_608.0)).to_array();
    k.map(|v| (v.to_bits() & 0xF) as usize)
}

/// Partitions `items` so that those for which `left` holds come first; returns how many do
/// and the boxes of the two sides' centres (left, right).
///
/// The order is that of the two-ended partition the tree was first built with (the item at
/// the front stays when it goes left, else it is swapped with the last unexamined one), so
/// the tree, its leaf order and the order of the triangles in a leaf do not change. That
/// partition reads its items as a queue: the next is the one after the front when the
/// present one went left, else the last. Sides are decided first for every item in a pass
/// without branches, then the items are moved by selects in place of a branch that went
/// either way at random.
fn partition(items: &mut [Item], left: impl Fn(&Item) -> bool) -> (usize, [Bounds; 2]) {
    let n = items.len();
    let mut small = [false; 512];
    let mut large = Vec::new();
    let sides: &mut [bool] = if n <= small.len() {
        &mut small[..n]
    } else {
        large.resize(n, false);
        &mut large
    };
    for (s, it) in sides.iter_mut().zip(items.iter()) {
        *s = left(it);
    }
    partition_by(items, sides)
}

/// [`partition`] with the sides decided: `sides[k]` tells whether the item at `k` goes left.
///
/// The loop is bound by the chain of its reads (the next item depends on the present one's
/// side), so the two boxes of centres, grown beside it by selects, cost little.
fn partition_by(items: &mut [Item], sides: &[bool]) -> (usize, [Bounds; 2]) {
    let n = items.len();
    let mut centres = [Bounds::EMPTY; 2];
    if n == 0 {
        return (0, centres);
    }
    // `i` and `j` bound the slots not yet written; the present item came from the queue's
    // front or back and its slot is one of the free ones.
    let (mut i, mut j) = (0usize, n);
    let (mut present, mut side) = (items[0], sides[0]);
    while i < j {
        let (to, from) = if side { (i, i + 1) } else { (j - 1, j - 1) };
        // The next item is read before the present one is written over it; past the end
        // (the last item placed), any slot will do.
        let from = from.min(n - 1);
        let (next, next_side) = (items[from], sides[from]);
        items[to] = present;
        let c = Vec3A::from(present.centre);
        let on_left = BVec3A::splat(side);
        let [l, r] = &mut centres;
        l.grow(
            Vec3A::select(on_left, c, Bounds::EMPTY.min),
            Vec3A::select(on_left, c, Bounds::EMPTY.max),
        );
        r.grow(
            Vec3A::select(on_left, Bounds::EMPTY.min, c),
            Vec3A::select(on_left, Bounds::EMPTY.max, c),
        );
        i += side as usize;
        j -= !side as usize;
        present = next;
        side = next_side;
    }
    (i, centres)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples;

    /// Every triangle by brute force, in f64: the oracle for the tree.
    fn brute_first_hit(mesh: &Mesh, ray: &Ray) -> Option<f64> {
        let mut best: Option<f64> = None;
        for t in 0..mesh.triangles.len() {
            if ray.skip == Some(t as u32) {
                continue;
            }
            let [a, b, c] = mesh.corners(t);
            let (e1, e2) = (b - a, c - a);
            let p = ray.direction.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-12 * e1.length() * e2.length() {
                continue;
            }
            let s = ray.origin - a;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = ray.direction.dot(q) / det;
            if u < 0.0 || v < 0.0 || u + v > 1.0 {
                continue;
            }
            let d = e2.dot(q) / det;
            if d >= ray.min_distance && d <= ray.max_distance && best.is_none_or(|b| d < b) {
                best = Some(d);
            }
        }
        best
    }

    /// A tiny deterministic generator (xorshift), so the test needs no dependency.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn unit(&mut self) -> DVec3 {
            loop {
                let v = DVec3::new(self.next(), self.next(), self.next()) * 2.0 - 1.0;
                let l = v.length();
                if l > 0.1 && l <= 1.0 {
                    return v / l;
                }
            }
        }
    }

    #[test]
    fn seeded_random_rays_match_brute_force() {
        for name in ["cover", "cap", "plate", "bracket"] {
            let mesh = samples::sample(name).unwrap();
            let bvh = Bvh::new(&mesh);
            assert_eq!(bvh.len(), mesh.triangles.len());
            let b = mesh.bounds();
            let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
            let mut hits = 0;
            for _ in 0..2000 {
                let o = b.min + (b.max - b.min) * DVec3::new(rng.next(), rng.next(), rng.next());
                let ray = Ray::new(o, rng.unit());
                let want = brute_first_hit(&mesh, &ray);
                let got = bvh.first_hit(&ray).map(|h| h.distance);
                match (want, got) {
                    (Some(w), Some(g)) => {
                        hits += 1;
                        assert!((w - g).abs() < 1e-3, "{name}: {w} vs {g} for {ray:?}");
                    }
                    (None, None) => {}
                    // The tree's edge slack may catch a ray the exact test lets through a
                    // crack-free edge; it may not invent or lose a hit otherwise.
                    _ => panic!("{name}: brute {want:?}, tree {got:?} for {ray:?}"),
                }
                assert_eq!(bvh.any_hit(&ray), got.is_some());
            }
            assert!(hits > 500, "{name}: only {hits} hits, test too weak");
        }
    }

    #[test]
    fn counting_sort_of_morton_keys_is_the_sort_of_the_keys() {
        let mut rng = Rng(0x1234_5678_9abc_def1);
        for bits in [10, 13] {
            let id_bits = index_bits(bits);
            for n in [0usize, 1, 5, 1000, 20_000] {
                // Few distinct codes in the small cases (many ties), all of them in the last.
                let spread = if n < 1000 {
                    7.0
                } else {
                    (1u64 << (3 * bits)) as f64
                };
                let mut keys: Vec<u64> = (0..n as u64)
                    .map(|i| ((rng.next() * spread) as u64) << id_bits | i)
                    .collect();
                let mut want = keys.clone();
                want.sort_unstable();
                sort_by_code(&mut keys, bits);
                assert_eq!(keys, want, "{n} keys of {bits} bits an axis");
            }
        }
    }

    #[test]
    fn a_long_part_s_morton_tree_is_cut_across_its_length_first() {
        // Points on a strip 40 long, 1 wide and 1 high (a part 40 times longer than wide):
        // the cells are cubes, so the first cuts are across x, and each of the root's
        // children holds about half the strip's length (with cells scaled to each axis, the
        // first cut was along z, each child as long as the strip).
        let mut rng = Rng(0x0bad_cafe_f00d_1234);
        let boxes: Vec<(Vec3, Vec3)> = (0..4000)
            .map(|_| {
                let p = Vec3::new(
                    40.0 * rng.next() as f32,
                    rng.next() as f32,
                    rng.next() as f32,
                );
                (p, p)
            })
            .collect();
        let (nodes, ids) = build_morton(&boxes);
        assert_eq!(ids.len(), boxes.len());
        let root = &nodes[0];
        assert_eq!(root.count, 0, "the root is split");
        let length = root.max[0] - root.min[0];
        for child in [&nodes[1], &nodes[root.link as usize]] {
            let along = child.max[0] - child.min[0];
            assert!(along < 0.6 * length, "a child {along} long of {length}");
        }
    }

    #[test]
    fn spread_bits_puts_each_bit_three_places_apart() {
        for x in [0u32, 1, 2, 0x5555, 0xaaaa, 0x1fff, 0xffff, 0x1_ffff, 0x1234] {
            let want = (0..16).fold(0u64, |acc, k| acc | ((x as u64 >> k) & 1) << (3 * k));
            assert_eq!(spread_bits(x), want, "{x:#x}");
        }
    }

    #[test]
    fn the_noted_first_subtrees_are_those_a_recount_gives() {
        // Sorted codes over several levels of large nodes (about 12 times `PARALLEL_MIN`),
        // with runs of equal codes (split half way) and a sparse top.
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut codes: Vec<u64> = (0..200_000)
            .map(|i| {
                let c = (rng.next() * (1u64 << 30) as f64) as u64;
                if i % 7 == 0 {
                    c & !0xffff
                } else {
                    c
                }
            })
            .collect();
        codes.sort_unstable();
        let (count, mut noted) = morton_count_noting(&codes, 0);
        assert_eq!(count, morton_count(&codes));
        noted.sort_unstable();
        // Every large node, found by walking the splits, is noted with its first child's
        // count, and nothing else is.
        let mut want = Vec::new();
        let mut stack = vec![(0usize, codes.len())];
        while let Some((first, len)) = stack.pop() {
            if len <= PARALLEL_MIN {
                continue;
            }
            let mid = morton_split(&codes[first..first + len]).unwrap();
            want.push(((first, len), morton_count(&codes[first..first + mid])));
            stack.push((first, mid));
            stack.push((first + mid, len - mid));
        }
        want.sort_unstable();
        assert!(want.len() > 10, "{} large nodes", want.len());
        assert_eq!(noted, want);
    }

    #[test]
    fn morton_tree_answers_as_the_surface_area_tree() {
        // The same hits to the bit (distances; the triangle named where no other triangle
        // is at that distance), first from the root and from a region, any-hit, and the
        // same nearest triangle within a radius (of equally near ones the least index), on rays and points all over and just off the
        // surface (the wall thickness's queries). The cover split twice has more than
        // `PARALLEL_MIN` triangles: its Morton tree is built in parallel, its large nodes'
        // subtrees placed by the counts noted once (checked against a recount in debug).
        let split = samples::sample("cover").unwrap().subdivided().subdivided();
        assert!(split.triangles.len() > PARALLEL_MIN);
        let meshes = samples::SAMPLES
            .iter()
            .map(|info| (info.name, samples::sample(info.name).unwrap()))
            .chain([("cover split twice", split)]);
        for (name, mesh) in meshes {
            let (sah, morton) = (Bvh::new(&mesh), Bvh::new_morton(&mesh));
            assert_eq!(morton.len(), mesh.triangles.len());
            let mut order = morton.leaf_order().to_vec();
            order.sort_unstable();
            assert!(order.iter().enumerate().all(|(i, &t)| t as usize == i));
            let b = mesh.bounds();
            let diagonal = b.diagonal();
            let mut rng = Rng(0x2545_f491_4f6c_dd1d);
            let (mut hits, mut near) = (0, 0);
            for i in 0..3000 {
                let (o, skip) = if i % 2 == 0 {
                    (
                        b.min + (b.max - b.min) * DVec3::new(rng.next(), rng.next(), rng.next()),
                        None,
                    )
                } else {
                    let t = (rng.next() * mesh.triangles.len() as f64) as usize;
                    let [a, b, c] = mesh.corners(t.min(mesh.triangles.len() - 1));
                    ((a + b + c) / 3.0, Some(t as u32))
                };
                let mut ray = Ray::new(o, rng.unit()).within(1e-6 * diagonal, f64::INFINITY);
                ray.skip = skip;
                let (want, got) = (sah.first_hit(&ray), morton.first_hit(&ray));
                assert_eq!(
                    want.map(|h| h.distance),
                    got.map(|h| h.distance),
                    "{name} {ray:?}"
                );
                hits += want.is_some() as usize;
                assert_eq!(sah.any_hit(&ray), morton.any_hit(&ray));
                let radius = rng.next() * 0.2 * diagonal;
                let region = (sah.region(o, radius), morton.region(o, radius));
                let short = ray.within(1e-6 * diagonal, radius);
                assert_eq!(
                    sah.first_hit_in(&short, &region.0).map(|h| h.distance),
                    morton.first_hit_in(&short, &region.1).map(|h| h.distance),
                );
                let (want, got) = (
                    sah.nearest_within_in(o, 0.5 * radius, &region.0),
                    morton.nearest_within_in(o, 0.5 * radius, &region.1),
                );
                assert_eq!(
                    want.map(|h| (h.triangle, h.distance)),
                    got.map(|h| (h.triangle, h.distance)),
                    "{name} {o}"
                );
                near += want.is_some() as usize;
                let (mut a, mut b) = (Vec::new(), Vec::new());
                sah.for_each_hit(&ray, |h| {
                    a.push((h.triangle, h.distance));
                    true
                });
                morton.for_each_hit(&ray, |h| {
                    b.push((h.triangle, h.distance));
                    true
                });
                a.sort_by_key(|x| x.0);
                b.sort_by_key(|x| x.0);
                assert_eq!(a, b);
            }
            assert!(
                hits > 1000 && near > 300,
                "{name}: {hits} hits, {near} near: too weak"
            );
        }
    }

    /// The binary tree the four-wide one is made from, searched as it was before the four-wide
    /// nodes (one box at a time, one triangle at a time): the oracle of the four-wide search,
    /// which must find the same distances to the bit.
    struct BinaryTree {
        nodes: Vec<Node>,
        /// Each triangle in leaf order: a corner, the two edges from it, its mesh index.
        tris: Vec<(Vec3, Vec3, Vec3, u32)>,
        origin: DVec3,
    }

    impl BinaryTree {
        fn new(mesh: &Mesh) -> BinaryTree {
            let (origin, nodes, ids) = binary_tree(mesh, Build::SurfaceArea);
            let tris = ids
                .iter()
                .map(|&t| {
                    let [a, b, c] = mesh.corners(t as usize).map(|v| (v - origin).as_vec3());
                    (a, b - a, c - a, t)
                })
                .collect();
            BinaryTree {
                nodes,
                tris,
                origin,
            }
        }

        fn slab(n: &Node, o: Vec3, inv: Vec3, t_min: f32, t_max: f32) -> bool {
            let t1 = (Vec3::from_array(n.min) - o) * inv;
            let t2 = (Vec3::from_array(n.max) - o) * inv;
            let near = t1.min(t2).max_element().max(0.0);
            let far = t1.max(t2).min_element().min(t_max);
            near <= far && far >= t_min
        }

        fn intersect((a, ab, ac, _): &(Vec3, Vec3, Vec3, u32), o: Vec3, d: Vec3) -> Option<f32> {
            let p = d.cross(*ac);
            let det = ab.dot(p);
            let min_det = 1e-7 * ab.length() * ac.length();
            if det.abs().partial_cmp(&min_det) != Some(Ordering::Greater) {
                return None;
            }
            let inv = 1.0 / det;
            let s = o - *a;
            let u = s.dot(p) * inv;
            if !(-EDGE_TOLERANCE..=1.0 + EDGE_TOLERANCE).contains(&u) {
                return None;
            }
            let q = s.cross(*ab);
            let v = d.dot(q) * inv;
            if v < -EDGE_TOLERANCE || u + v > 1.0 + EDGE_TOLERANCE {
                return None;
            }
            Some(ac.dot(q) * inv)
        }

        /// Every hit of the ray within its limits, sorted (the set the tree may report).
        fn hits(&self, ray: &Ray) -> Vec<(u32, u32)> {
            let o = (ray.origin - self.origin).as_vec3();
            let d = ray.direction.as_vec3();
            let tiny = d.abs().cmplt(Vec3::splat(TINY_COMPONENT));
            let inv = Vec3::ONE / Vec3::select(tiny, Vec3::splat(TINY_COMPONENT), d);
            let t_min = ray.min_distance as f32;
            let t_max = ray.max_distance.min(f32::MAX as f64) as f32;
            let mut out = Vec::new();
            let mut stack = vec![0usize];
            while let Some(i) = stack.pop() {
                let n = &self.nodes[i];
                if !Self::slab(n, o, inv, t_min, t_max) {
                    continue;
                }
                if n.count == 0 {
                    if self.nodes.len() > 1 {
                        stack.extend([i + 1, n.link as usize]);
                    }
                    continue;
                }
                for tri in &self.tris[n.link as usize..(n.link + n.count) as usize] {
                    if ray.skip == Some(tri.3) {
                        continue;
                    }
                    if let Some(t) = Self::intersect(tri, o, d) {
                        if t >= t_min && t <= t_max {
                            out.push((t.to_bits(), tri.3));
                        }
                    }
                }
            }
            out.sort_unstable();
            out
        }

        fn first_hit(&self, ray: &Ray) -> Option<f64> {
            self.hits(ray)
                .iter()
                .map(|h| f32::from_bits(h.0))
                .min_by(f32::total_cmp)
                .map(f64::from)
        }

        /// The nearest triangle by brute force, of equal distances the least index: what
        /// [`Bvh::nearest_within`] names, whatever the tree.
        fn nearest_named(&self, p: DVec3, radius: f64) -> Option<(u32, f64)> {
            let q = (p - self.origin).as_vec3();
            let r = radius as f32;
            self.tris
                .iter()
                .filter(|t| t.3 != NO_TRIANGLE)
                .map(|&(a, ab, ac, id)| (closest_on_triangle(a, ab, ac, q).distance_squared(q), id))
                .filter(|&(d2, _)| d2 < r * r)
                .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
                .map(|(d2, id)| (id, (d2 as f64).sqrt()))
        }

        fn nearest_within(&self, p: DVec3, radius: f64) -> Option<f64> {
            let q = (p - self.origin).as_vec3();
            let r = radius as f32;
            let best2 = self
                .tris
                .iter()
                .filter(|t| t.3 != NO_TRIANGLE)
                .map(|&(a, ab, ac, _)| closest_on_triangle(a, ab, ac, q).distance_squared(q))
                .fold(r * r, f32::min);
            (best2 < r * r).then(|| (best2 as f64).sqrt())
        }
    }

    /// A soup of random triangles of every size and shape (slivers, needles, repeats, some
    /// in axis planes), in a box of 100 mm.
    fn triangle_soup(seed: u64, n: usize) -> Mesh {
        let mut rng = Rng(seed);
        let mut mesh = Mesh::default();
        for t in 0..n {
            let centre = DVec3::new(rng.next(), rng.next(), rng.next()) * 100.0;
            let size = 10f64.powf(-2.0 + 3.0 * rng.next());
            let mut corners = [0; 3]
                .map(|_| centre + (DVec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * size);
            match t % 7 {
                0 => corners[2] = corners[0] + (corners[1] - corners[0]) * rng.next(), // no area
                1 => corners.iter_mut().for_each(|c| c.z = centre.z), // in an axis plane
                2 if t > 0 => {
                    // A repeat of the last triangle.
                    let last = mesh.triangles.len() - 1;
                    corners = mesh.corners(last);
                }
                _ => {}
            }
            let first = mesh.vertices.len() as u32;
            mesh.vertices.extend(corners);
            mesh.triangles.push([first, first + 1, first + 2]);
        }
        mesh
    }

    #[test]
    fn four_lane_closest_points_are_the_scalar_ones() {
        // Triangles of every shape (slivers, needles, points, repeats, axis planes) and
        // points near and far, in every Voronoi region: each lane's distance is the scalar
        // function's to the bit, or left to it.
        let mut mesh = triangle_soup(0x9e37_79b9_7f4a_7c15, 4000);
        let origin = mesh.bounds().centre();
        // Triangles that are points and segments, and one with a corner at infinity (its
        // packet is left to the scalar function).
        let v = mesh.vertices.len() as u32;
        mesh.vertices
            .extend([DVec3::ZERO, DVec3::X, DVec3::splat(f64::INFINITY)]);
        mesh.triangles.push([v, v + 1, v + 2]);
        for k in 0..40 {
            let v = mesh.vertices.len() as u32;
            let a = DVec3::new(k as f64, 50.0, 20.0);
            let b = if k % 2 == 0 {
                a
            } else {
                a + DVec3::new(0.5, 0.25, 0.0)
            };
            mesh.vertices.extend([a, b, a]);
            mesh.triangles.push([v, v + 1, v + 2]);
        }
        let mut rng = Rng(0x5851_f42d_4c95_7f2d);
        let (mut lanes_checked, mut left) = (0, 0);
        for first in (0..mesh.triangles.len() as u32).step_by(4) {
            let four: Vec<u32> = (first..(first + 4).min(mesh.triangles.len() as u32)).collect();
            let tri = packet(&mesh, origin, &four);
            for _ in 0..8 {
                let t = four[(rng.next() * four.len() as f64) as usize] as usize;
                let [a, b, c] = mesh.corners(t);
                let w = DVec3::new(rng.next(), rng.next(), rng.next()) * 3.0 - 1.0;
                let p = a + (b - a) * w.x + (c - a) * w.y + (rng.unit() * w.z * 3.0);
                let q = (p - origin).as_vec3();
                let (d2, scalar) = closest_distance2(&tri, &Point4::splat(q));
                for (k, &t) in four.iter().enumerate() {
                    let [a, b, c] = mesh.corners(t as usize).map(|v| (v - origin).as_vec3());
                    let want = closest_on_triangle(a, b - a, c - a, q).distance_squared(q);
                    if scalar & (1 << k) == 0 {
                        assert_eq!(d2[k].to_bits(), want.to_bits(), "triangle {t} at {q}");
                        lanes_checked += 1;
                    } else {
                        left += 1;
                    }
                }
            }
        }
        assert!(lanes_checked > 20_000 && left > 0, "{lanes_checked} {left}");
    }

    #[test]
    fn four_wide_search_finds_what_the_binary_tree_finds() {
        let mut meshes: Vec<(String, Mesh)> = ["cover", "cap", "plate", "bracket", "tray"]
            .iter()
            .map(|n| (n.to_string(), samples::sample(n).unwrap()))
            .collect();
        for (k, n) in [3, 17, 300, 5000].into_iter().enumerate() {
            meshes.push((
                format!("soup {n}"),
                triangle_soup(0x51_7cc1_b727_220a + k as u64, n),
            ));
        }
        let (mut hits, mut nears, mut partial) = (0, 0, 0);
        for (name, mesh) in &meshes {
            let bvh = Bvh::new(mesh);
            let old = BinaryTree::new(mesh);
            let b = mesh.bounds();
            let mut rng = Rng(0x2545_f491_4f6c_dd1d);
            let mut rays: Vec<Ray> = Vec::new();
            // Rays from each facet's centroid along its inverted normal, skipping the facet
            // (the wall thickness's rays, through shared edges and vertices), and random rays
            // with random limits.
            for t in (0..mesh.triangles.len()).step_by(1 + mesh.triangles.len() / 500) {
                let [a, b, c] = mesh.corners(t);
                let n = (b - a).cross(c - a).normalize_or_zero();
                if n != DVec3::ZERO {
                    rays.push(Ray::new((a + b + c) / 3.0, -n).skipping(t as u32));
                }
            }
            for k in 0..1500 {
                let o = b.min + (b.max - b.min) * DVec3::new(rng.next(), rng.next(), rng.next());
                let mut ray = Ray::new(o, rng.unit());
                if k % 3 == 1 {
                    let near = b.diagonal() * 0.5 * rng.next();
                    ray = ray.within(near, near + b.diagonal() * 0.5 * rng.next());
                }
                if k % 5 == 2 {
                    // Along an axis: direction components of zero.
                    ray.direction = [DVec3::X, -DVec3::Y, DVec3::Z][k % 3];
                }
                rays.push(ray);
            }
            for ray in &rays {
                let want = old.first_hit(ray);
                let got = bvh.first_hit(ray).map(|h| h.distance);
                assert_eq!(got, want, "{name}: {ray:?}");
                hits += usize::from(want.is_some());
                assert_eq!(bvh.any_hit(ray), want.is_some(), "{name}: {ray:?}");
                let mut all = Vec::new();
                bvh.for_each_hit(ray, |h| {
                    all.push(((h.distance as f32).to_bits(), h.triangle));
                    true
                });
                all.sort_unstable();
                assert_eq!(all, old.hits(ray), "{name}: {ray:?}");
                // The same ray from a region around its start that holds it.
                if ray.max_distance.is_finite() {
                    let region = bvh.region(ray.origin, ray.max_distance * 1.001 + 1e-3);
                    partial += usize::from(region.len > 0);
                    let inside = bvh.first_hit_in(ray, &region).map(|h| h.distance);
                    assert_eq!(inside, want, "{name}: {ray:?} in a region");
                }
            }
            for _ in 0..1000 {
                let p = b.min + (b.max - b.min) * DVec3::new(rng.next(), rng.next(), rng.next());
                let radius = b.diagonal() * 0.2 * rng.next();
                // The nearest distance, within the rounding of the plane test that rules
                // triangles out (in either tree, which of two triangles at nearly one
                // distance survives it depends on the order of the search).
                let want = old.nearest_within(p, radius);
                let got = bvh.nearest_within(p, radius);
                let close = |got: Option<f64>| match (got, want) {
                    (Some(g), Some(w)) => (g - w).abs() <= 1e-6 * w,
                    (None, None) => true,
                    (Some(g), None) => g >= radius * (1.0 - 1e-6),
                    (None, Some(w)) => w >= radius * (1.0 - 1e-6),
                };
                assert!(
                    close(got.map(|h| h.distance)),
                    "{name}: at {p}, {radius}: {got:?} {want:?}"
                );
                if let Some(h) = got {
                    nears += 1;
                    // The triangle named is at that distance.
                    let (a, ab, ac, _) =
                        old.tris[old.tris.iter().position(|t| t.3 == h.triangle).unwrap()];
                    let q = (p - old.origin).as_vec3();
                    let d2 = closest_on_triangle(a, ab, ac, q).distance_squared(q);
                    assert_eq!((d2 as f64).sqrt(), h.distance, "{name}: at {p}");
                }
                let region = bvh.region(p, radius * 1.001 + 1e-3);
                let inside = bvh.nearest_within_in(p, radius, &region);
                assert!(
                    close(inside.map(|h| h.distance)),
                    "{name}: at {p} in a region"
                );
            }
        }
        assert!(
            hits > 2000 && nears > 2000 && partial > 500,
            "{hits} {nears} {partial}"
        );
    }

    #[test]
    fn no_node_holds_only_two_leaves_that_fit_in_one() {
        // A node of two leaf lanes whose packets one leaf can hold is made one leaf: such
        // nodes were most of the tree's nodes.
        let mesh = crate::samples::sample("cover").unwrap().subdivided();
        for bvh in [Bvh::new(&mesh), Bvh::new_morton(&mesh)] {
            let fit_in_one = bvh
                .nodes
                .iter()
                .filter(|n| {
                    let kids: Vec<u32> = n.child.into_iter().filter(|&c| c != NO_CHILD).collect();
                    kids.len() == 2
                        && kids.iter().all(|&c| c & LEAF != 0)
                        && kids.iter().map(|&c| leaf_packets(c).len()).sum::<usize>()
                            <= LEAF_PACKETS
                })
                .count();
            assert_eq!(fit_in_one, 0, "{} nodes", bvh.nodes.len());
            // Fewer nodes than a third of the packets: about three lanes or more a node.
            assert!(
                3 * bvh.nodes.len() < bvh.packets.len(),
                "{} nodes, {} packets",
                bvh.nodes.len(),
                bvh.packets.len()
            );
        }
    }

    #[test]
    fn collapse_on_two_threads_makes_the_one_thread_tree() {
        let mut meshes: Vec<Mesh> = ["cover", "bracket", "tray"]
            .iter()
            .map(|n| samples::sample(n).unwrap())
            .collect();
        meshes.push(triangle_soup(0x3c6e_f372_fe94_f82b, 20_000));
        let bits = |n: &Node4| {
            let lanes = n.lo.iter().chain(&n.hi).flat_map(|v| v.to_array());
            (lanes.map(f32::to_bits).collect::<Vec<_>>(), n.child)
        };
        let mut split = 0;
        for mesh in &meshes {
            let (_, built, _) = binary_tree(mesh, Build::SurfaceArea);
            let one = Collapse::of(&built, usize::MAX);
            // Every subtree of more than 16 binary nodes split between two collapses.
            let two = Collapse::of(&built, 16);
            assert_eq!(one.root, two.root);
            assert_eq!(one.packets, two.packets);
            assert_eq!(one.leaves, two.leaves);
            let (a, b): (Vec<_>, Vec<_>) = (
                one.nodes.iter().map(bits).collect(),
                two.nodes.iter().map(bits).collect(),
            );
            assert_eq!(a, b);
            split += built.len();
        }
        assert!(split > 10_000, "{split}");
    }

    #[test]
    fn limits_and_skip_are_honoured() {
        // Plate 3 mm thick (z from 0 to 3): straight down from above.
        let mesh = samples::sample("plate").unwrap();
        let bvh = Bvh::new(&mesh);
        let down = Ray::new(DVec3::new(-30.0, 10.0, 10.0), -DVec3::Z);
        let top = bvh.first_hit(&down).unwrap();
        assert!((top.distance - 7.0).abs() < 1e-4, "{top:?}");
        let below = bvh.first_hit(&down.skipping(top.triangle)).unwrap();
        assert!((below.distance - 10.0).abs() < 1e-4, "{below:?}");
        assert!(bvh.first_hit(&down.within(0.0, 6.9)).is_none());
        let far = bvh.first_hit(&down.within(7.5, 100.0)).unwrap();
        assert!((far.distance - 10.0).abs() < 1e-4);
        // Through the hole at (20, 0): nothing.
        assert!(!bvh.any_hit(&Ray::new(DVec3::new(20.0, 0.0, 10.0), -DVec3::Z)));
    }

    #[test]
    fn rays_through_shared_edges_and_vertices_are_not_lost() {
        // The bracket's faces are split into triangles along diagonals; aim at the diagonals
        // and at the vertices of the 60 x 40 base from below.
        let mesh = samples::sample("bracket").unwrap();
        let bvh = Bvh::new(&mesh);
        for &(x, y) in &[
            (5.0, 0.0),
            (30.0, 20.0),
            (5.0, 40.0),
            (60.0, 40.0),
            (32.5, 20.0),
        ] {
            let ray = Ray::new(DVec3::new(x, y, -5.0), DVec3::Z);
            let h = bvh.first_hit(&ray);
            assert!(
                h.is_some_and(|h| (h.distance - 5.0).abs() < 1e-4),
                "{x},{y}: {h:?}"
            );
        }
    }

    #[test]
    fn nearest_matches_closed_forms() {
        let mesh = samples::sample("tray").unwrap(); // 80 x 60 x 20, pocket floor at z = 4
        let bvh = Bvh::new(&mesh);
        let h = bvh.nearest_within(DVec3::new(0.0, 0.0, 1.0), 10.0).unwrap();
        assert!((h.distance - 1.0).abs() < 1e-5, "{h:?}");
        let h = bvh.nearest_within(DVec3::new(0.0, 0.0, 9.0), 10.0).unwrap();
        assert!((h.distance - 5.0).abs() < 1e-5, "{h:?}");
        // Outside a corner: distance to the corner point (40, 30, 20).
        let p = DVec3::new(43.0, 34.0, 20.0);
        let h = bvh.nearest_within(p, 10.0).unwrap();
        assert!((h.distance - 5.0).abs() < 1e-5, "{h:?}");
        assert!(bvh.nearest_within(p, 4.9).is_none());
    }

    #[test]
    fn nearest_names_the_least_index_of_equally_near_triangles() {
        // Points at corners and edge middles of the mesh and just off them, where several
        // triangles are equally near: the tree names the brute force's triangle (the least
        // index among the nearest), from the root and from a region, as a tree of another
        // shape would.
        let (mut ties, mut named) = (0, 0);
        for name in ["cover", "cap", "bracket", "tray"] {
            let mesh = samples::sample(name).unwrap();
            let bvh = Bvh::new(&mesh);
            let old = BinaryTree::new(&mesh);
            let mut rng = Rng(0x9e37_79b9);
            for t in (0..mesh.triangles.len()).step_by(1 + mesh.triangles.len() / 300) {
                let [a, b, c] = mesh.corners(t);
                let n = (b - a).cross(c - a).normalize_or_zero();
                for p in [
                    a,
                    (a + b) * 0.5,
                    b + n * 0.3,
                    (b + c) * 0.5 - n * 0.7,
                    c - n * 2.0,
                ] {
                    let radius = 0.5 + 5.0 * rng.next();
                    let want = old.nearest_named(p, radius);
                    let got = bvh
                        .nearest_within(p, radius)
                        .map(|h| (h.triangle, h.distance));
                    assert_eq!(got, want, "{name}: at {p}, {radius}");
                    let region = bvh.region(p, radius * 1.001 + 1e-3);
                    let inside = bvh.nearest_within_in(p, radius, &region);
                    assert_eq!(
                        inside.map(|h| (h.triangle, h.distance)),
                        want,
                        "{name}: {p}"
                    );
                    if let Some((id, d)) = want {
                        named += 1;
                        let q = (p - old.origin).as_vec3();
                        let as_near = old
                            .tris
                            .iter()
                            .filter(|t| t.3 != NO_TRIANGLE && t.3 != id)
                            .any(|&(a, ab, ac, _)| {
                                let d2 = closest_on_triangle(a, ab, ac, q).distance_squared(q);
                                (d2 as f64).sqrt() == d
                            });
                        ties += usize::from(as_near);
                    }
                }
            }
        }
        assert!(
            named > 1000 && ties > 200,
            "{named} named, {ties} ties: test too weak"
        );
    }

    #[test]
    fn seeded_random_nearest_matches_brute_force() {
        for name in ["cover", "cap", "bracket"] {
            let mesh = samples::sample(name).unwrap();
            let bvh = Bvh::new(&mesh);
            let b = mesh.bounds();
            let mut rng = Rng(0x2545_f491_4f6c_dd1d);
            let mut found = 0;
            for _ in 0..500 {
                let p = b.min + (b.max - b.min) * DVec3::new(rng.next(), rng.next(), rng.next());
                let radius = 10.0 * rng.next();
                let want = (0..mesh.triangles.len())
                    .map(|t| crate::thickness::nearest_on_triangle(mesh.corners(t), p).distance(p))
                    .fold(f64::INFINITY, f64::min);
                match bvh.nearest_within(p, radius) {
                    Some(h) => {
                        found += 1;
                        assert!(
                            (h.distance - want).abs() < 1e-4,
                            "{name}: {h:?} vs {want} at {p}"
                        );
                        let mine = crate::thickness::nearest_on_triangle(
                            mesh.corners(h.triangle as usize),
                            p,
                        );
                        assert!((mine.distance(p) - want).abs() < 1e-4, "{name} at {p}");
                    }
                    None => assert!(want >= radius - 1e-4, "{name}: missed {want} < {radius}"),
                }
            }
            assert!(found > 100, "{name}: only {found} found, test too weak");
        }
    }

    #[test]
    fn stack_spills_and_refills_in_order() {
        // Pushes and pops far past the in-place entries, against a vector: last in, first
        // out, across every spill and refill.
        let (mut stack, mut model) = (Stack::new(), Vec::new());
        let mut rng = Rng(7);
        let mut deepest = 0;
        for i in 0..20_000u32 {
            if rng.next() < 0.6 {
                stack.push((i, i as f32));
                model.push((i, i as f32));
            } else {
                assert_eq!(stack.pop(), model.pop());
            }
            deepest = deepest.max(model.len());
        }
        while let Some(item) = model.pop() {
            assert_eq!(stack.pop(), Some(item));
        }
        assert_eq!(stack.pop(), None);
        assert!(deepest > 4 * STACK, "only {deepest} deep, test too weak");
    }

    #[test]
    fn queries_inside_a_region_match_the_whole_tree() {
        // Rays and nearest-point balls inside a region's ball find what the whole tree finds,
        // and the region is smaller than the whole tree (else the test proves nothing).
        let (mut hits, mut nears, mut partial) = (0, 0, 0);
        for name in ["cover", "cap", "bracket", "tray"] {
            let mesh = samples::sample(name).unwrap();
            let bvh = Bvh::new(&mesh);
            let b = mesh.bounds();
            let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
            for _ in 0..400 {
                let c = b.min + (b.max - b.min) * DVec3::new(rng.next(), rng.next(), rng.next());
                let radius = 0.1 + 4.0 * rng.next();
                let region = bvh.region(c, radius);
                partial += usize::from(region.len > 0);
                let length = radius * rng.next();
                let ray = Ray::new(c, rng.unit()).within(0.0, length);
                let whole = bvh.first_hit(&ray).map(|h| h.distance);
                assert_eq!(bvh.first_hit_in(&ray, &region).map(|h| h.distance), whole);
                hits += usize::from(whole.is_some());
                let reach = radius * rng.next();
                let whole = bvh.nearest_within(c, reach).map(|h| h.distance);
                assert_eq!(
                    bvh.nearest_within_in(c, reach, &region).map(|h| h.distance),
                    whole
                );
                nears += usize::from(whole.is_some());
            }
        }
        assert!(
            hits > 100 && nears > 100 && partial > 500,
            "{hits} {nears} {partial}"
        );
    }

    #[test]
    fn sampling_covers_the_facet_evenly() {
        let corners = [
            DVec3::ZERO,
            DVec3::new(6.0, 0.0, 0.0),
            DVec3::new(0.0, 3.0, 0.0),
        ];
        let mut points = Vec::new();
        Sampling::Centroid.for_each(corners, |p| points.push(p));
        assert_eq!(points, vec![DVec3::new(2.0, 1.0, 0.0)]);
        points.clear();
        // Longest edge sqrt(45) = 6.71 mm, so k = 4 and 16 points.
        Sampling::Spacing(2.0).for_each(corners, |p| points.push(p));
        assert_eq!(points.len(), 16);
        let mean = points.iter().sum::<DVec3>() / 16.0;
        assert!(
            (mean - DVec3::new(2.0, 1.0, 0.0)).length() < 1e-12,
            "{mean}"
        );
        for p in &points {
            assert!(p.x > 0.0 && p.y > 0.0 && p.x / 6.0 + p.y / 3.0 < 1.0, "{p}");
        }
        let mut unique = points.clone();
        unique.dedup();
        assert_eq!(unique.len(), 16);
        assert_eq!(
            Sampling::Spacing(1e-9).subdivision(corners),
            MAX_SUBDIVISION
        );
        assert_eq!(Sampling::Spacing(f64::NAN).subdivision(corners), 1);
    }

    #[test]
    fn empty_and_non_finite_inputs_give_nothing() {
        let bvh = Bvh::new(&Mesh::default());
        assert!(bvh.is_empty());
        assert!(bvh.first_hit(&Ray::new(DVec3::ZERO, DVec3::Z)).is_none());
        let bvh = Bvh::new(&samples::sample("plate").unwrap());
        assert!(bvh
            .first_hit(&Ray::new(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Z))
            .is_none());
        assert!(bvh.nearest_within(DVec3::ZERO, f64::NAN).is_none());
        assert!(bvh.nearest_within(DVec3::ZERO, -1.0).is_none());
    }

    /// The split as the tree was first built (one set of bins for every node, a branching
    /// two-ended partition): the oracle of the faster one, which must build the same tree.
    fn earlier_split(items: &mut [Item], bounds: &Bounds, centres: &Bounds) -> SplitAnswer {
        let extent = centres.max - centres.min;
        let (mut axes_of, mut n_axes) = ([0usize; 3], 0);
        for axis in 0..3 {
            if extent[axis].partial_cmp(&0.0) == Some(Ordering::Greater) {
                axes_of[n_axes] = axis;
                n_axes += 1;
            }
        }
        let axes = &axes_of[..n_axes];
        let lo = centres.min;
        let scale = Vec3A::splat(BINS as f32) / extent;
        let bin_of = |axis: usize, c: f32| (((c - lo[axis]) * scale[axis]) as usize).min(BINS - 1);
        let mut bins = [[Extent::EMPTY; BINS]; 3];
        let mut counts = [[0usize; BINS]; 3];
        for it in items.iter() {
            let b = bins_of(it, lo, scale);
            for &axis in axes {
                bins[axis][b[axis]].add(it);
                counts[axis][b[axis]] += 1;
            }
        }
        let mut best: Option<(f32, usize, f32)> = None; // (cost, axis, position)
        for &axis in axes {
            let (boxes, counts) = (&bins[axis], &counts[axis]);
            // Sweep from the right, then from the left, to price every plane between bins.
            let mut right_area = [0f32; BINS];
            let mut acc = Bounds::EMPTY;
            let mut n = 0;
            let mut right_count = [0usize; BINS];
            for b in (1..BINS).rev() {
                acc.grow(boxes[b].bounds.min, boxes[b].bounds.max);
                n += counts[b];
                right_area[b] = acc.half_area();
                right_count[b] = n;
            }
            let mut acc = Bounds::EMPTY;
            let mut n = 0;
            for b in 0..BINS - 1 {
                acc.grow(boxes[b].bounds.min, boxes[b].bounds.max);
                n += counts[b];
                let (nl, nr) = (n, right_count[b + 1]);
                if nl == 0 || nr == 0 {
                    continue;
                }
                let cost = acc.half_area() * nl as f32 + right_area[b + 1] * nr as f32;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    let plane = lo[axis] + (b + 1) as f32 / scale[axis];
                    best = Some((cost, axis, plane));
                }
            }
        }
        let Some((cost, axis, plane)) = best else {
            // Centres all equal: halve the list so that leaves stay small.
            return (items.len() > LEAF_SIZE).then_some((items.len() / 2, None));
        };
        let leaf_cost = bounds.half_area() * items.len() as f32;
        if cost >= leaf_cost && items.len() <= 4 * LEAF_SIZE {
            return None;
        }
        // Partition in place by the chosen plane, with the binning's own arithmetic.
        let cut = (((plane - lo[axis]) * scale[axis]).round()) as usize;
        let mut i = 0;
        let mut j = items.len();
        while i < j {
            let b = bin_of(axis, items[i].centre[axis]);
            if b < cut {
                i += 1;
            } else {
                j -= 1;
                items.swap(i, j);
            }
        }
        // The parts are the bins below and above the cut: their extents are the bins' unions.
        let (mut left, mut right) = (Extent::EMPTY, Extent::EMPTY);
        for (b, e) in bins[axis].iter().enumerate() {
            if b < cut {
                left.join(e);
            } else {
                right.join(e);
            }
        }
        (i > 0 && i < items.len()).then_some((i, Some((left, right))))
    }

    /// Random items: boxes of random sizes, some centres repeated, some on one plane, so
    /// that ties, empty bins and coincident centres all occur.
    fn random_items(rng: &mut Rng, n: usize) -> Vec<Item> {
        let flat = rng.next() < 0.2;
        let mut items: Vec<Item> = Vec::with_capacity(n);
        for id in 0..n {
            let item = if id > 0 && rng.next() < 0.15 {
                // A triangle repeated: the same box and centre.
                Item {
                    id: id as u32,
                    ..items[(rng.next() * id as f64) as usize]
                }
            } else {
                let c =
                    DVec3::new(rng.next(), rng.next(), if flat { 0.5 } else { rng.next() }) * 100.0;
                let half = DVec3::new(rng.next(), rng.next(), rng.next()) * 3.0;
                let (min, max) = ((c - half).as_vec3(), (c + half).as_vec3());
                Item {
                    min,
                    max,
                    centre: (min + max) * 0.5,
                    id: id as u32,
                }
            };
            items.push(item);
        }
        items
    }

    fn same_extent(a: &Extent, b: &Extent) -> bool {
        let bits = |e: &Extent| {
            [e.bounds.min, e.bounds.max, e.centres.min, e.centres.max]
                .map(|v| v.to_array().map(f32::to_bits))
        };
        bits(a) == bits(b)
    }

    #[test]
    fn split_matches_the_earlier_split() {
        let mut rng = Rng(0x5851_f42d_4c95_7f2d);
        for round in 0..600 {
            // Both sides of the few-items limit and of the two sets of bins.
            let n = match round % 4 {
                0 => 5 + (rng.next() * (FEW_ITEMS - 4) as f64) as usize,
                1 => FEW_ITEMS + 1 + (rng.next() * 100.0) as usize,
                2 => WIDE_BINNING - 2 + (rng.next() * 5.0) as usize,
                _ => 300 + (rng.next() * 3000.0) as usize,
            };
            let mut a = random_items(&mut rng, n);
            let mut b = a.clone();
            let Extent { bounds, centres } = Extent::of(&a);
            let new = split(&mut a, &bounds, &centres);
            let old = earlier_split(&mut b, &bounds, &centres);
            match (new, old) {
                (None, None) => {}
                (Some((i, None)), Some((j, None))) => assert_eq!(i, j, "round {round}"),
                (Some((i, Some((l, r)))), Some((j, Some((m, s))))) => {
                    assert_eq!(i, j, "round {round}");
                    assert!(same_extent(&l, &m) && same_extent(&r, &s), "round {round}");
                }
                (new, old) => panic!(
                    "round {round}: {:?} against {:?}",
                    new.map(|x| x.0),
                    old.map(|x| x.0)
                ),
            }
            let ids = |v: &[Item]| v.iter().map(|i| i.id).collect::<Vec<_>>();
            assert_eq!(ids(&a), ids(&b), "round {round}: the items' order");
        }
    }

    #[test]
    fn partition_keeps_the_two_ended_order() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        for n in (0..40).chain([511, 512, 513, 2000]) {
            let items = random_items(&mut rng, n.max(1))[..n].to_vec();
            let left: Vec<bool> = (0..n).map(|_| rng.next() < 0.5).collect();
            let goes_left = |it: &Item| left[it.id as usize];
            let mut a = items.clone();
            let (i, _) = partition(&mut a, goes_left);
            // The partition the tree was first built with.
            let mut b = items;
            let (mut p, mut q) = (0, n);
            while p < q {
                if goes_left(&b[p]) {
                    p += 1;
                } else {
                    q -= 1;
                    b.swap(p, q);
                }
            }
            assert_eq!(i, p, "{n} items");
            let ids = |v: &[Item]| v.iter().map(|i| i.id).collect::<Vec<_>>();
            assert_eq!(ids(&a), ids(&b), "{n} items");
        }
    }
}
