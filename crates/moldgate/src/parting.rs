//! The parting line for a demolding direction, and the aesthetic gate on it (the paper's
//! Fig. 5).
//!
//! A triangle *faces the fixed side* when its outward normal points against the demolding
//! direction D (n.D < -1e-6); every other triangle, including faces parallel to D, belongs to
//! the moving (+D) half. The parting line is made of the edges shared by a triangle that faces
//! the fixed side and one that does not. With drafted walls this is the silhouette of the part
//! seen along D. On walls without draft (a band of faces parallel to D) the line runs along
//! the -D end of the band: the mould splits where the part's -D face begins, so the +D half
//! forms every vertical wall, as it does when those walls are drafted towards +D. For a cover
//! open towards -D that is the outer edge of its rim; for a plate or a tray, the outline of the
//! face that lies on the -D side.
//!
//! Such edges also run round holes, pockets, rib ends and threads, where the two halves do
//! not meet. By default ([`PartingRule::Longest`], the paper's path, cheap beside the rays)
//! the parting line is the longest connected loop of them. With [`PartingRule::Outline`] it
//! keeps the edges on the part's **outline** seen along D: an
//! edge is on it when, in the projection plane, a point just beside its middle (1e-6 of the
//! projected box diagonal, on either side) is covered by no triangle of the part. Those
//! edges are chained into loops (connected sets of edges); the parting line is, for each
//! body, its outline loop with the largest projected box (the outer rim; a hole's rim lies
//! inside it), so a file with two parts has two loops. A loop is closed when each of its
//! vertices has two of its edges. Where the outline itself steps along D (a rim whose -D
//! end changes height) it runs up an undrafted wall, whose edges do not separate the sides;
//! there the loop stays open and says so.

use rayon::prelude::*;
use serde::Serialize;

use crate::frame::Frame;
use crate::math::{nearest_on_segment, DVec2, DVec3};
use crate::mesh::topology::root;
use crate::mesh::{Mesh, Topology};

/// Which edges make the parting line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PartingRule {
    /// The longest loop of the edges between the two sides (the paper's path; on parts
    /// whose holes or pockets have a longer rim than the outline, that rim wins).
    #[default]
    Longest,
    /// The outer outline loop of each body seen along D, chain ends bridged (the module's
    /// documentation; slower: a cover test per edge and shortest paths along the mesh).
    Outline,
}

/// The parting line: the kept loop (or loops, one per body, by [`PartingRule::Outline`]).
#[derive(Debug, Clone, Default)]
pub struct PartingLine {
    /// The edges of the kept loops, as vertex index pairs.
    pub edges: Vec<[u32; 2]>,
    /// Total length of those edges in mm.
    pub length_mm: f64,
    /// Every edge between the two sides, on the outline or not.
    pub edges_all: usize,
    /// Number of outline loops found (outer rims, hole rims).
    pub loops: usize,
    /// True when every kept loop is closed.
    pub closed: bool,
    /// The kept loops, one per body with an outline, in body order.
    pub rims: Vec<Rim>,
}

/// One kept loop of the parting line.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Rim {
    /// The body it belongs to (numbered as [`crate::mesh::topology::body_of_triangle`]).
    pub body: u32,
    /// Its edges.
    pub edges: usize,
    /// Its length, mm.
    pub length_mm: f64,
    /// Whether each of its vertices has two of its edges.
    pub closed: bool,
}

/// A gate on the parting line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AestheticGate {
    /// The point of the parting line nearest the centre of mass.
    pub point: DVec3,
    /// Its distance to the centre of mass in mm.
    pub distance_3d: f64,
    /// Its distance to the centre of mass in the projection plane.
    pub distance_2d: f64,
}

/// Per-triangle flag: faces the fixed (-D) side (n.D < -1e-6 for the unit normal n).
fn faces_fixed_side(mesh: &Mesh, d: DVec3) -> Vec<bool> {
    (0..mesh.triangles.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = mesh.corners(t);
            let cross = (b - a).cross(c - a);
            cross.dot(d) < -1e-6 * cross.length()
        })
        .collect()
}

/// The edges between a triangle that faces the fixed side and one that does not, sorted,
/// each once, as (smaller, larger) vertex pairs.
fn side_edges(mesh: &Mesh, topology: &Topology, frame: &Frame) -> Vec<[u32; 2]> {
    let fixed = faces_fixed_side(mesh, frame.d);
    // Each edge between the sides is found from its triangle that faces the fixed side,
    // in blocks of triangles in parallel (the edges are sorted below).
    const BLOCK: usize = 16 * 1024;
    let mut edges: Vec<[u32; 2]> = (0..mesh.triangles.len().div_ceil(BLOCK))
        .into_par_iter()
        .flat_map_iter(|b| {
            let block = b * BLOCK..((b + 1) * BLOCK).min(mesh.triangles.len());
            let fixed = &fixed;
            block.filter(|&t| fixed[t]).flat_map(move |t| {
                topology
                    .two_sided(t)
                    .filter(|&(_, n)| !fixed[n as usize])
                    .map(move |(k, _)| {
                        let tri = mesh.triangles[t];
                        let (a, b) = (tri[k], tri[(k + 1) % 3]);
                        [a.min(b), a.max(b)]
                    })
            })
        })
        .collect();
    edges.par_sort_unstable();
    edges.dedup();
    edges
}

impl PartingLine {
    /// Extracts the parting line of `mesh` for the frame's demolding direction.
    /// Extracts the parting line of `mesh` for the frame's demolding direction by the
    /// [`PartingRule::Longest`] rule: the longest loop of the edges between the two sides
    /// (the paper's path: cheap beside the rays). Its one rim is that loop; `closed` says
    /// whether each of its vertices has two of its edges.
    pub fn new(mesh: &Mesh, topology: &Topology, frame: &Frame) -> PartingLine {
        let edges = side_edges(mesh, topology, frame);
        if edges.is_empty() {
            return PartingLine::default();
        }
        // Loops are the connected components of the edges (union-find on vertices).
        let mut parent: Vec<u32> = (0..mesh.vertices.len() as u32).collect();
        for &[a, b] in &edges {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            if ra != rb {
                parent[ra.max(rb) as usize] = ra.min(rb);
            }
        }
        let mut length = rustc_hash::FxHashMap::<u32, f64>::default();
        for &[a, b] in &edges {
            let r = root(&mut parent, a);
            *length.entry(r).or_default() +=
                mesh.vertices[a as usize].distance(mesh.vertices[b as usize]);
        }
        // The longest loop; ties go to the loop with the smallest root vertex.
        let (&best, &length_mm) = length
            .iter()
            .max_by(|x, y| x.1.total_cmp(y.1).then(y.0.cmp(x.0)))
            .expect("at least one edge");
        let kept: Vec<[u32; 2]> = edges
            .iter()
            .copied()
            .filter(|&[a, _]| root(&mut parent, a) == best)
            .collect();
        let mut degree = rustc_hash::FxHashMap::<u32, u32>::default();
        for &[a, b] in &kept {
            *degree.entry(a).or_default() += 1;
            *degree.entry(b).or_default() += 1;
        }
        let closed = degree.values().all(|&d| d == 2);
        // The body of the kept loop, numbered as `body_of_triangle` numbers them: bodies
        // in the order of their first triangle.
        let body = {
            let mut joined = crate::mesh::topology::joined_vertices(mesh);
            let target = root(&mut joined, best);
            let mut seen = rustc_hash::FxHashSet::<u32>::default();
            let mut body = 0;
            for tri in &mesh.triangles {
                let r = root(&mut joined, tri[0]);
                if r == target {
                    break;
                }
                if seen.insert(r) {
                    body += 1;
                }
            }
            body
        };
        PartingLine {
            closed,
            edges_all: edges.len(),
            loops: length.len(),
            rims: vec![Rim {
                body,
                edges: kept.len(),
                length_mm,
                closed,
            }],
            edges: kept,
            length_mm,
        }
    }

    /// Extracts the parting line of `mesh` for the frame's demolding direction by the
    /// [`PartingRule::Outline`] rule (see the module's documentation).
    pub fn outline(mesh: &Mesh, topology: &Topology, frame: &Frame) -> PartingLine {
        let edges = side_edges(mesh, topology, frame);
        if edges.is_empty() {
            return PartingLine::default();
        }
        let edges_all = edges.len();
        let outline = Outline::new(mesh, frame);
        let project = |v: u32| frame.project(mesh.vertices[v as usize]);
        let on_outline: Vec<bool> = edges
            .par_iter()
            .map(|&[a, b]| outline.borders(project(a), project(b)))
            .collect();
        let edges: Vec<[u32; 2]> = edges
            .iter()
            .zip(&on_outline)
            .filter(|(_, &on)| on)
            .map(|(&e, _)| e)
            .collect();
        if edges.is_empty() {
            return PartingLine {
                edges_all,
                ..PartingLine::default()
            };
        }
        let mut edges = edges;
        edges.extend(bridges(mesh, frame, &edges));
        edges.sort_unstable();
        edges.dedup();
        // Loops are the connected components of the outline edges (union-find on vertices).
        let mut parent: Vec<u32> = (0..mesh.vertices.len() as u32).collect();
        for &[a, b] in &edges {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            if ra != rb {
                parent[ra.max(rb) as usize] = ra.min(rb);
            }
        }
        let body_of_vertex = {
            let body = crate::mesh::topology::body_of_triangle(mesh);
            let mut of = vec![u32::MAX; mesh.vertices.len()];
            for (t, tri) in mesh.triangles.iter().enumerate() {
                for &v in tri {
                    of[v as usize] = body[t];
                }
            }
            of
        };
        #[derive(Default)]
        struct Loop {
            length: f64,
            edges: usize,
            lo: DVec2,
            hi: DVec2,
        }
        // Keyed by root vertex, in a sorted map so the choice below is deterministic.
        let mut loops = std::collections::BTreeMap::<u32, Loop>::new();
        let mut degree = rustc_hash::FxHashMap::<u32, u32>::default();
        for &[a, b] in &edges {
            let r = root(&mut parent, a);
            let l = loops.entry(r).or_insert_with(|| Loop {
                lo: DVec2::splat(f64::INFINITY),
                hi: DVec2::splat(f64::NEG_INFINITY),
                ..Loop::default()
            });
            l.length += mesh.vertices[a as usize].distance(mesh.vertices[b as usize]);
            l.edges += 1;
            for q in [project(a), project(b)] {
                l.lo = l.lo.min(q);
                l.hi = l.hi.max(q);
            }
            *degree.entry(a).or_default() += 1;
            *degree.entry(b).or_default() += 1;
        }
        // Per body, the loop with the largest projected box; ties go to the longer loop,
        // then to the smaller root vertex.
        let mut kept = std::collections::BTreeMap::<u32, (u32, f64, f64)>::new();
        for (&r, l) in &loops {
            let size = (l.hi - l.lo).x * (l.hi - l.lo).y;
            let body = body_of_vertex[r as usize];
            let better = kept
                .get(&body)
                .is_none_or(|&(_, s, len)| size > s || (size == s && l.length > len));
            if better {
                kept.insert(body, (r, size, l.length));
            }
        }
        let kept_roots: rustc_hash::FxHashMap<u32, u32> =
            kept.iter().map(|(&body, &(r, _, _))| (r, body)).collect();
        let mut rims: Vec<Rim> = kept
            .iter()
            .map(|(&body, &(r, _, length))| Rim {
                body,
                edges: loops[&r].edges,
                length_mm: length,
                closed: true,
            })
            .collect();
        let mut kept_edges = Vec::new();
        for &[a, b] in &edges {
            if let Some(&body) = kept_roots.get(&root(&mut parent, a)) {
                kept_edges.push([a, b]);
                if degree[&a] != 2 || degree[&b] != 2 {
                    if let Some(rim) = rims.iter_mut().find(|x| x.body == body) {
                        rim.closed = false;
                    }
                }
            }
        }
        PartingLine {
            closed: rims.iter().all(|r| r.closed),
            length_mm: rims.iter().map(|r| r.length_mm).sum(),
            edges_all,
            loops: loops.len(),
            edges: kept_edges,
            rims,
        }
    }

    /// The kept loop as polylines of points, for drawing: edges chained end to end (a
    /// closed loop repeats its first point at the end; a vertex where more than two edges
    /// meet starts a new polyline).
    pub fn polylines(&self, mesh: &Mesh) -> Vec<Vec<DVec3>> {
        let mut at = rustc_hash::FxHashMap::<u32, Vec<usize>>::default();
        for (i, &[a, b]) in self.edges.iter().enumerate() {
            at.entry(a).or_default().push(i);
            at.entry(b).or_default().push(i);
        }
        let mut used = vec![false; self.edges.len()];
        let mut lines = Vec::new();
        for start in 0..self.edges.len() {
            if used[start] {
                continue;
            }
            used[start] = true;
            let [a, mut v] = self.edges[start];
            let mut line = vec![a, v];
            while let Some(&next) = at[&v].iter().find(|&&e| !used[e]) {
                if at[&v].len() != 2 {
                    break;
                }
                used[next] = true;
                let [p, q] = self.edges[next];
                v = if p == v { q } else { p };
                line.push(v);
            }
            lines.push(line.iter().map(|&i| mesh.vertices[i as usize]).collect());
        }
        lines
    }

    /// The point of the line nearest `centre` (the aesthetic gate), or `None` for an empty
    /// line. Ties go to the first edge in vertex order.
    pub fn nearest(&self, mesh: &Mesh, frame: &Frame, centre: DVec3) -> Option<AestheticGate> {
        self.nearest_allowed(mesh, frame, centre, 1.0, |_| true)
    }

    /// The point of the line nearest `centre` among the points `allowed` accepts. Where an
    /// edge's nearest point is refused, the edge is sampled every `step` mm and the allowed
    /// samples compete instead.
    pub fn nearest_allowed(
        &self,
        mesh: &Mesh,
        frame: &Frame,
        centre: DVec3,
        step: f64,
        allowed: impl Fn(DVec3) -> bool,
    ) -> Option<AestheticGate> {
        let mut best: Option<(f64, DVec3)> = None;
        let mut consider = |p: DVec3| {
            let d = p.distance(centre);
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, p));
            }
        };
        for &[a, b] in &self.edges {
            let (va, vb) = (mesh.vertices[a as usize], mesh.vertices[b as usize]);
            let p = nearest_on_segment(va, vb, centre);
            if allowed(p) {
                consider(p);
                continue;
            }
            let n = ((va.distance(vb) / step.max(1e-6)).ceil() as usize).clamp(1, 100_000);
            for k in 0..=n {
                let q = va.lerp(vb, k as f64 / n as f64);
                if allowed(q) {
                    consider(q);
                }
            }
        }
        best.map(|(d, p)| AestheticGate {
            point: p,
            distance_3d: d,
            distance_2d: frame.project(p).distance(frame.project(centre)),
        })
    }
}

/// Most chain ends [`bridges`] joins; past that the outline is left as found.
const MAX_BRIDGED_ENDS: usize = 2000;
/// Candidates considered for each chain end when pairing them (its nearest).
const PAIRS_PER_END: usize = 8;
/// Most vertices one bridge's search visits.
const MAX_BRIDGE_VISITS: usize = 20_000;
/// Most vertices all bridge searches of one line visit together (bounds the cost on fine
/// meshes; bridges past it are not built and their loops stay open).
const MAX_BRIDGE_VISITS_TOTAL: usize = 200_000;

/// Mesh-edge paths joining the ends of the outline chains where the outline steps along D
/// (it runs up an undrafted wall whose edges do not separate the sides). Ends (vertices
/// with an odd number of chain edges) are paired nearest first in the projection plane,
/// within a tenth of the box diagonal in space, each with an end of another chain when there is one (a chain's own two ends
/// when it has no other left); each pair is joined by the shortest path along mesh edges
/// (Dijkstra, at most [`MAX_BRIDGE_VISITS`] vertices each, [`MAX_BRIDGE_VISITS_TOTAL`] in
/// all).
fn bridges(mesh: &Mesh, frame: &Frame, chains: &[[u32; 2]]) -> Vec<[u32; 2]> {
    let mut degree = rustc_hash::FxHashMap::<u32, u32>::default();
    let mut parent = rustc_hash::FxHashMap::<u32, u32>::default();
    fn find(parent: &mut rustc_hash::FxHashMap<u32, u32>, v: u32) -> u32 {
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
    let reach = 0.1 * mesh.bounds().diagonal();
    let at = |v: u32| mesh.vertices[v as usize];
    // Each end's [`PAIRS_PER_END`] nearest candidates, nearest in the projection plane (a
    // step of the outline is a vertical run).
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    let mut near: Vec<(f64, usize)> = Vec::new();
    for i in 0..ends.len() {
        near.clear();
        let p = at(ends[i]);
        for (j, &e) in ends.iter().enumerate() {
            let q = at(e);
            if j != i && p.distance(q) <= reach {
                near.push((frame.project(p).distance(frame.project(q)), j));
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
    let mut open_ends = rustc_hash::FxHashMap::<u32, usize>::default();
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
    let neighbours = Neighbours::new(mesh);
    let mut out = Vec::new();
    let mut search = Search::new(mesh.vertices.len());
    let mut budget = MAX_BRIDGE_VISITS_TOTAL;
    for (from, to) in chosen {
        if budget == 0 {
            break;
        }
        if let Some(path) = shortest_path(mesh, &neighbours, &mut search, from, to, &mut budget) {
            out.extend(path.windows(2).map(|w| [w[0].min(w[1]), w[0].max(w[1])]));
        }
    }
    out
}

/// The shortest path along mesh edges from `from` to `to`, as vertices, or `None` when not
/// found within [`MAX_BRIDGE_VISITS`] vertices. `search` is reused from path to path.
fn shortest_path(
    mesh: &Mesh,
    neighbours: &Neighbours,
    search: &mut Search,
    from: u32,
    to: u32,
    budget: &mut usize,
) -> Option<Vec<u32>> {
    use std::cmp::Reverse;
    search.reset();
    search.set(from, 0.0, from);
    search.heap.push(Reverse((OrdF64(0.0), from)));
    let mut visits = 0;
    while let Some(Reverse((OrdF64(d), v))) = search.heap.pop() {
        if d > search.dist[v as usize] {
            continue;
        }
        if v == to {
            let mut path = vec![to];
            let mut at = to;
            while at != from {
                at = search.from[at as usize];
                path.push(at);
            }
            return Some(path);
        }
        visits += 1;
        if visits > MAX_BRIDGE_VISITS || *budget == 0 {
            return None;
        }
        *budget -= 1;
        for &n in neighbours.of(v) {
            let nd = d + mesh.vertices[v as usize].distance(mesh.vertices[n as usize]);
            if nd < search.dist[n as usize] {
                search.set(n, nd, v);
                search.heap.push(Reverse((OrdF64(nd), n)));
            }
        }
    }
    None
}

/// Dijkstra's state over all vertices, reset between searches by the vertices touched.
struct Search {
    dist: Vec<f64>,
    from: Vec<u32>,
    touched: Vec<u32>,
    heap: std::collections::BinaryHeap<std::cmp::Reverse<(OrdF64, u32)>>,
}

impl Search {
    fn new(vertices: usize) -> Search {
        Search {
            dist: vec![f64::INFINITY; vertices],
            from: vec![u32::MAX; vertices],
            touched: Vec::new(),
            heap: std::collections::BinaryHeap::new(),
        }
    }

    fn set(&mut self, v: u32, d: f64, from: u32) {
        if self.dist[v as usize] == f64::INFINITY {
            self.touched.push(v);
        }
        self.dist[v as usize] = d;
        self.from[v as usize] = from;
    }

    fn reset(&mut self) {
        for &v in &self.touched {
            self.dist[v as usize] = f64::INFINITY;
        }
        self.touched.clear();
        self.heap.clear();
    }
}

/// The neighbours of each vertex along mesh edges, in one flat array (each edge is listed
/// from both of its triangles, so most neighbours appear twice; the search does not mind).
struct Neighbours {
    /// Where each vertex's neighbours begin in `items` (one more at the end).
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Neighbours {
    fn new(mesh: &Mesh) -> Neighbours {
        let mut start = vec![0u32; mesh.vertices.len() + 1];
        for tri in &mesh.triangles {
            for &v in tri {
                start[v as usize + 1] += 2;
            }
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; start[mesh.vertices.len()] as usize];
        for tri in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                for (from, to) in [(a, b), (b, a)] {
                    let at = &mut fill[from as usize];
                    items[*at as usize] = to;
                    *at += 1;
                }
            }
        }
        Neighbours { start, items }
    }

    fn of(&self, v: u32) -> &[u32] {
        &self.items[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
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

/// The projection of the part's triangles along D, binned in a uniform grid, to tell which
/// points of the projection plane the part covers.
struct Outline {
    /// Projected corners of each triangle with projected area.
    triangles: Vec<[DVec2; 3]>,
    /// Where each cell's triangles begin in `items` (cells row by row; one more at the end).
    start: Vec<u32>,
    /// The triangles overlapping each cell, cell after cell.
    items: Vec<u32>,
    lo: DVec2,
    cell: f64,
    n_u: usize,
    n_w: usize,
    /// How far beside an edge's middle the cover is tested.
    offset: f64,
}

impl Outline {
    /// Every triangle with projected area covers (the fixed side alone would do on a closed
    /// part, not on an open mesh). The grid is one flat array of triangle indices, cell after
    /// cell, with an offset per cell (counted, then filled).
    fn new(mesh: &Mesh, frame: &Frame) -> Outline {
        let triangles: Vec<[DVec2; 3]> = mesh
            .triangles
            .par_iter()
            .map(|t| t.map(|v| frame.project(mesh.vertices[v as usize])))
            .filter(|[a, b, c]| (*b - *a).perp_dot(*c - *a).abs() > 0.0)
            .collect();
        let (lo, hi) = triangles
            .par_iter()
            .fold(
                || (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
                |(lo, hi), t| {
                    (
                        lo.min(t[0].min(t[1]).min(t[2])),
                        hi.max(t[0].max(t[1]).max(t[2])),
                    )
                },
            )
            .reduce(
                || (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
        let size = (hi - lo).max(DVec2::splat(1e-12));
        // About two triangles per cell.
        let cells_wanted = (triangles.len() / 2).clamp(1, 1 << 22) as f64;
        let cell = (size.x * size.y / cells_wanted).sqrt().max(1e-12);
        let n_u = ((size.x / cell).ceil() as usize).clamp(1, 1 << 12);
        let n_w = ((size.y / cell).ceil() as usize).clamp(1, 1 << 12);
        let cell = (size.x / n_u as f64).max(size.y / n_w as f64);
        let index = |x: f64, n: usize| (((x / cell).floor().max(0.0)) as usize).min(n - 1);
        // The cells a triangle overlaps, row by row: in each row, the x range of the
        // triangle clipped to the row's slab (a thin sliver crossing the grid touches few
        // cells per row, not its whole bounding box).
        let for_cells = |t: &[DVec2; 3], f: &mut dyn FnMut(usize)| {
            let (y_lo, y_hi) = (
                t[0].y.min(t[1].y).min(t[2].y),
                t[0].y.max(t[1].y).max(t[2].y),
            );
            for w in index(y_lo - lo.y, n_w)..=index(y_hi - lo.y, n_w) {
                let s0 = (lo.y + w as f64 * cell).max(y_lo);
                let s1 = (lo.y + (w + 1) as f64 * cell).min(y_hi);
                let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
                for k in 0..3 {
                    let (p, q) = (t[k], t[(k + 1) % 3]);
                    if (s0..=s1).contains(&p.y) {
                        x0 = x0.min(p.x);
                        x1 = x1.max(p.x);
                    }
                    for y in [s0, s1] {
                        if (p.y - y) * (q.y - y) < 0.0 {
                            let x = p.x + (q.x - p.x) * (y - p.y) / (q.y - p.y);
                            x0 = x0.min(x);
                            x1 = x1.max(x);
                        }
                    }
                }
                if x0 > x1 {
                    // Rounding left the slab empty: the row's share of the box.
                    x0 = t[0].x.min(t[1].x).min(t[2].x);
                    x1 = t[0].x.max(t[1].x).max(t[2].x);
                }
                for u in index(x0 - lo.x, n_u)..=index(x1 - lo.x, n_u) {
                    f(w * n_u + u);
                }
            }
        };
        let mut start = vec![0u32; n_u * n_w + 1];
        for t in &triangles {
            for_cells(t, &mut |c| start[c + 1] += 1);
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; start[n_u * n_w] as usize];
        for (i, t) in triangles.iter().enumerate() {
            for_cells(t, &mut |c| {
                items[fill[c] as usize] = i as u32;
                fill[c] += 1;
            });
        }
        Outline {
            triangles,
            start,
            items,
            lo,
            cell,
            n_u,
            n_w,
            offset: 1e-6 * size.length(),
        }
    }

    /// Whether some triangle covers `p` (on its boundary counts).
    fn covers(&self, p: DVec2) -> bool {
        let d = p - self.lo;
        if d.x < 0.0 || d.y < 0.0 {
            return false;
        }
        let (u, w) = ((d.x / self.cell) as usize, (d.y / self.cell) as usize);
        if u >= self.n_u || w >= self.n_w {
            return false;
        }
        let c = w * self.n_u + u;
        let cell = &self.items[self.start[c] as usize..self.start[c + 1] as usize];
        cell.iter().any(|&i| {
            let [a, b, c] = self.triangles[i as usize];
            let (e0, e1, e2) = (
                (b - a).perp_dot(p - a),
                (c - b).perp_dot(p - b),
                (a - c).perp_dot(p - c),
            );
            (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0)
        })
    }

    /// Whether the projected edge `a`-`b` borders the uncovered plane: a point beside its
    /// middle, on one side or the other, is covered by no triangle. An edge seen end-on
    /// (along D) borders nothing.
    fn borders(&self, a: DVec2, b: DVec2) -> bool {
        let along = b - a;
        let len = along.length();
        if len <= self.offset {
            return false;
        }
        let side = along.perp() / len * self.offset;
        let m = 0.5 * (a + b);
        !self.covers(m + side) || !self.covers(m - side)
    }
}

/// The parting line summary reported in the JSON output.
#[derive(Debug, Clone, Serialize)]
pub struct PartingSummary {
    /// Edges of the kept loops.
    pub edges: usize,
    /// Their length in mm.
    pub length_mm: f64,
    /// Edges between the two sides, on the outline or not.
    pub edges_all: usize,
    /// Outline loops found.
    pub loops: usize,
    /// Whether every kept loop is closed.
    pub closed: bool,
    /// The kept loops (the outer rim of each body).
    pub rims: Vec<Rim>,
}

impl From<&PartingLine> for PartingSummary {
    fn from(p: &PartingLine) -> Self {
        PartingSummary {
            edges: p.edges.len(),
            length_mm: p.length_mm,
            edges_all: p.edges_all,
            loops: p.loops,
            closed: p.closed,
            rims: p.rims.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::Direction;
    use crate::samples::sample;

    fn parting(name: &str, demold: &str) -> (Mesh, PartingLine, Frame) {
        let mesh = sample(name).unwrap();
        let frame = Frame::new(demold.parse::<Direction>().unwrap());
        let line = PartingLine::outline(&mesh, &Topology::new(&mesh), &frame);
        (mesh, line, frame)
    }

    fn all_on_plane(mesh: &Mesh, line: &PartingLine, z: f64) -> bool {
        line.edges
            .iter()
            .flatten()
            .all(|&v| mesh.vertices[v as usize].z == z)
    }

    #[test]
    fn closed_loop_chains_into_one_polyline_of_the_loop_length() {
        let (mesh, line, _) = parting("cover", "+z");
        let lines = line.polylines(&mesh);
        assert_eq!(lines.len(), 1);
        let l = &lines[0];
        assert_eq!(l.first(), l.last(), "a closed loop ends where it starts");
        assert_eq!(l.len(), line.edges.len() + 1);
        let length: f64 = l.windows(2).map(|p| p[0].distance(p[1])).sum();
        assert!((length - line.length_mm).abs() < 1e-9, "{length}");
    }

    #[test]
    fn cover_splits_at_the_outer_edge_of_its_rim() {
        let (mesh, line, frame) = parting("cover", "+z");
        assert!((line.length_mm - 400.0).abs() < 1e-9, "{}", line.length_mm);
        assert!(line.closed);
        assert!(all_on_plane(&mesh, &line, 0.0));
        // Nearest rim point to a centre above the middle: the middle of a long side.
        let gate = line
            .nearest(&mesh, &frame, DVec3::new(0.0, 0.0, 20.0))
            .unwrap();
        assert!((gate.point.x).abs() < 1e-9 && (gate.point.y.abs() - 40.0).abs() < 1e-9);
        assert!((gate.distance_3d - (1600.0f64 + 400.0).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn plate_and_bracket_split_at_their_bottom_outline() {
        let (mesh, line, _) = parting("plate", "+z");
        assert!((line.length_mm - 320.0).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 0.0));
        assert_eq!(line.loops, 2, "outline and hole");
        let (mesh, line, _) = parting("bracket", "+z");
        assert!((line.length_mm - 200.0).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 0.0));
    }

    #[test]
    fn demolding_the_other_way_moves_the_line_to_the_other_end_of_the_walls() {
        let (mesh, line, _) = parting("tray", "-z");
        assert!((line.length_mm - 280.0).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 20.0));
        let (mesh, line, _) = parting("cap", "+z");
        // A 96-gon of radius 20 at the rim.
        let expected = 96.0 * 2.0 * 20.0 * (std::f64::consts::PI / 96.0).sin();
        assert!((line.length_mm - expected).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 0.0));
    }
}
