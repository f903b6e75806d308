//! The [`PartingRule::Outline`](super::PartingRule::Outline) rule: the closed outer rim of
//! each body seen along D.
//!
//! 1. *Rim edges.* Of the edges between the two sides, those on the body's outline seen
//!    along D and at the part's **+D end** there (`outside.rs`: the body's edges between the
//!    sides drawn into a raster of its projection, the outside flooded from the border). A
//!    vertical band has one such edge per outline position, its +D end; the rims of holes,
//!    grooves, ribs and thread turns, inside the outline or below its +D end, are not rim
//!    edges.
//! 2. *One cycle per body.* The rim edges are not always one chain: where the +D end of a
//!    wall steps along D (a notch, a tab standing out of a wall) the rim runs up the step on
//!    edges that join no two sides, and on finely tessellated rounded corners a few rim edges
//!    fall a cell inside the outline. So the cycle is the cheapest closed path round the
//!    outline on the mesh's own edges, through the vertices that lie near the rim edges seen
//!    along D (the *band*: within [`BAND_CELLS`] cells of a cell a rim edge passes through,
//!    which takes in the walls along D standing on the outline; measured from the rim edges
//!    rather than from the outside, so that a rim edge a little farther in, behind a tab
//!    standing out of a wall by about the band's width, stays in the band and the band does
//!    not break there): a rim edge costs its length, any other edge
//!    [`OFF_RIM_COST`] times its length. The path must go round once: the band is cut at
//!    its leftmost rim vertex s along the line through s parallel to the plane's u axis, the
//!    shortest paths from s are found on the cut band (Dijkstra), and the cycle is the
//!    cheapest of the cut edges with the two paths to its ends, from where they part. It is
//!    closed and simple by construction (two branches of one shortest-path tree and an
//!    edge).

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicU8, Ordering};

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::outside::{Outside, Segment};
use super::{find, longest_loop, side_edges, PartingLine, Rim};
use crate::frame::Frame;
use crate::math::DVec2;
use crate::mesh::topology::{body_of_vertex, NO_TRIANGLE};
use crate::mesh::{Mesh, Topology};

/// Faces whose normal is within this (as n.D for the unit normal) of the plane are walls
/// along D, of the fixed half: the f32 coordinates of a mesh file tilt a wall drawn along
/// D by up to about 1e-4 on small facets, and such noise must not split a wall into strips
/// of both sides. A wall drafted by 0.06 degrees or more is classed by its facing.
const WALL_TILT: f64 = 1e-3;
/// The band round the outline the cycle may use, in raster cells from the rim edges' cells.
const BAND_CELLS: usize = 3;
/// Most rim edges tried as the place to cut the band, per body.
const START_TRIES: usize = 4;
/// The cost of a step along an edge that is not a rim edge, per mm, against 1 on a rim
/// edge: the cycle leaves the rim only where it must (up a step, over a lost rim edge).
const OFF_RIM_COST: f64 = 4.0;

/// The parting line of `mesh` along the frame's D by the outline rule (the module's
/// documentation).
pub(super) fn outline(mesh: &Mesh, topology: &Topology, frame: &Frame) -> PartingLine {
    let edges = side_edges(mesh, topology, frame, WALL_TILT);
    if edges.is_empty() {
        return PartingLine::default();
    }
    let edges_all = edges.len();
    // Frame coordinates are computed where they are needed rather than stored for every
    // vertex: a copy of the whole mesh's vertices (24 bytes each) would add to the peak
    // memory of `locate`, which runs this beside the rays.
    let plane = |v: u32| {
        let p = mesh.vertices[v as usize];
        DVec2::new(p.dot(frame.u), p.dot(frame.w))
    };
    // Depth below the part's +D end (less is nearer it): the rim is the +D end of a wall.
    let depth = |v: u32| -mesh.vertices[v as usize].dot(frame.d);
    // Each vertex's body (one array of the vertices' size, see `body_of_vertex`), and each
    // body's triangles (a counting sort by the body of their first corner), so that a
    // body's band reads its own triangles only and a part of many bodies is read once, not
    // once a body; with marks of the vertices near the outline, shared by the bodies (no
    // two bodies share a vertex).
    let body_of_vertex = (topology.bodies > 1).then(|| body_of_vertex(mesh));
    let body_of = |v: u32| body_of_vertex.as_ref().map_or(0, |b| b[v as usize]);
    let by_body = body_of_vertex.as_ref().map(|b| {
        // The bodies' count from the vertices in order (a vertex of no triangle is body 0),
        // not from a pass over the triangles' corners.
        let bodies = b.iter().max().map_or(0, |&m| m as usize + 1);
        Groups::of((mesh.triangles.len(), bodies), |t| {
            b[mesh.triangles[t][0] as usize]
        })
    });
    let marks: Vec<AtomicU8> = match by_body {
        Some(_) => (0..mesh.vertices.len()).map(|_| AtomicU8::new(0)).collect(),
        None => Vec::new(),
    };
    let tolerance = 1e-3 * mesh.bounds().diagonal();
    let segment = |[a, b]: [u32; 2]| Segment {
        a: plane(a),
        b: plane(b),
        depth_a: depth(a),
        depth_b: depth(b),
    };
    let mut order: Vec<u32> = (0..edges.len() as u32).collect();
    if body_of_vertex.is_some() {
        order.sort_by_key(|&e| body_of(edges[e as usize][0]));
    }
    // Each body's raster: the full one unless the part has very many bodies.
    let cells = super::outside::cells_for(by_body.as_ref().map_or(1, Groups::len));
    let mut all_rim: Vec<[u32; 2]> = Vec::new();
    let mut rims = Vec::new();
    let mut kept = Vec::new();
    for group in
        order.chunk_by(|&x, &y| body_of(edges[x as usize][0]) == body_of(edges[y as usize][0]))
    {
        let body = body_of(edges[group[0] as usize][0]);
        // 1. Rim edges.
        // The segments are made from the edges where they are needed, not stored: an array
        // of them (48 bytes an edge) would be held beside the rays.
        let mut raster =
            Outside::with_cells(group.iter().map(|&e| segment(edges[e as usize])), cells);
        let (mut rim, rim_segments): (Vec<[u32; 2]>, Vec<Segment>) = group
            .par_iter()
            .map(|&e| (edges[e as usize], segment(edges[e as usize])))
            .filter(|(_, s)| raster.on_rim(s, tolerance))
            .unzip();
        if rim.is_empty() {
            // No edge of the body's on its outline at its +D end: its longest loop.
            let (cycle, rim_of, _) =
                longest_loop(mesh, group.iter().map(|&e| edges[e as usize]), body);
            rims.push(rim_of);
            kept.extend(cycle);
            continue;
        }
        rim.sort_unstable();
        // 2. The cycle round the band.
        raster.rims_found();
        raster.mark_band(&rim_segments, BAND_CELLS);
        drop(rim_segments);
        let near = |p: DVec2| raster.in_band(p);
        let scope = match &by_body {
            Some(groups) => Scope::Body {
                triangles: groups.of_body(body),
                marks: &marks,
            },
            None => Scope::Whole,
        };
        let band = Band::new(mesh, topology, &plane, scope, &near, &rim);
        let projected = |edges: &[[u32; 2]]| -> f64 {
            edges
                .iter()
                .map(|&[a, b]| plane(a).distance(plane(b)))
                .sum()
        };
        // The cut is made at one of the longest rim edges in the plane (a long straight run
        // of the outer rim, mostly); when the cycle found from there is short of the rim
        // edges' length (the edge was on a small island of the band, a feature standing out
        // of a wall), the next is tried.
        let mut starts: Vec<[u32; 2]> = rim.clone();
        starts.sort_by(|x, y| {
            let l = |e: &[u32; 2]| plane(e[0]).distance(plane(e[1]));
            l(y).total_cmp(&l(x)).then(x.cmp(y))
        });
        let rim_projected = projected(&rim);
        let mut found: Option<Vec<[u32; 2]>> = None;
        for &e0 in starts.iter().take(START_TRIES) {
            let Some(cycle) = round_the_band(mesh, &plane, &band, e0, near, &raster) else {
                continue;
            };
            let length = projected(&cycle);
            if found.as_ref().is_none_or(|f| length > projected(f)) {
                found = Some(cycle);
            }
            if length >= 0.7 * rim_projected {
                break;
            }
        }
        if let Some(cycle) = found {
            let length_mm: f64 = cycle
                .iter()
                .map(|&[a, b]| mesh.vertices[a as usize].distance(mesh.vertices[b as usize]))
                .sum();
            let mut degree = FxHashMap::<u32, u32>::default();
            for &[a, b] in &cycle {
                *degree.entry(a).or_default() += 1;
                *degree.entry(b).or_default() += 1;
            }
            rims.push(Rim {
                body,
                edges: cycle.len(),
                length_mm,
                closed: degree.values().all(|&d| d == 2),
                longest_loop: false,
            });
            kept.extend(cycle);
        } else {
            // The band does not go round: the outline seen along D is made of pieces of the
            // body at different depths (walls that do not run along D, seen at a slant),
            // which no edges of the mesh near the outline join. The body's longest loop of
            // edges between the sides is its silhouette there.
            let (cycle, rim_of, _) =
                longest_loop(mesh, group.iter().map(|&e| edges[e as usize]), body);
            rims.push(rim_of);
            kept.extend(cycle);
        }
        all_rim.extend(rim);
    }
    kept.sort_unstable();
    PartingLine {
        closed: !rims.is_empty() && rims.iter().all(|r| r.closed),
        length_mm: rims.iter().map(|r| r.length_mm).sum(),
        edges_all,
        loops: components(&all_rim),
        edges: kept,
        rims,
    }
}

/// The number of connected sets of `edges` (union-find on their vertices).
fn components(edges: &[[u32; 2]]) -> usize {
    let mut parent = FxHashMap::<u32, u32>::default();
    for &[a, b] in edges {
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            parent.insert(ra.max(rb), ra.min(rb));
        }
    }
    let vertices: Vec<u32> = parent.keys().copied().collect();
    vertices
        .into_iter()
        .filter(|&v| find(&mut parent, v) == v)
        .count()
}

/// The cheapest closed path of mesh edges round the band once (the module's documentation,
/// step 2), as sorted vertex pairs, or `None` when the band does not go round.
fn round_the_band(
    mesh: &Mesh,
    plane: &impl Fn(u32) -> DVec2,
    band: &Band,
    e0: [u32; 2],
    near: impl Fn(DVec2) -> bool,
    raster: &Outside,
) -> Option<Vec<[u32; 2]>> {
    let cell = raster.cell();
    let s = e0[0];
    let (p0, p1) = (plane(e0[0]), plane(e0[1]));
    if p0.distance(p1) == 0.0 {
        return None;
    }
    let middle = 0.5 * (p0 + p1);
    let mut inward = (p1 - p0).perp().normalize();
    if raster.is_outside(middle + 2.0 * cell * inward) {
        inward = -inward;
    }
    let mut depth = 0.0;
    while depth < 1e4 * cell && near(middle + (depth + 0.5 * cell) * inward) {
        depth += 0.5 * cell;
    }
    let depth = depth + 2.0 * cell;
    let side = |v: u32| inward.perp_dot(plane(v) - middle) >= 0.0;
    let cut = |a: u32, b: u32| {
        if side(a) == side(b) {
            return false;
        }
        let (p, q) = (plane(a) - middle, plane(b) - middle);
        let (sp, sq) = (inward.perp_dot(p), inward.perp_dot(q));
        let t = sp / (sp - sq);
        (p + (q - p) * t).dot(inward) <= depth
    };
    // Dijkstra on the band's own numbering (vertex arrays, not maps); the band numbers
    // its vertices in the order of the mesh's, so the heap breaks ties as it would on the
    // mesh's numbers.
    let s = band.index(s)?;
    let n = band.vertices.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut previous = vec![u32::MAX; n];
    let mut heap = BinaryHeap::new();
    let mut cut_edges: Vec<(u32, u32, f64)> = Vec::new();
    dist[s as usize] = 0.0;
    heap.push(Reverse((OrdF64(0.0), s)));
    while let Some(Reverse((OrdF64(d), v))) = heap.pop() {
        if d > dist[v as usize] {
            continue;
        }
        let global = band.vertices[v as usize];
        for k in band.start[v as usize]..band.start[v as usize + 1] {
            let entry = band.to[k as usize];
            let n = entry & !ON_RIM;
            let length = mesh.vertices[global as usize]
                .distance(mesh.vertices[band.vertices[n as usize] as usize]);
            let cost = if entry & ON_RIM != 0 {
                length
            } else {
                OFF_RIM_COST * length
            };
            if cut(global, band.vertices[n as usize]) {
                cut_edges.push((v, n, cost));
                continue;
            }
            let nd = d + cost;
            if nd < dist[n as usize] {
                dist[n as usize] = nd;
                previous[n as usize] = v;
                heap.push(Reverse((OrdF64(nd), n)));
            }
        }
    }
    let (a, b) = cut_edges
        .iter()
        .filter(|&&(a, b, _)| dist[a as usize].is_finite() && dist[b as usize].is_finite())
        .map(|&(a, b, cost)| {
            (
                dist[a as usize] + dist[b as usize] + cost,
                a.min(b),
                a.max(b),
            )
        })
        .min_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))))
        .map(|(_, a, b)| (a, b))?;
    let path = |mut v: u32| {
        let mut p = vec![band.vertices[v as usize]];
        while v != s {
            v = previous[v as usize];
            p.push(band.vertices[v as usize]);
        }
        p.reverse();
        p
    };
    let (pa, pb) = (path(a), path(b));
    let shared = pa.iter().zip(&pb).take_while(|(x, y)| x == y).count();
    // Both paths start at s; from their last shared vertex on they are apart.
    let from = shared.max(1) - 1;
    let mut cycle: Vec<[u32; 2]> = pa[from..]
        .windows(2)
        .chain(pb[from..].windows(2))
        .map(|w| [w[0].min(w[1]), w[0].max(w[1])])
        .collect();
    let (a, b) = (band.vertices[a as usize], band.vertices[b as usize]);
    cycle.push([a.min(b), a.max(b)]);
    (cycle.len() >= 3).then_some(cycle)
}

/// The mesh edges of the band: both ends and the middle near the outline seen along D (an
/// edge over the inside of the band, a long facet's edge from one side of it to the other,
/// would let a path short-cut the band). The band's vertices are numbered in the mesh's
/// order, and each one's neighbours are one run of a flat array (no list per vertex, no
/// map), in increasing order, built once per body and shared by the tries at the cut.
///
/// The arrays are what `locate` holds beside the rays at its peak, so they are kept small:
/// each edge is taken from one of its triangles only, the runs are filled by a counting
/// sort rather than a sort of both directions of every edge, and the step costs are not
/// stored (a step's length is computed when it is taken; whether it is a rim edge is the top
/// bit of its entry).
struct Band {
    /// The band's vertices (mesh numbers, increasing).
    vertices: Vec<u32>,
    /// Per band vertex, where its run of `to` begins (one more entry at the end).
    start: Vec<u32>,
    /// The neighbours, in band numbers, with [`ON_RIM`] set for a rim edge.
    to: Vec<u32>,
}

/// Which triangles a [`Band`] is made from.
#[derive(Clone, Copy)]
enum Scope<'a> {
    /// Every triangle of the mesh (a part of one body).
    Whole,
    /// One body's triangles (increasing), with marks of the mesh's vertices (0 for those of
    /// bodies not yet read: the bodies share no vertex).
    Body {
        triangles: &'a [u32],
        marks: &'a [AtomicU8],
    },
}

/// The triangles of each body, in increasing order: a counting sort by body.
struct Groups {
    /// Where each body's run of `items` begins (one more entry at the end).
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Groups {
    /// The `n` triangles grouped by `label(t)`, body numbers below `count`.
    fn of((n, count): (usize, usize), label: impl Fn(usize) -> u32) -> Groups {
        let mut start = vec![0u32; count + 1];
        for t in 0..n {
            start[label(t) as usize + 1] += 1;
        }
        for k in 0..count {
            start[k + 1] += start[k];
        }
        let mut fill = start[..count].to_vec();
        let mut items = vec![0u32; n];
        for t in 0..n {
            let l = label(t) as usize;
            items[fill[l] as usize] = t as u32;
            fill[l] += 1;
        }
        Groups { start, items }
    }

    /// The number of bodies.
    fn len(&self) -> usize {
        self.start.len() - 1
    }

    /// The triangles of body `body` (none for a body beyond the labels).
    fn of_body(&self, body: u32) -> &[u32] {
        let b = body as usize;
        match (self.start.get(b), self.start.get(b + 1)) {
            (Some(&s), Some(&e)) => &self.items[s as usize..e as usize],
            _ => &[],
        }
    }
}

/// The bit of a [`Band::to`] entry that marks a rim edge (band numbers are below it).
const ON_RIM: u32 = 1 << 31;

impl Band {
    fn new(
        mesh: &Mesh,
        topology: &Topology,
        plane: &(impl Fn(u32) -> DVec2 + Sync),
        scope: Scope<'_>,
        near: &(impl Fn(DVec2) -> bool + Sync),
        rim: &[[u32; 2]],
    ) -> Band {
        // Whether each vertex of the scope is near the outline: for the whole mesh a flag
        // per vertex; for a body, its triangles' corners marked (1 near, 2 not) in the
        // shared marks (no other body has those vertices).
        let inside: Vec<bool> = match scope {
            Scope::Whole => (0..mesh.vertices.len() as u32)
                .into_par_iter()
                .map(|v| near(plane(v)))
                .collect(),
            Scope::Body { triangles, marks } => {
                triangles.par_iter().for_each(|&t| {
                    for v in mesh.triangles[t as usize] {
                        let mark = &marks[v as usize];
                        if mark.load(Ordering::Relaxed) == 0 {
                            mark.store(if near(plane(v)) { 1 } else { 2 }, Ordering::Relaxed);
                        }
                    }
                });
                Vec::new()
            }
        };
        let is_inside = |v: u32| match scope {
            Scope::Whole => inside[v as usize],
            Scope::Body { marks, .. } => marks[v as usize].load(Ordering::Relaxed) == 1,
        };
        // An edge is taken from the triangle across it when that one comes later (or there
        // is none): on a non-manifold edge each triangle names the next one round it and the
        // last the first, so the first of them always takes it. A few edges may still come
        // twice; the runs are deduplicated below.
        // Most triangles have no two corners in the band, and are passed over on the
        // corners' flags alone, in blocks of triangles in parallel, whose lists are joined
        // once at their total size.
        const BLOCK: usize = 16 * 1024;
        let triangles = &mesh.triangles;
        let in_scope = match scope {
            Scope::Whole => triangles.len(),
            Scope::Body { triangles, .. } => triangles.len(),
        };
        let triangle = |i: usize| match scope {
            Scope::Whole => i,
            Scope::Body { triangles, .. } => triangles[i] as usize,
        };
        let mut edges: Vec<[u32; 2]> = (0..in_scope.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut found = Vec::new();
                for i in b * BLOCK..((b + 1) * BLOCK).min(in_scope) {
                    let t = triangle(i);
                    let tri = triangles[t];
                    let corners = tri.map(is_inside);
                    if u8::from(corners[0]) + u8::from(corners[1]) + u8::from(corners[2]) < 2 {
                        continue;
                    }
                    let across = topology.neighbours(t);
                    for k in 0..3 {
                        let (a, b) = (tri[k], tri[(k + 1) % 3]);
                        if corners[k]
                            && corners[(k + 1) % 3]
                            && a != b
                            && (across[k] == NO_TRIANGLE || across[k] as usize >= t)
                            && near(0.5 * (plane(a) + plane(b)))
                        {
                            found.push([a.min(b), a.max(b)]);
                        }
                    }
                }
                found
            })
            .collect::<Vec<Vec<[u32; 2]>>>()
            .concat();
        // The band's vertices are the ends of its edges, in the mesh's order, numbered by
        // rank in a bit set of the mesh's vertices (a count per word of 64 and the bits
        // below in the word: no search per edge end, and no number per mesh vertex).
        drop(inside);
        let words = mesh.vertices.len().div_ceil(64);
        let mut used = vec![0u64; words];
        for &[a, b] in &edges {
            used[a as usize / 64] |= 1 << (a % 64);
            used[b as usize / 64] |= 1 << (b % 64);
        }
        let mut rank = Vec::with_capacity(words);
        let mut count = 0u32;
        for w in &used {
            rank.push(count);
            count += w.count_ones();
        }
        // Read from the set bits, word by word (not a test of every mesh vertex).
        let mut vertices: Vec<u32> = Vec::with_capacity(count as usize);
        for (w, &word) in used.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                vertices.push((w * 64) as u32 + bits.trailing_zeros());
                bits &= bits - 1;
            }
        }
        let index = |v: u32| {
            let w = v as usize / 64;
            rank[w] + (used[w] & ((1u64 << (v % 64)) - 1)).count_ones()
        };
        edges
            .par_iter_mut()
            .for_each(|e| *e = [index(e[0]), index(e[1])]);
        drop((used, rank));
        // Counting sort of the edges both ways by their first end.
        let n = vertices.len();
        let mut start = vec![0u32; n + 1];
        for &[a, b] in &edges {
            start[a as usize + 1] += 1;
            start[b as usize + 1] += 1;
        }
        for k in 0..n {
            start[k + 1] += start[k];
        }
        let mut fill: Vec<u32> = start[..n].to_vec();
        let mut to = vec![0u32; 2 * edges.len()];
        for &[a, b] in &edges {
            to[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            to[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        drop(fill);
        drop(edges);
        // Each run in increasing order, each neighbour once (as a sort of all the pairs
        // would give them), compacted in place; then the rim edges marked.
        let mut written = 0usize;
        for v in 0..n {
            let (s, e) = (start[v] as usize, start[v + 1] as usize);
            to[s..e].sort_unstable();
            start[v] = written as u32;
            let mut last = u32::MAX;
            for k in s..e {
                if to[k] != last {
                    last = to[k];
                    to[written] = last;
                    written += 1;
                }
            }
        }
        start[n] = written as u32;
        to.truncate(written);
        to.shrink_to_fit();
        // The rim edges (a few thousand) are found in their ends' runs and marked there.
        let index = |v: u32| vertices.binary_search(&v).ok();
        for &[a, b] in rim {
            let (Some(ia), Some(ib)) = (index(a), index(b)) else {
                continue;
            };
            for (from, other) in [(ia, ib), (ib, ia)] {
                let run = &mut to[start[from] as usize..start[from + 1] as usize];
                // Entries already marked are compared without their mark (the run is
                // sorted by band number).
                if let Ok(k) = run.binary_search_by_key(&(other as u32), |&n| n & !ON_RIM) {
                    run[k] |= ON_RIM;
                }
            }
        }
        Band {
            vertices,
            start,
            to,
        }
    }

    /// The band number of mesh vertex `v`, if it is in the band.
    fn index(&self, v: u32) -> Option<u32> {
        self.vertices.binary_search(&v).ok().map(|k| k as u32)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Direction;
    use crate::samples::sample;

    /// Seen at a slant, the plate's outline is made of its top and bottom faces' edges,
    /// which no edges near the outline join: the rule falls back to the longest loop of
    /// edges between the sides (the silhouette, closed), which the longest-loop rule finds
    /// too, and says so. Along +z the plate keeps its outline cycle.
    #[test]
    fn an_outline_seen_at_a_slant_falls_back_to_the_longest_loop() {
        let mesh = sample("plate").unwrap();
        let topology = Topology::new(&mesh);
        let slant = Frame::new("1,0.3,0.2".parse::<Direction>().unwrap());
        let line = outline(&mesh, &topology, &slant);
        assert!(!line.edges.is_empty(), "no parting line at a slant");
        assert_eq!(line.rims.len(), 1);
        assert!(
            line.rims[0].longest_loop && line.rims[0].closed,
            "{:?}",
            line.rims
        );
        let longest = PartingLine::new(&mesh, &topology, &slant);
        assert_eq!(line.edges, longest.edges);
        assert!((line.length_mm - longest.length_mm).abs() < 1e-9);
        let along = outline(
            &mesh,
            &topology,
            &Frame::new("+z".parse::<Direction>().unwrap()),
        );
        assert!(
            along.rims.iter().all(|r| !r.longest_loop && r.closed),
            "{:?}",
            along.rims
        );
    }

    /// The band built by the counting sort of edges taken once is the one a sort of both
    /// directions of every triangle's edges gives (the construction it replaced): the same
    /// vertices, the same neighbours in the same order, and the rim edges marked.
    #[test]
    fn the_band_is_the_sorted_edges_of_every_triangle_both_ways() {
        for name in ["cover", "plate", "bracket"] {
            let mesh = sample(name).unwrap();
            let topology = Topology::new(&mesh);
            let frame = Frame::new("+z".parse::<Direction>().unwrap());
            let plane = |v: u32| {
                let p = mesh.vertices[v as usize];
                DVec2::new(p.dot(frame.u), p.dot(frame.w))
            };
            // A band that keeps the vertices on one side of the part's middle, so that some
            // edges are in it and some are not.
            let middle = mesh.bounds().centre();
            let near = |p: DVec2| p.x <= middle.dot(frame.u);
            let rim: Vec<[u32; 2]> = side_edges(&mesh, &topology, &frame, WALL_TILT);
            let band = Band::new(&mesh, &topology, &plane, Scope::Whole, &near, &rim);
            // A body's band from its own triangles and the shared marks is the same.
            let all: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
            let marks: Vec<AtomicU8> = (0..mesh.vertices.len()).map(|_| AtomicU8::new(0)).collect();
            let scope = Scope::Body {
                triangles: &all,
                marks: &marks,
            };
            let of_body = Band::new(&mesh, &topology, &plane, scope, &near, &rim);
            assert_eq!(
                (&of_body.vertices, &of_body.start, &of_body.to),
                (&band.vertices, &band.start, &band.to),
                "{name}"
            );
            let mut both: Vec<[u32; 2]> = mesh
                .triangles
                .iter()
                .flat_map(|t| (0..3).map(move |k| [t[k], t[(k + 1) % 3]]))
                .filter(|&[a, b]| {
                    a != b && near(plane(a)) && near(plane(b)) && near(0.5 * (plane(a) + plane(b)))
                })
                .flat_map(|[a, b]| [[a, b], [b, a]])
                .collect();
            both.sort_unstable();
            both.dedup();
            assert!(!both.is_empty() && both.len() < 6 * mesh.triangles.len());
            let mut vertices: Vec<u32> = both.iter().map(|e| e[0]).collect();
            vertices.dedup();
            assert_eq!(band.vertices, vertices, "{name}");
            let mut from_band = Vec::new();
            let mut marked = 0;
            for (v, &global) in band.vertices.iter().enumerate() {
                for &entry in &band.to[band.start[v] as usize..band.start[v + 1] as usize] {
                    let other = band.vertices[(entry & !ON_RIM) as usize];
                    let on_rim = rim
                        .binary_search(&[global.min(other), global.max(other)])
                        .is_ok();
                    assert_eq!(entry & ON_RIM != 0, on_rim, "{name}: {global}-{other}");
                    marked += on_rim as usize;
                    from_band.push([global, other]);
                }
            }
            assert_eq!(from_band, both, "{name}");
            assert!(marked > 0, "{name}: some rim edges are in the band");
        }
    }

    /// The bodies of a part of many are drawn in smaller rasters (`cells_for`) and still
    /// get their rims: a file of 300 loose unit cubes gives 300 closed rims, each the cube's
    /// 4 mm square.
    #[test]
    fn many_small_bodies_each_get_a_closed_rim() {
        // A unit cube of 12 triangles wound outwards: its rim is the bottom's 4 edges.
        let corner = |i: u32| {
            crate::math::DVec3::new(f64::from(i & 1), f64::from((i >> 1) & 1), f64::from(i >> 2))
        };
        let cube = Mesh {
            vertices: (0..8).map(corner).collect(),
            triangles: vec![
                [0, 2, 3],
                [0, 3, 1],
                [4, 5, 7],
                [4, 7, 6],
                [0, 1, 5],
                [0, 5, 4],
                [2, 6, 7],
                [2, 7, 3],
                [0, 4, 6],
                [0, 6, 2],
                [1, 3, 7],
                [1, 7, 5],
            ],
        };
        let mut many = Mesh {
            vertices: Vec::new(),
            triangles: Vec::new(),
        };
        for k in 0..300u32 {
            let at = crate::math::DVec3::new(f64::from(k % 20) * 3.0, f64::from(k / 20) * 3.0, 0.0);
            let n = many.vertices.len() as u32;
            many.vertices.extend(cube.vertices.iter().map(|&p| at + p));
            many.triangles
                .extend(cube.triangles.iter().map(|t| t.map(|v| v + n)));
        }
        assert_eq!(
            super::super::outside::cells_for(64),
            super::super::outside::CELLS
        );
        assert_eq!(super::super::outside::cells_for(300), 472);
        assert_eq!(super::super::outside::cells_for(1_000_000), 64);
        assert_eq!(
            super::super::outside::cells_for(1),
            super::super::outside::CELLS
        );
        let topology = Topology::new(&many);
        assert_eq!(topology.bodies, 300);
        let frame = Frame::new("+z".parse::<Direction>().unwrap());
        let line = outline(&many, &topology, &frame);
        assert_eq!(line.rims.len(), 300);
        assert_eq!(line.edges_all, 4 * 300, "4 edges between the sides a cube");
        for rim in &line.rims {
            assert!(rim.closed);
            assert!((rim.length_mm - 4.0).abs() < 1e-9, "{}", rim.length_mm);
        }
    }

    /// A part of several bodies gets each body's own line: two copies of a sample side by
    /// side (the second's triangles first, so that bodies and mesh order differ) give the
    /// edges of the sample's line in both copies, and its rim twice.
    #[test]
    fn each_body_of_several_gets_its_own_line() {
        for name in ["cover", "bracket", "tray"] {
            let one = sample(name).unwrap();
            let frame = Frame::new("+z".parse::<Direction>().unwrap());
            let alone = outline(&one, &Topology::new(&one), &frame);
            assert!(!alone.edges.is_empty(), "{name}");
            let n = one.vertices.len() as u32;
            let shift = 2.0 * one.bounds().diagonal() * frame.u;
            let mut two = Mesh {
                vertices: one.vertices.clone(),
                triangles: Vec::new(),
            };
            two.vertices.extend(one.vertices.iter().map(|&p| p + shift));
            two.triangles
                .extend(one.triangles.iter().map(|t| t.map(|v| v + n)));
            two.triangles.extend(one.triangles.iter().copied());
            let topology = Topology::new(&two);
            assert_eq!(topology.bodies, 2, "{name}");
            let both = outline(&two, &topology, &frame);
            let mut expected: Vec<[u32; 2]> = alone.edges.clone();
            expected.extend(alone.edges.iter().map(|e| e.map(|v| v + n)));
            expected.sort_unstable();
            assert_eq!(both.edges, expected, "{name}");
            assert_eq!(both.rims.len(), 2, "{name}");
            for rim in &both.rims {
                assert!(
                    (rim.length_mm - alone.length_mm).abs() <= 1e-9 * alone.length_mm,
                    "{name}"
                );
            }
        }
    }
}
