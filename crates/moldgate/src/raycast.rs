//! Rays in any direction through a mesh: a bounding volume hierarchy (BVH) over its triangles.
//!
//! The projection of [`crate::gate`] casts only rays parallel to D and draws triangles into
//! them instead; the rays here go anywhere (along a facet's inverted normal for the wall
//! thickness, along ±D from every facet for undercuts), so they need a tree of boxes.
//!
//! The tree is built once per mesh with a binned surface-area heuristic (12 bins per axis,
//! leaves of at most 4 triangles; the top levels are built on both threads; the three axes
//! are binned in one pass over a node's triangles, and a child's box comes from the union of
//! its parent's bins, so each level reads its triangles twice: bins, then partition). Boxes and
//! triangles are stored in `f32`, relative to the centre of the mesh's box, to halve the
//! memory read per ray; queries take and return `f64`. The tree knows only boxes and triangle
//! numbers: what a hit means (wall, undercut) is the caller's business. The finished tree
//! keeps the two children of a node side by side in one 64-byte cache line, so a step of the
//! descent, which tests both boxes, reads one line; each triangle carries its mesh index.
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

use glam::{Vec3, Vec3A};
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
/// Bins per axis of the surface-area heuristic.
const BINS: usize = 12;
/// Subtrees with more triangles than this are built on another thread (the top levels only).
const PARALLEL_MIN: usize = 16_384;

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

/// The two children of an interior node, side by side in one cache line: a traversal that
/// tests both boxes reads one line instead of two. The root is the first node of the first
/// pair (the second is unused).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Pair([Node; 2]);

/// A triangle in leaf order: a corner and the two edges from it, relative to the tree's
/// origin, and its index in the mesh.
#[derive(Debug, Clone, Copy)]
struct Tri {
    a: Vec3,
    ab: Vec3,
    ac: Vec3,
    /// Smallest |determinant| of a hit, relative to the edges' lengths (see [`intersect`]):
    /// kept here so that the test needs no square root.
    min_det: f32,
    /// Index of the triangle in the mesh.
    id: u32,
}

/// A bounding volume hierarchy over the triangles of a mesh.
#[derive(Debug, Clone)]
pub struct Bvh {
    origin: DVec3,
    /// The nodes, two by two: node k is `pairs[k / 2].0[k % 2]`.
    pairs: Vec<Pair>,
    tris: Vec<Tri>,
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

impl Bvh {
    /// Builds the tree over every triangle of `mesh`.
    pub fn new(mesh: &Mesh) -> Bvh {
        let origin = mesh.bounds().centre();
        let origin = if origin.is_finite() {
            origin
        } else {
            DVec3::ZERO
        };
        let local = |v: DVec3| (v - origin).as_vec3();
        let mut items: Vec<Item> = (0..mesh.triangles.len())
            .into_par_iter()
            .map(|t| {
                let [a, b, c] = mesh.corners(t).map(local);
                let min = a.min(b).min(c);
                let max = a.max(b).max(c);
                if !(min.is_finite() && max.is_finite()) {
                    // A corner not finite: the triangle can never be hit (its test gives
                    // NaN); an empty box keeps NaN and infinity out of the boxes' unions.
                    return Item {
                        min: Vec3::INFINITY,
                        max: Vec3::NEG_INFINITY,
                        centre: Vec3::ZERO,
                        id: t as u32,
                    };
                }
                Item {
                    min,
                    max,
                    centre: (min + max) * 0.5,
                    id: t as u32,
                }
            })
            .collect();
        let mut nodes = if items.is_empty() {
            vec![Node {
                min: [f32::INFINITY; 3],
                link: 0,
                max: [f32::NEG_INFINITY; 3],
                count: 0,
            }]
        } else {
            build(&mut items, 0, None)
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
        let ids: Vec<u32> = items.iter().map(|i| i.id).collect();
        let tris = ids
            .par_iter()
            .map(|&t| {
                let [a, b, c] = mesh.corners(t as usize).map(local);
                let (ab, ac) = (b - a, c - a);
                Tri {
                    a,
                    ab,
                    ac,
                    min_det: 1e-7 * ab.length() * ac.length(),
                    id: t,
                }
            })
            .collect();
        Bvh {
            origin,
            pairs: pair_up(&nodes),
            tris,
            ids,
        }
    }

    /// Node `k` of the finished tree.
    #[inline]
    fn node(&self, k: u32) -> &Node {
        &self.pairs[(k >> 1) as usize].0[(k & 1) as usize]
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
        let whole = Region::WHOLE;
        if self.ids.is_empty() || !centre.is_finite() || !radius.is_finite() {
            return whole;
        }
        let c = Vec3A::from((centre - self.origin).as_vec3());
        let r = radius as f32;
        let (r2, size) = (r * r, 4.0 * r);
        let mut region = Region {
            starts: [0; REGION_STARTS],
            len: 0,
        };
        let mut stack = [0u32; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let k = stack[top];
            let node = self.node(k);
            if box_distance2(node, c) > r2 {
                continue;
            }
            let extent = Vec3A::from_array(node.max) - Vec3A::from_array(node.min);
            if node.count > 0 || extent.max_element() <= size {
                if region.len == REGION_STARTS {
                    return whole;
                }
                region.starts[region.len] = k;
                region.len += 1;
                continue;
            }
            if top + 2 > stack.len() {
                return whole;
            }
            stack[top] = node.link + 1;
            stack[top + 1] = node.link;
            top += 2;
        }
        region
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
        self.traverse(ray, region.starts(), |hit| {
            best = Some(hit);
            // Shorten the ray: only nearer hits matter from now on.
            Some(hit.distance)
        });
        best
    }

    /// Whether `ray` hits anything within its limits (stops at the first hit found).
    pub fn any_hit(&self, ray: &Ray) -> bool {
        let mut found = false;
        self.traverse(ray, &[0], |_| {
            found = true;
            None
        });
        found
    }

    /// Calls `f` with every hit of `ray` within its limits, in no particular order, until `f`
    /// returns `false`.
    pub fn for_each_hit(&self, ray: &Ray, mut f: impl FnMut(Hit) -> bool) {
        let limit = ray.max_distance;
        self.traverse(ray, &[0], |hit| f(hit).then_some(limit));
    }

    /// Walks the subtrees `starts` (the root: `&[0]`) nearest box first. `on_hit` gets every
    /// hit nearer than the current limit and returns the new limit, or `None` to stop.
    fn traverse(&self, ray: &Ray, starts: &[u32], mut on_hit: impl FnMut(Hit) -> Option<f64>) {
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
        let inv = Vec3A::from(Vec3::ONE / Vec3::select(tiny, Vec3::splat(TINY_COMPONENT), d));
        let oa = Vec3A::from(o);
        let t_min = ray.min_distance as f32;
        let mut t_max = ray.max_distance.min(f32::MAX as f64) as f32;
        let mut stack = [0u32; 64];
        let mut top = 0usize;
        // The starts wait on the stack, the first on top so that it is searched first.
        for &k in starts.iter().rev() {
            stack[top] = k;
            top += 1;
        }
        'pop: loop {
            // Pop the next box, skipping those now beyond the shortened ray.
            let mut node = loop {
                if top == 0 {
                    return;
                }
                top -= 1;
                let candidate = stack[top];
                if slab(self.node(candidate), oa, inv, t_min, t_max).is_some() {
                    break candidate;
                }
            };
            loop {
                let n = self.node(node);
                if n.count > 0 {
                    let first = n.link as usize;
                    for tri in &self.tris[first..first + n.count as usize] {
                        let id = tri.id;
                        if ray.skip == Some(id) {
                            continue;
                        }
                        if let Some(t) = intersect(tri, o, d) {
                            if t >= t_min && t <= t_max {
                                match on_hit(Hit {
                                    triangle: id,
                                    distance: t as f64,
                                }) {
                                    Some(limit) => t_max = limit as f32,
                                    None => return,
                                }
                            }
                        }
                    }
                } else {
                    let left = n.link;
                    let right = left + 1;
                    let [l, r] = &self.pairs[(left >> 1) as usize].0;
                    let tl = slab(l, oa, inv, t_min, t_max);
                    let tr = slab(r, oa, inv, t_min, t_max);
                    match (tl, tr) {
                        (Some(a), Some(b)) => {
                            let (near, far) = if a <= b { (left, right) } else { (right, left) };
                            if top < stack.len() {
                                stack[top] = far;
                                top += 1;
                            }
                            node = near;
                            continue;
                        }
                        (Some(_), None) => {
                            node = left;
                            continue;
                        }
                        (None, Some(_)) => {
                            node = right;
                            continue;
                        }
                        (None, None) => {}
                    }
                }
                continue 'pop;
            }
        }
    }

    /// The triangle nearest to `p` among those nearer than `radius`, with its distance; `None`
    /// when no triangle comes within `radius`.
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
        let qa = Vec3A::from(q);
        let r = radius.min(f32::MAX as f64) as f32;
        let mut best2 = r * r;
        let mut best: Option<u32> = None;
        let mut stack = [0u32; 64];
        let starts = region.starts();
        let mut top = starts.len();
        for (slot, &k) in stack.iter_mut().zip(starts.iter().rev()) {
            *slot = k;
        }
        while top > 0 {
            top -= 1;
            let node = self.node(stack[top]);
            if box_distance2(node, qa) >= best2 {
                continue;
            }
            if node.count > 0 {
                let first = node.link as usize;
                for tri in &self.tris[first..first + node.count as usize] {
                    // A triangle whose plane is no nearer than the best so far cannot be
                    // nearer itself: most are ruled out so, without the full search.
                    let n = tri.ab.cross(tri.ac);
                    let (h, nn) = (n.dot(q - tri.a), n.length_squared());
                    if nn > 0.0 && h * h >= best2 * nn {
                        continue;
                    }
                    let d2 = closest_on_triangle(tri, q).distance_squared(q);
                    if d2 < best2 {
                        best2 = d2;
                        best = Some(tri.id);
                    }
                }
            } else {
                let left = node.link;
                let right = left + 1;
                let [l, r] = &self.pairs[(left >> 1) as usize].0;
                let (dl, dr) = (box_distance2(l, qa), box_distance2(r, qa));
                // Push the farther child first so the nearer is searched first.
                let order = if dl <= dr {
                    [right, left]
                } else {
                    [left, right]
                };
                for c in order {
                    if top < stack.len() {
                        stack[top] = c;
                        top += 1;
                    }
                }
            }
        }
        best.map(|triangle| Hit {
            triangle,
            distance: (best2 as f64).sqrt(),
        })
    }
}

/// Most subtrees of a [`Region`].
const REGION_STARTS: usize = 16;

/// Subtrees of a [`Bvh`] that hold every triangle meeting a ball ([`Bvh::region`]): a query
/// that stays in the ball starts from them and is spared the descent from the root, which is
/// most of the cost of a short ray.
#[derive(Debug, Clone, Copy)]
pub struct Region {
    starts: [u32; REGION_STARTS],
    len: usize,
}

impl Region {
    /// The whole tree (its root).
    pub const WHOLE: Region = Region {
        starts: [0; REGION_STARTS],
        len: 1,
    };

    fn starts(&self) -> &[u32] {
        &self.starts[..self.len]
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
    pub fn for_each(self, corners: [DVec3; 3], mut f: impl FnMut(DVec3)) {
        let [a, b, c] = corners;
        let k = self.subdivision(corners);
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

/// Squared distance from `q` to the node's box (0 inside).
#[inline]
fn box_distance2(n: &Node, q: Vec3A) -> f32 {
    let min = Vec3A::from_array(n.min);
    let max = Vec3A::from_array(n.max);
    let d = (min - q).max(q - max).max(Vec3A::ZERO);
    d.length_squared()
}

/// Entry distance of the ray into the node's box, if it enters before `t_max`; `inv` is the
/// inverse of the direction with tiny components raised (see [`TINY_COMPONENT`]). A box left
/// before `t_min` (the ray's `min_distance`) is passed as well: it holds no hit that counts.
#[inline]
fn slab(n: &Node, o: Vec3A, inv: Vec3A, t_min: f32, t_max: f32) -> Option<f32> {
    // Four-lane arithmetic (the fourth lane unused): one instruction per step, and min / max
    // without the NaN rules of `f32::min`, which no operand here can be (finite inverse).
    let t1 = (Vec3A::from_array(n.min) - o) * inv;
    let t2 = (Vec3A::from_array(n.max) - o) * inv;
    let near = t1.min(t2).max_element().max(0.0);
    let far = t1.max(t2).min_element().min(t_max);
    (near <= far && far >= t_min).then_some(near)
}

/// Möller-Trumbore with the barycentric slack of [`EDGE_TOLERANCE`]; the distance along the
/// ray, or `None` when the ray misses or runs parallel to the triangle.
#[inline]
fn intersect(tri: &Tri, o: Vec3, d: Vec3) -> Option<f32> {
    let p = d.cross(tri.ac);
    let det = tri.ab.dot(p);
    // Relative test: edge-on (or area-less) triangles are never hit.
    if det.abs().partial_cmp(&tri.min_det) != Some(Ordering::Greater) {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - tri.a;
    let u = s.dot(p) * inv;
    if !(-EDGE_TOLERANCE..=1.0 + EDGE_TOLERANCE).contains(&u) {
        return None;
    }
    let q = s.cross(tri.ab);
    let v = d.dot(q) * inv;
    if v < -EDGE_TOLERANCE || u + v > 1.0 + EDGE_TOLERANCE {
        return None;
    }
    Some(tri.ac.dot(q) * inv)
}

/// The point of the triangle nearest to `p` (Ericson, *Real-Time Collision Detection*, 5.1.5).
fn closest_on_triangle(tri: &Tri, p: Vec3) -> Vec3 {
    let (a, ab, ac) = (tri.a, tri.ab, tri.ac);
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
    let mut nodes = Vec::with_capacity(2 * items.len() / LEAF_SIZE + 1);
    build_into(items, first, &mut nodes, known);
    nodes
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
    let Some((mid, sides)) = split(items, &bounds, &centres) else {
        return; // Every centre in one place: a (large) leaf is the only way.
    };
    let (l_known, r_known) = match sides {
        Some((l, r)) => (Some(l), Some(r)),
        None => (None, None),
    };
    let (left, right) = items.split_at_mut(mid);
    nodes[me].count = 0;
    if left.len() + right.len() > PARALLEL_MIN {
        let (l, r) = join(
            || build(left, first, l_known),
            || build(right, first + mid, r_known),
        );
        let base = nodes.len();
        append(nodes, l, base);
        nodes[me].link = nodes.len() as u32;
        let base = nodes.len();
        append(nodes, r, base);
    } else {
        build_into(left, first, nodes, l_known);
        nodes[me].link = nodes.len() as u32;
        build_into(right, first + mid, nodes, r_known);
    }
}

/// The finished tree from the built one (each interior node followed by its first child,
/// `link` naming its second): the same nodes, in depth-first order of their pairs of
/// children, with `link` naming the pair.
fn pair_up(built: &[Node]) -> Vec<Pair> {
    let mut pairs = Vec::with_capacity(built.len() / 2 + 1);
    pairs.push(Pair([built[0], built[0]]));
    // (index in `built`, node number in the finished tree) of interior nodes to expand.
    let mut todo = vec![(0usize, 0u32)];
    while let Some((old, new)) = todo.pop() {
        let n = built[old];
        // A leaf, or the empty tree's root (no triangle, no children).
        if n.count > 0 || built.len() == 1 {
            continue;
        }
        let (left, right) = (old + 1, n.link as usize);
        let k = pairs.len() as u32;
        pairs.push(Pair([built[left], built[right]]));
        pairs[(new >> 1) as usize].0[(new & 1) as usize].link = 2 * k;
        // Right first, so that the left subtree's pairs come next (depth first).
        todo.push((right, 2 * k + 1));
        todo.push((left, 2 * k));
    }
    pairs
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
    // The bin of a centre along an axis. A centre lies at or above `lo` and at most a
    // rounding above `lo + extent`, so the scaled offset is in [0, BINS + 1) and its
    // conversion to `i32` is the conversion to `usize` the split was first written with,
    // without the latter's range handling.
    let bin_of =
        |axis: usize, c: f32| (((c - lo[axis]) * scale[axis]) as i32).min(BINS as i32 - 1) as usize;
    let mut bins = [[Extent::EMPTY; BINS]; 3];
    let mut counts = [[0u32; BINS]; 3];
    if items.len() >= WIDE_BINNING && n_axes == 3 {
        // Neighbouring items mostly fall into the same bins, so one set of bins is a chain
        // of dependent minima through memory; two sets, one for the even and one for the
        // odd items, break it. Minima and maxima are exact, so their union is the one set.
        let mut odd = [[Extent::EMPTY; BINS]; 3];
        let mut pairs = items.chunks_exact(2);
        for pair in &mut pairs {
            let (p, q) = (&pair[0], &pair[1]);
            let (bp, bq) = (bins_of(p, lo, scale), bins_of(q, lo, scale));
            for axis in 0..3 {
                bins[axis][bp[axis]].add(p);
                odd[axis][bq[axis]].add(q);
                counts[axis][bp[axis]] += 1;
                counts[axis][bq[axis]] += 1;
            }
        }
        for it in pairs.remainder() {
            let b = bins_of(it, lo, scale);
            for axis in 0..3 {
                bins[axis][b[axis]].add(it);
                counts[axis][b[axis]] += 1;
            }
        }
        for (set, other) in bins.iter_mut().zip(&odd) {
            for (e, o) in set.iter_mut().zip(other) {
                e.join(o);
            }
        }
    } else {
        for it in items.iter() {
            for &axis in axes {
                let b = bin_of(axis, it.centre[axis]);
                bins[axis][b].add(it);
                counts[axis][b] += 1;
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
            acc.grow(boxes[b].bounds.min, boxes[b].bounds.max);
            n += counts[b];
            right_area[b] = acc.half_area();
            right_count[b] = n;
        }
        let mut acc = Bounds::EMPTY;
        let mut n = 0u32;
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
    let (axis, cut) = match chosen_cut(best, bounds, items.len(), lo, scale) {
        ControlFlow::Continue(chosen) => chosen,
        ControlFlow::Break(answer) => return answer,
    };
    // Partition in place by the chosen plane, with the binning's own arithmetic.
    let i = partition(items, |it| bin_of(axis, it.centre[axis]) < cut);
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
    let i = partition_by(items, &goes_left[..n]);
    // The parts' extents: the union over their items is the union over their bins.
    let left = Extent::of(&items[..i]);
    let right = Extent::of(&items[i..]);
    (i > 0 && i < n).then_some((i, Some((left, right))))
}

/// Items from which a split bins into two sets of bins (see [`split`]): below this the
/// second set's emptying costs more than it saves.
const WIDE_BINNING: usize = 256;

/// The bins of an item's centre along the three axes, as [`split`]'s `bin_of` gives them
/// (the same lane-wise arithmetic, so the same bins).
#[inline]
fn bins_of(it: &Item, lo: Vec3A, scale: Vec3A) -> [usize; 3] {
    let f = (Vec3A::from(it.centre) - lo) * scale;
    let last = BINS as i32 - 1;
    [
        (f.x as i32).min(last) as usize,
        (f.y as i32).min(last) as usize,
        (f.z as i32).min(last) as usize,
    ]
}

/// Partitions `items` so that those for which `left` holds come first; returns how many do.
///
/// The order is that of the two-ended partition the tree was first built with (the item at
/// the front stays when it goes left, else it is swapped with the last unexamined one), so
/// the tree, its leaf order and the order of the triangles in a leaf do not change. That
/// partition reads its items as a queue: the next is the one after the front when the
/// present one went left, else the last. Sides are decided first for every item in a pass
/// without branches, then the items are moved by selects in place of a branch that went
/// either way at random.
fn partition(items: &mut [Item], left: impl Fn(&Item) -> bool) -> usize {
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
fn partition_by(items: &mut [Item], sides: &[bool]) -> usize {
    let n = items.len();
    if n == 0 {
        return 0;
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
        i += side as usize;
        j -= !side as usize;
        present = next;
        side = next_side;
    }
    i
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
                partial += usize::from(region.starts() != [0]);
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
            hits > 100 && nears > 100 && partial > 1000,
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
            for &axis in axes {
                let b = bin_of(axis, it.centre[axis]);
                bins[axis][b].add(it);
                counts[axis][b] += 1;
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
            let i = partition(&mut a, goes_left);
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
