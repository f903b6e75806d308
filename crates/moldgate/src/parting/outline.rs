//! The [`PartingRule::Outline`](super::PartingRule::Outline) rule: the closed outer rim of
//! each body seen along D.
//!
//! 1. *Rim edges.* Of the edges between the two sides, those on the outline (a point just
//!    beside the edge's middle, 1e-6 of the part's diagonal away, is covered by no triangle
//!    of its body on one side) and at the **-D end** of the part there (on the covered side,
//!    no triangle of the body lies lower than the edge, by more than 1e-3 of the diagonal).
//!    A vertical band has one such edge per outline position, its -D end; the rims of grooves,
//!    ribs and thread turns seen edge-on above it are dropped.
//! 2. *Steps.* Where the -D end of the band changes height (a notch cut into a wall), the
//!    rim edges stop at both heights; the chain ends are paired, nearest first in the
//!    projection plane, and joined by the shortest path along mesh edges that stays near
//!    the segment between them in the plane (up the notch's side).
//! 3. *One cycle per body.* From each connected set of rim edges' vertex lowest in (u, w),
//!    the outer boundary of the set in the projection is walked counter-clockwise, taking at
//!    each vertex the edge that turns most to the right (the outside); edges seen end-on (a
//!    step) are walked through. Edges the walk crosses twice (a spur) are not on the cycle.
//!    Per body the cycle with the largest projected box is kept (a hole's rim lies inside
//!    the outer one). It is closed when the walk comes back to its first edge and every
//!    vertex has two of its edges.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::cover::Cover;
use super::{side_edges, PartingLine, Rim};
use crate::frame::Frame;
use crate::math::{DVec2, DVec3};
use crate::mesh::topology::{body_of_triangle, root, NO_TRIANGLE};
use crate::mesh::{Mesh, Topology};

/// Most chain ends [`bridges`] joins; past that the rim is left as found (and open).
const MAX_BRIDGED_ENDS: usize = 2000;
/// Candidates considered for each chain end when pairing them (its nearest).
const PAIRS_PER_END: usize = 8;
/// Most vertices one bridge's search visits.
const MAX_BRIDGE_VISITS: usize = 4096;
/// Most vertices all bridge searches of one line visit together.
const MAX_BRIDGE_VISITS_TOTAL: usize = 100_000;
/// How far apart in the projection plane two chain ends may be to be joined, as a share of
/// the part's diagonal (a step of the rim is a run along D: its ends are one point of the
/// plane, or nearly, for a drafted step; a gap where the outline test lost edges is
/// longer).
const BRIDGE_PLANE_REACH: f64 = 0.1;
/// How far from the segment between its ends (in the plane) a bridge may stray, as a share
/// of the diagonal: a bridge runs up a wall or along the rim, not round the part.
const BRIDGE_CORRIDOR: f64 = 1e-2;
/// Most triangles walked around one vertex each way (a fan; bounds a non-manifold tangle).
const MAX_FAN: usize = 256;

/// The parting line of `mesh` along the frame's D by the outline rule (the module's
/// documentation).
pub(super) fn outline(mesh: &Mesh, topology: &Topology, frame: &Frame) -> PartingLine {
    let edges = side_edges(mesh, topology, frame);
    if edges.is_empty() {
        return PartingLine::default();
    }
    let edges_all = edges.len();
    let at: Vec<DVec3> = mesh
        .vertices
        .par_iter()
        .map(|&p| DVec3::new(p.dot(frame.u), p.dot(frame.w), p.dot(frame.d)))
        .collect();
    let plane = |v: u32| at[v as usize].truncate();
    let body_of_tri = (topology.bodies > 1).then(|| body_of_triangle(mesh));
    let body_of_vertex = body_of_tri.as_ref().map(|body| {
        let of: Vec<AtomicU32> = (0..mesh.vertices.len())
            .map(|_| AtomicU32::new(0))
            .collect();
        mesh.triangles.par_iter().zip(body).for_each(|(tri, &b)| {
            for &v in tri {
                of[v as usize].store(b, Ordering::Relaxed);
            }
        });
        of.into_iter()
            .map(AtomicU32::into_inner)
            .collect::<Vec<u32>>()
    });
    let body_of = |v: u32| body_of_vertex.as_ref().map_or(0, |b| b[v as usize]);
    let diagonal = mesh.bounds().diagonal();
    let offset = 1e-6 * diagonal;
    let tolerance = 1e-3 * diagonal;

    // 1. Rim edges: two probe points beside each edge's middle (none for an edge seen
    // end-on, which borders nothing).
    let probes: Vec<Option<[DVec2; 2]>> = edges
        .par_iter()
        .map(|&[a, b]| {
            let (pa, pb) = (plane(a), plane(b));
            let along = pb - pa;
            let length = along.length();
            (length > offset).then(|| {
                let side = along.perp() / length * offset;
                let m = 0.5 * (pa + pb);
                [m + side, m - side]
            })
        })
        .collect();
    let cover = Cover::new(
        mesh,
        &at,
        body_of_tri.as_deref(),
        probes.iter().flatten().flatten().copied(),
    );
    let rim: Vec<[u32; 2]> = edges
        .par_iter()
        .zip(&probes)
        .filter_map(|(&[a, b], probe)| {
            let [left, right] = (*probe)?;
            let body = body_of(a);
            let lowest = match (cover.probe(left, body), cover.probe(right, body)) {
                (Some(_), Some(_)) => return None,
                (Some(h), None) | (None, Some(h)) => h,
                (None, None) => f64::INFINITY,
            };
            let height = 0.5 * (at[a as usize].z + at[b as usize].z);
            (lowest >= height - tolerance).then_some([a, b])
        })
        .collect();
    if rim.is_empty() {
        return PartingLine {
            edges_all,
            ..PartingLine::default()
        };
    }

    // 2. Steps: the chain ends joined along the mesh.
    let mut graph = rim.clone();
    let bridged = bridges(mesh, topology, &at, &rim, diagonal);
    graph.extend(bridged);
    graph.sort_unstable();
    graph.dedup();

    // 3. One cycle per body, on a compact copy of the graph: its vertices, sorted, and each
    // one's neighbours in one flat array.
    let mut verts: Vec<u32> = graph.iter().flatten().copied().collect();
    verts.sort_unstable();
    verts.dedup();
    let local = |v: u32| verts.binary_search(&v).expect("a graph vertex") as u32;
    let mut start = vec![0u32; verts.len() + 1];
    let local_edges: Vec<[u32; 2]> = graph.iter().map(|&[a, b]| [local(a), local(b)]).collect();
    for &[a, b] in &local_edges {
        start[a as usize + 1] += 1;
        start[b as usize + 1] += 1;
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut fill = start.clone();
    let mut adjacent = vec![0u32; start[verts.len()] as usize];
    for &[a, b] in &local_edges {
        for (from, to) in [(a, b), (b, a)] {
            adjacent[fill[from as usize] as usize] = to;
            fill[from as usize] += 1;
        }
    }
    let mut parent: Vec<u32> = (0..verts.len() as u32).collect();
    for &[a, b] in &local_edges {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        if ra != rb {
            parent[ra.max(rb) as usize] = ra.min(rb);
        }
    }
    let loops = (0..verts.len() as u32)
        .filter(|&i| root(&mut parent, i) == i)
        .count();
    // Each component's first vertex in (u, w, height) order.
    let mut first = std::collections::BTreeMap::<u32, u32>::new();
    let key = |i: u32| {
        let p = at[verts[i as usize] as usize];
        (p.x, p.y, p.z)
    };
    for i in 0..verts.len() as u32 {
        let component = root(&mut parent, i);
        let better = first.get(&component).is_none_or(|&j| {
            let (x, y) = (key(i), key(j));
            x.0.total_cmp(&y.0)
                .then(x.1.total_cmp(&y.1))
                .then(x.2.total_cmp(&y.2))
                .is_lt()
        });
        if better {
            first.insert(component, i);
        }
    }
    let walk = Walk {
        at: &at,
        verts: &verts,
        start: &start,
        adjacent: &adjacent,
        offset,
    };
    // Per body, the component whose walk is the outer rim: the largest projected box (a
    // hole's rim, or a feature's, lies inside the outer one), then closed before open, then
    // the longer.
    struct Found {
        cycle: Vec<[u32; 2]>,
        closed: bool,
        size: f64,
        length_mm: f64,
    }
    let mut best = std::collections::BTreeMap::<u32, Found>::new();
    for &from in first.values() {
        let (cycle, returned) = walk.outer(from);
        if cycle.is_empty() {
            continue;
        }
        let mut degree = FxHashMap::<u32, u32>::default();
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for &[a, b] in &cycle {
            *degree.entry(a).or_default() += 1;
            *degree.entry(b).or_default() += 1;
            for v in [a, b] {
                lo = lo.min(plane(v));
                hi = hi.max(plane(v));
            }
        }
        let found = Found {
            closed: returned && degree.values().all(|&d| d == 2),
            size: (hi - lo).x * (hi - lo).y,
            length_mm: cycle
                .iter()
                .map(|&[a, b]| mesh.vertices[a as usize].distance(mesh.vertices[b as usize]))
                .sum(),
            cycle,
        };
        let body = body_of(verts[from as usize]);
        let better = best.get(&body).is_none_or(|old| {
            (found.size, found.closed, found.length_mm) > (old.size, old.closed, old.length_mm)
        });
        if better {
            best.insert(body, found);
        }
    }
    let mut rims = Vec::new();
    let mut kept = Vec::new();
    for (body, found) in best {
        rims.push(Rim {
            body,
            edges: found.cycle.len(),
            length_mm: found.length_mm,
            closed: found.closed,
        });
        kept.extend(found.cycle);
    }
    kept.sort_unstable();
    PartingLine {
        closed: rims.iter().all(|r| r.closed),
        length_mm: rims.iter().map(|r| r.length_mm).sum(),
        edges_all,
        loops,
        edges: kept,
        rims,
    }
}

/// The rim graph in compact form, for the outer walk.
struct Walk<'a> {
    at: &'a [DVec3],
    /// Mesh vertex of each graph vertex.
    verts: &'a [u32],
    /// Where each graph vertex's neighbours begin in `adjacent` (one more at the end).
    start: &'a [u32],
    adjacent: &'a [u32],
    /// Projected lengths up to this are edges seen end-on (along D).
    offset: f64,
}

impl Walk<'_> {
    fn plane(&self, i: u32) -> DVec2 {
        self.at[self.verts[i as usize] as usize].truncate()
    }

    fn around(&self, v: u32) -> &[u32] {
        &self.adjacent[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }

    fn end_on(&self, a: u32, b: u32) -> bool {
        self.plane(a).distance(self.plane(b)) <= self.offset
    }

    /// The outer boundary of the component of `from` (its vertex lowest in (u, w)), walked
    /// counter-clockwise in the projection. Edges seen end-on (a step along D) are walked
    /// through: the vertices they join count as one point of the plane, and the walk leaves
    /// that point by the edge, from any of them, turning most to the right of the heading
    /// (the last edge walked; south at the start), never the way it came unless there is no
    /// other. Returns the edges crossed once, as sorted mesh vertex pairs, and whether the
    /// walk came back to its first edge.
    fn outer(&self, from: u32) -> (Vec<[u32; 2]>, bool) {
        let mut heading = DVec2::new(0.0, -1.0);
        let mut v = from;
        let mut came: Option<(u32, u32)> = None;
        let mut first: Option<(u32, u32)> = None;
        let mut crossed = FxHashMap::<[u32; 2], u32>::default();
        let mut directed = rustc_hash::FxHashSet::<(u32, u32)>::default();
        let mut order = Vec::new();
        let mut returned = false;
        // The point of v: the vertices joined to it by end-on edges, each with the vertex it
        // was reached from (a breadth-first tree).
        let mut point: Vec<(u32, u32)> = Vec::new();
        let mut cross = |a: u32, b: u32, order: &mut Vec<[u32; 2]>| {
            let (a, b) = (self.verts[a as usize], self.verts[b as usize]);
            let edge = [a.min(b), a.max(b)];
            let count = crossed.entry(edge).or_default();
            if *count == 0 {
                order.push(edge);
            }
            *count += 1;
        };
        for _ in 0..self.adjacent.len() + 2 {
            point.clear();
            point.push((v, v));
            let mut k = 0;
            while k < point.len() && point.len() < 64 {
                let (x, _) = point[k];
                for &n in self.around(x) {
                    if self.end_on(x, n) && !point.iter().any(|&(y, _)| y == n) {
                        point.push((n, x));
                    }
                }
                k += 1;
            }
            let mut best: Option<(f64, u32, u32, u32)> = None;
            let mut back = None;
            for &(x, _) in &point {
                for &n in self.around(x) {
                    if self.end_on(x, n) {
                        continue;
                    }
                    if came == Some((n, x)) {
                        back = Some((x, n));
                        continue;
                    }
                    let dir = self.plane(n) - self.plane(x);
                    let turn = heading.perp_dot(dir).atan2(heading.dot(dir));
                    let key = self.verts[n as usize];
                    if best.is_none_or(|(t, bk, _, _)| turn < t || (turn == t && key < bk)) {
                        best = Some((turn, key, x, n));
                    }
                }
            }
            let Some((x, next)) = best.map(|(_, _, x, n)| (x, n)).or(back) else {
                break;
            };
            if first == Some((x, next)) {
                returned = true;
                break;
            }
            if !directed.insert((x, next)) {
                // A walk that does not come back to its first edge (edges that cross in the
                // plane): no cycle.
                break;
            }
            first.get_or_insert((x, next));
            // Through the point from v to x, then the edge.
            let mut y = x;
            while y != v {
                let (_, up) = *point.iter().find(|&&(z, _)| z == y).expect("in the point");
                cross(up, y, &mut order);
                y = up;
            }
            cross(x, next, &mut order);
            heading = (self.plane(next) - self.plane(x)).normalize();
            came = Some((x, next));
            v = next;
        }
        let cycle = order.into_iter().filter(|e| crossed[e] == 1).collect();
        (cycle, returned)
    }
}

/// Mesh-edge paths joining the ends of the rim chains where the rim steps along D. Ends
/// (vertices with an odd number of rim edges) are paired nearest first in the projection
/// plane, within [`BRIDGE_PLANE_REACH`] there and a tenth of the diagonal in space, each with an end of another chain when
/// there is one (a chain's own two ends when it has no other left); each pair is joined by
/// the shortest path along mesh edges that stays within [`BRIDGE_CORRIDOR`] of them in the
/// plane (Dijkstra, at most [`MAX_BRIDGE_VISITS`] vertices
/// each, [`MAX_BRIDGE_VISITS_TOTAL`] in all).
fn bridges(
    mesh: &Mesh,
    topology: &Topology,
    at: &[DVec3],
    chains: &[[u32; 2]],
    diagonal: f64,
) -> Vec<[u32; 2]> {
    let mut degree = FxHashMap::<u32, u32>::default();
    let mut parent = FxHashMap::<u32, u32>::default();
    fn find(parent: &mut FxHashMap<u32, u32>, v: u32) -> u32 {
        let mut r = v;
        while let Some(&p) = parent.get(&r).filter(|&&p| p != r) {
            r = p;
        }
        parent.insert(v, r);
        r
    }
    for &[a, b] in chains {
        *degree.entry(a).or_default() += 1;
        *degree.entry(b).or_default() += 1;
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            parent.insert(ra.max(rb), ra.min(rb));
        }
    }
    let mut ends: Vec<u32> = degree
        .iter()
        .filter(|(_, &d)| d % 2 == 1)
        .map(|(&v, _)| v)
        .collect();
    ends.sort_unstable();
    if ends.len() < 2 || ends.len() > MAX_BRIDGED_ENDS {
        return Vec::new();
    }
    let reach = 0.1 * diagonal;
    let plane_reach = BRIDGE_PLANE_REACH * diagonal;
    let corridor = BRIDGE_CORRIDOR * diagonal;
    let point = |v: u32| at[v as usize];
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    let mut near: Vec<(f64, usize)> = Vec::new();
    for i in 0..ends.len() {
        near.clear();
        let p = point(ends[i]);
        for (j, &e) in ends.iter().enumerate() {
            let q = point(e);
            let apart = p.truncate().distance(q.truncate());
            if j != i && p.distance(q) <= reach && apart <= plane_reach {
                near.push((apart, j));
            }
        }
        if near.len() > PAIRS_PER_END {
            near.select_nth_unstable_by(PAIRS_PER_END, |x, y| {
                x.0.total_cmp(&y.0).then(x.1.cmp(&y.1))
            });
            near.truncate(PAIRS_PER_END);
        }
        pairs.extend(near.iter().map(|&(d, j)| (d, i.min(j), i.max(j))));
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
    pairs.dedup();
    let mut open_ends = FxHashMap::<u32, usize>::default();
    for &e in &ends {
        *open_ends.entry(find(&mut parent, e)).or_default() += 1;
    }
    let mut paired = vec![false; ends.len()];
    let mut chosen = Vec::new();
    for &(_, i, j) in &pairs {
        if paired[i] || paired[j] {
            continue;
        }
        let (ri, rj) = (find(&mut parent, ends[i]), find(&mut parent, ends[j]));
        if ri == rj && open_ends[&ri] > 2 {
            continue;
        }
        paired[i] = true;
        paired[j] = true;
        chosen.push((ends[i], ends[j]));
        if ri != rj {
            let merged = open_ends[&ri] + open_ends[&rj] - 2;
            parent.insert(ri.max(rj), ri.min(rj));
            open_ends.insert(ri.min(rj), merged);
        } else {
            open_ends.insert(ri, open_ends[&ri] - 2);
        }
    }
    if chosen.is_empty() {
        return Vec::new();
    }
    let fans = Fans::new(mesh, topology);
    let mut out = Vec::new();
    let mut budget = MAX_BRIDGE_VISITS_TOTAL;
    for (from, to) in chosen {
        if budget == 0 {
            break;
        }
        if let Some(path) = shortest_path(mesh, at, &fans, from, to, corridor, &mut budget) {
            out.extend(path.windows(2).map(|w| [w[0].min(w[1]), w[0].max(w[1])]));
        }
    }
    out
}

/// The mesh's vertex neighbours, found by walking the triangles around a vertex through the
/// topology's neighbour table (no adjacency list is built).
struct Fans<'a> {
    mesh: &'a Mesh,
    topology: &'a Topology,
    /// Per vertex, the smallest triangle that has it.
    triangle: Vec<u32>,
}

impl<'a> Fans<'a> {
    fn new(mesh: &'a Mesh, topology: &'a Topology) -> Fans<'a> {
        let triangle: Vec<AtomicU32> = (0..mesh.vertices.len())
            .map(|_| AtomicU32::new(u32::MAX))
            .collect();
        mesh.triangles.par_iter().enumerate().for_each(|(t, tri)| {
            for &v in tri {
                triangle[v as usize].fetch_min(t as u32, Ordering::Relaxed);
            }
        });
        Fans {
            mesh,
            topology,
            triangle: triangle.into_iter().map(AtomicU32::into_inner).collect(),
        }
    }

    /// Calls `f` with each neighbour of `v` in its fan of triangles (most twice).
    fn each(&self, v: u32, mut f: impl FnMut(u32)) {
        let t0 = self.triangle[v as usize];
        if t0 == u32::MAX {
            return;
        }
        let corner = |t: u32| {
            let tri = self.mesh.triangles[t as usize];
            (tri, tri.iter().position(|&x| x == v))
        };
        // Forward across the edge from v to its next corner, then, if that ends at an open
        // edge, backward across the edge into v.
        for forward in [true, false] {
            let mut t = t0;
            for _ in 0..MAX_FAN {
                let (tri, Some(k)) = corner(t) else { break };
                if forward || t != t0 {
                    f(tri[(k + 1) % 3]);
                    f(tri[(k + 2) % 3]);
                }
                let edge = if forward { k } else { (k + 2) % 3 };
                let n = self.topology.neighbours(t as usize)[edge];
                if n == NO_TRIANGLE {
                    break;
                }
                if n == t0 {
                    return;
                }
                t = n;
            }
        }
    }
}

/// A finite f64 ordered for the heap.
#[derive(Clone, Copy, PartialEq)]
struct OrdF64(f64);
impl Eq for OrdF64 {}
impl PartialOrd for OrdF64 {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for OrdF64 {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// The shortest path along mesh edges from `from` to `to`, as vertices, or `None` when not
/// found within [`MAX_BRIDGE_VISITS`] vertices (or the shared `budget`).
fn shortest_path(
    mesh: &Mesh,
    at: &[DVec3],
    fans: &Fans,
    from: u32,
    to: u32,
    corridor: f64,
    budget: &mut usize,
) -> Option<Vec<u32>> {
    let (a, b) = (at[from as usize].truncate(), at[to as usize].truncate());
    let inside = |v: u32| {
        let p = at[v as usize].truncate();
        let ab = b - a;
        let t = if ab.length_squared() > 0.0 {
            ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        p.distance(a + ab * t) <= corridor
    };
    let mut best = FxHashMap::<u32, (f64, u32)>::default();
    let mut heap = BinaryHeap::new();
    best.insert(from, (0.0, from));
    heap.push(Reverse((OrdF64(0.0), from)));
    let mut visits = 0;
    while let Some(Reverse((OrdF64(d), v))) = heap.pop() {
        if d > best[&v].0 {
            continue;
        }
        if v == to {
            let mut path = vec![to];
            let mut at = to;
            while at != from {
                at = best[&at].1;
                path.push(at);
            }
            return Some(path);
        }
        visits += 1;
        if visits > MAX_BRIDGE_VISITS || *budget == 0 {
            return None;
        }
        *budget -= 1;
        let p = mesh.vertices[v as usize];
        fans.each(v, |n| {
            if !inside(n) {
                return;
            }
            let nd = d + p.distance(mesh.vertices[n as usize]);
            if best.get(&n).is_none_or(|&(old, _)| nd < old) {
                best.insert(n, (nd, v));
                heap.push(Reverse((OrdF64(nd), n)));
            }
        });
    }
    None
}
