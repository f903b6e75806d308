//! The parting line for a demolding direction, and the aesthetic gate on it (the paper's
//! Fig. 5).
//!
//! A triangle *faces the moving side* when its outward normal points along the demolding
//! direction D (n.D > 1e-6); every other triangle, including faces parallel to D, belongs to
//! the fixed (-D) half. The parting line is made of the edges shared by a triangle that
//! faces the moving side and one that does not (the split of the reference implementation).
//! With drafted walls this is the silhouette of the part seen along D. On walls without draft
//! (a band of faces parallel to D) the line runs along the +D end of the band: the fixed half
//! forms every vertical wall, as it does when the outer walls of a cover open towards +D are
//! drafted to release from it (wider towards +D). D points from the fixed half (the cavity,
//! which forms the outside) to the moving half (the core, which forms the faces turned
//! towards +D and the inside of a cover open towards it), so for such a cover the line is the
//! outer edge of its open rim, away from the show face; for a plate or a tray, the outline
//! of the face that lies on the +D side.
//!
//! Such edges also run round holes, pockets, rib ends and threads, where the two halves do
//! not meet. By default ([`PartingRule::Outline`], `outline.rs`) the parting line keeps, of
//! them, the ones on each body's **outline** seen along D and at its +D end there (one edge
//! per outline position on a vertical band), and closes them into one cycle per body round
//! the outline on the mesh's edges (up the steps where that end changes height). The rims of
//! holes, and of grooves, ribs and thread turns seen edge-on below the +D end, are not on
//! it. With [`PartingRule::Longest`] (the paper's path) it is the longest connected loop of
//! the edges between the sides, on the outline or not.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

mod outline;
mod outside;

use crate::frame::Frame;
use crate::math::{nearest_on_segment, DVec3};
use crate::mesh::topology::{root, NO_TRIANGLE};
use crate::mesh::{Mesh, Topology};
use rustc_hash::FxHashMap;

/// Which edges make the parting line (`parting_line` in the study options).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PartingRule {
    /// The default: the closed outer rim of each body seen along D, at the +D end of walls
    /// without draft (the module's documentation).
    #[default]
    Outline,
    /// The longest loop of the edges between the two sides (the paper's path; on parts whose
    /// holes, pockets or threads have a longer rim than the outline, that rim wins, and the
    /// loop may be open).
    Longest,
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
    /// Number of connected sets of rim edges found (the edges between the sides on the
    /// outline at its +D end, before they are closed into cycles; for
    /// [`PartingRule::Longest`], of all the edges between the sides).
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
    /// Whether the outline rule found no cycle round this body's outline, so that the loop
    /// is the body's longest loop of edges between the two sides (as
    /// [`PartingRule::Longest`] takes it): on a body whose walls do not run along D, whose
    /// outline seen along D is the silhouette of faces at different depths.
    pub longest_loop: bool,
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

/// Per-triangle flag: faces the moving (+D) side (n.D > `tilt` for the unit normal n).
fn faces_moving_side(mesh: &Mesh, d: DVec3, tilt: f64) -> Vec<bool> {
    (0..mesh.triangles.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = mesh.corners(t);
            let cross = (b - a).cross(c - a);
            cross.dot(d) > tilt * cross.length()
        })
        .collect()
}

/// The edges between a triangle that faces the moving side and one that does not, sorted,
/// each once, as (smaller, larger) vertex pairs.
fn side_edges(mesh: &Mesh, topology: &Topology, frame: &Frame, tilt: f64) -> Vec<[u32; 2]> {
    let moving = faces_moving_side(mesh, frame.d, tilt);
    // Each edge between the sides is found from its triangle that faces the moving side,
    // in blocks of triangles in parallel (the edges are sorted below). A plain loop a
    // block: most triangles are passed over on their own flag. The blocks' lists are
    // joined once, at their total size (a list grown edge by edge would be copied as it
    // grows, into fresh pages).
    const BLOCK: usize = 16 * 1024;
    let check = topology.non_manifold_edges > 0;
    let mut edges: Vec<[u32; 2]> = (0..mesh.triangles.len().div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut found = Vec::new();
            for t in b * BLOCK..((b + 1) * BLOCK).min(mesh.triangles.len()) {
                if !moving[t] {
                    continue;
                }
                let across = topology.neighbours(t);
                let tri = mesh.triangles[t];
                for k in 0..3 {
                    let n = across[k];
                    // As `Topology::two_sided`: an edge shared with exactly one other
                    // triangle.
                    if n == NO_TRIANGLE
                        || moving[n as usize]
                        || (check && !topology.neighbours(n as usize).contains(&(t as u32)))
                    {
                        continue;
                    }
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    found.push([a.min(b), a.max(b)]);
                }
            }
            found
        })
        .collect::<Vec<Vec<[u32; 2]>>>()
        .concat();
    // Sorted on this thread: the edges between the sides are a few per cent of the mesh's
    // (25,768 of 528,519 on the 352k part), too few for the parallel sort to pay, and the
    // rays use the other thread meanwhile.
    edges.sort_unstable();
    edges.dedup();
    edges
}

/// The root of `v` in a union-find forest of edge vertices kept in a map (a vertex not in
/// it is its own root), `v` linked to it directly.
pub(super) fn find(parent: &mut FxHashMap<u32, u32>, v: u32) -> u32 {
    let mut r = v;
    while let Some(&p) = parent.get(&r).filter(|&&p| p != r) {
        r = p;
    }
    parent.insert(v, r);
    r
}

/// Of `edges` (edges between the sides: a body's, or the whole mesh's), the connected set of
/// the greatest length (of two alike, the one holding the least vertex), as sorted vertex
/// pairs, with its [`Rim`] (`longest_loop` set) and the number of connected sets. A map
/// holds the forest, so a body's few edges cost their own count, not the mesh's vertices.
pub(super) fn longest_loop(
    mesh: &Mesh,
    edges: impl Iterator<Item = [u32; 2]> + Clone,
    body: u32,
) -> (Vec<[u32; 2]>, Rim, usize) {
    let mut parent = FxHashMap::<u32, u32>::default();
    for [a, b] in edges.clone() {
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            parent.insert(ra.max(rb), ra.min(rb));
        }
    }
    let length = |[a, b]: [u32; 2]| mesh.vertices[a as usize].distance(mesh.vertices[b as usize]);
    let mut per_set = FxHashMap::<u32, f64>::default();
    for e in edges.clone() {
        *per_set.entry(find(&mut parent, e[0])).or_default() += length(e);
    }
    let best = per_set
        .iter()
        .max_by(|x, y| x.1.total_cmp(y.1).then(y.0.cmp(x.0)))
        .map(|(&r, _)| r);
    let mut cycle: Vec<[u32; 2]> = edges
        .filter(|e| Some(find(&mut parent, e[0])) == best)
        .collect();
    cycle.sort_unstable();
    let mut degree = FxHashMap::<u32, u32>::default();
    for &[a, b] in &cycle {
        *degree.entry(a).or_default() += 1;
        *degree.entry(b).or_default() += 1;
    }
    let rim = Rim {
        body,
        edges: cycle.len(),
        length_mm: cycle.iter().map(|&e| length(e)).sum(),
        closed: !cycle.is_empty() && degree.values().all(|&d| d == 2),
        longest_loop: true,
    };
    (cycle, rim, per_set.len())
}

impl PartingLine {
    /// Extracts the parting line of `mesh` for the frame's demolding direction by the
    /// [`PartingRule::Longest`] rule: the longest loop of the edges between the two sides
    /// (the paper's path: cheap beside the rays). Its one rim is that loop; `closed` says
    /// whether each of its vertices has two of its edges.
    pub fn new(mesh: &Mesh, topology: &Topology, frame: &Frame) -> PartingLine {
        let edges = side_edges(mesh, topology, frame, 1e-6);
        if edges.is_empty() {
            return PartingLine::default();
        }
        let (kept, rim, loops) = longest_loop(mesh, edges.iter().copied(), 0);
        let best = kept[0][0];
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
            closed: rim.closed,
            edges_all: edges.len(),
            loops,
            length_mm: rim.length_mm,
            rims: vec![Rim {
                body,
                // The rule itself, not the outline rule's stand-in.
                longest_loop: false,
                ..rim
            }],
            edges: kept,
        }
    }

    /// The bodies whose loop is their longest loop of edges between the sides, the outline
    /// rule having found no cycle round their outline ([`Rim::longest_loop`]).
    pub fn longest_loop_rims(&self) -> impl Iterator<Item = &Rim> {
        self.rims.iter().filter(|r| r.longest_loop)
    }

    /// Extracts the parting line of `mesh` for the frame's demolding direction by the
    /// [`PartingRule::Outline`] rule: the closed outer rim of each body seen along D (the
    /// module's documentation).
    pub fn outline(mesh: &Mesh, topology: &Topology, frame: &Frame) -> PartingLine {
        outline::outline(mesh, topology, frame)
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

/// The parting line summary reported in the JSON output.
#[derive(Debug, Clone, Serialize)]
pub struct PartingSummary {
    /// Edges of the kept loops.
    pub edges: usize,
    /// Their length in mm.
    pub length_mm: f64,
    /// Edges between the two sides, on the outline or not.
    pub edges_all: usize,
    /// Connected sets of rim edges found (see [`PartingLine::loops`]).
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
        // The cover opens towards -z: demolded towards its opening, the moving half forms
        // its inside and the fixed half its outside, the line round the open rim.
        let (mesh, line, frame) = parting("cover", "-z");
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
    fn plate_and_bracket_split_at_the_outline_of_their_plus_d_face() {
        let (mesh, line, _) = parting("plate", "-z");
        assert!((line.length_mm - 320.0).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 0.0));
        assert_eq!(line.loops, 1, "the outline; the hole's rim is inside it");
        let (mesh, line, _) = parting("plate", "+z");
        assert!((line.length_mm - 320.0).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 3.0));
        let (mesh, line, _) = parting("bracket", "-z");
        assert!((line.length_mm - 200.0).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 0.0));
    }

    #[test]
    fn demolding_the_other_way_moves_the_line_to_the_other_end_of_the_walls() {
        // The tray opens towards +z: its rim is the +D end.
        let (mesh, line, _) = parting("tray", "+z");
        assert!((line.length_mm - 280.0).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 20.0));
        let (mesh, line, _) = parting("tray", "-z");
        assert!((line.length_mm - 280.0).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 0.0));
        let (mesh, line, _) = parting("cap", "-z");
        // A 96-gon of radius 20 at the rim.
        let expected = 96.0 * 2.0 * 20.0 * (std::f64::consts::PI / 96.0).sin();
        assert!((line.length_mm - expected).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 0.0));
        let (mesh, line, _) = parting("cap", "+z");
        assert!((line.length_mm - expected).abs() < 1e-9);
        assert!(all_on_plane(&mesh, &line, 15.0));
    }
}
