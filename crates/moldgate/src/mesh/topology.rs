//! Edges and bodies of a welded mesh.
//!
//! Edges are not stored one by one: each triangle records the triangle across each of its
//! three edges (4 bytes per edge side), which is all that the parting line and the counts
//! need, at a fifth of the memory of an edge list.

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

use rayon::prelude::*;

use super::Mesh;

/// Marks a missing neighbour: the edge is open (used by one triangle only).
pub const NO_TRIANGLE: u32 = u32::MAX;

/// Neighbours, edge counts and connected bodies of a mesh.
#[derive(Debug, Clone, Default)]
pub struct Topology {
    /// At 3 t + k: the triangle across the edge of triangle t from corner k to corner k + 1
    /// (see [`Topology::neighbours`]).
    across: Vec<u32>,
    /// Distinct undirected edges.
    pub edges: u64,
    /// Edges with one triangle.
    pub open_edges: u64,
    /// Edges with more than two triangles.
    pub non_manifold_edges: u64,
    /// Edges whose sides do not pair up by direction: not as many of its triangles run it
    /// one way as the other (an open edge; two facets across an edge, one of them turned
    /// round; a side from a vertex to itself, of a facet without area, which runs neither
    /// way). Counted as the sides are paired, at no extra pass; `None` on a mesh of more
    /// than [`DIRECTED_TRIANGLES`] triangles, whose side numbers leave no bit for the
    /// direction.
    pub unpaired_edges: Option<u64>,
    /// Number of bodies: sets of triangles linked through shared vertices (see
    /// [`body_of_triangle`] for which triangle is in which).
    pub bodies: u64,
    /// Of a mesh of several bodies, whether one has a negative signed volume (its facets
    /// wound inwards as a whole, when it is closed); `false` for one body, whose volume the
    /// centres of mass give.
    pub inward_body: bool,
}

impl Topology {
    /// Builds the neighbour table (edges grouped under their smaller vertex, no global
    /// sort) and, in parallel with it, the bodies.
    pub fn new(mesh: &Mesh) -> Topology {
        let ((across, counts), (bodies, inward_body)) =
            rayon::join(|| neighbours(mesh), || body_count(mesh));
        Topology {
            across,
            edges: counts.edges,
            open_edges: counts.open,
            non_manifold_edges: counts.non_manifold,
            unpaired_edges: counts.unpaired,
            bodies,
            inward_body,
        }
    }

    /// For k in 0..3, the triangle across the edge of triangle `t` from corner k to corner
    /// k + 1, or [`NO_TRIANGLE`] on an open edge. On a non-manifold edge (more than two
    /// triangles), each triangle records the next one around the edge in index order, the
    /// last one the first.
    #[inline]
    pub fn neighbours(&self, t: usize) -> [u32; 3] {
        [
            self.across[3 * t],
            self.across[3 * t + 1],
            self.across[3 * t + 2],
        ]
    }

    /// Every edge between exactly two triangles once, as (t, k, n): triangle t, its edge from
    /// corner k to corner k + 1, and the triangle n across it, with t < n. Open and
    /// non-manifold edges are left out.
    pub fn edge_sides(&self) -> impl Iterator<Item = (u32, usize, u32)> + '_ {
        (0..self.across.len() / 3).flat_map(move |t| {
            self.two_sided(t)
                .filter(move |&(_, n)| n > t as u32)
                .map(move |(k, n)| (t as u32, k, n))
        })
    }

    /// The edges of triangle `t` that it shares with exactly one other triangle, as (k, n):
    /// its edge from corner k to corner k + 1 and the triangle n across it.
    pub fn two_sided(&self, t: usize) -> impl Iterator<Item = (usize, u32)> + '_ {
        // Without non-manifold edges every neighbour relation is mutual; with them, a
        // triangle's neighbour may point on to a third one, and such pairs are left out.
        let check = self.non_manifold_edges > 0;
        let across = self.neighbours(t);
        (0..3).filter_map(move |k| {
            let n = across[k];
            (n != NO_TRIANGLE && (!check || self.neighbours(n as usize).contains(&(t as u32))))
                .then_some((k, n))
        })
    }
}

impl Topology {
    /// Whether every edge is run as often one way as the other by its triangles, as counted
    /// at load ([`Topology::unpaired_edges`]): then the surface is closed and consistently
    /// oriented (but for edges of more than two sides that still pair up). `false` when
    /// not counted, or when a facet without area leaves an edge unpaired, which the count
    /// cannot tell from an open or turned one.
    pub fn sides_pair_up(&self) -> bool {
        self.unpaired_edges == Some(0)
    }

    /// Whether the mesh is closed (no open edge), manifold (no edge with more than two
    /// triangles) and consistently oriented (the two triangles of every edge run it in
    /// opposite directions). Each body of such a mesh bounds a solid, and its facets all
    /// face out of it or all face into it; the picture uses this to skip the facets turned
    /// away from the viewer.
    pub fn closed_and_oriented(&self, mesh: &Mesh) -> bool {
        if self.open_edges > 0 || self.non_manifold_edges > 0 {
            return false;
        }
        // Closed and manifold, every edge has two sides: when every edge is paired, they run
        // opposite ways. (An edge left unpaired by a facet without area, whose side from a
        // vertex to itself runs neither way, is left to the check below.)
        if self.sides_pair_up() {
            return true;
        }
        // Each edge is checked from the side of its lower triangle only. Its two sides are
        // linked to each other (closed and manifold: two sides an edge); if the lower one
        // runs a to b and the upper triangle has a side from b to a, the upper side is that
        // one (a third side on the edge would make it non-manifold), so the check from the
        // upper side (the lower triangle runs a to b) holds too. Half the scattered reads.
        mesh.triangles.par_iter().enumerate().all(|(t, tri)| {
            (0..3).all(|k| {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let n = self.across[3 * t + k];
                if n == NO_TRIANGLE {
                    return false;
                }
                if (n as usize) < t {
                    return true; // checked from triangle n
                }
                let other = mesh.triangles[n as usize];
                // The neighbour runs the edge from b to a: b is followed by a in its order.
                (0..3).any(|j| other[j] == b && other[(j + 1) % 3] == a)
            })
        })
    }
}

/// The most triangles whose sides' numbers (3 t + k) leave a bit of a 32-bit number for
/// the side's direction in [`link_sides`].
pub const DIRECTED_TRIANGLES: usize = (1 << 31) / 3;

/// The counts of the edges of a mesh, as [`Topology`] gives them.
#[derive(Debug, Clone, Copy, Default)]
struct EdgeCounts {
    edges: u64,
    open: u64,
    non_manifold: u64,
    /// `None` when the sides were filed without their direction.
    unpaired: Option<u64>,
}

impl EdgeCounts {
    fn add(self, other: EdgeCounts) -> EdgeCounts {
        EdgeCounts {
            edges: self.edges + other.edges,
            open: self.open + other.open,
            non_manifold: self.non_manifold + other.non_manifold,
            unpaired: self.unpaired.zip(other.unpaired).map(|(a, b)| a + b),
        }
    }
}

fn neighbours(mesh: &Mesh) -> (Vec<u32>, EdgeCounts) {
    let tris = &mesh.triangles;
    let nv = mesh.vertices.len();
    // Each side is written once, by the thread that owns its near vertex; relaxed atomic
    // stores let the threads share the table without locks.
    let across: Vec<AtomicU32> = (0..3 * tris.len())
        .into_par_iter()
        .map(|_| AtomicU32::new(NO_TRIANGLE))
        .collect();
    // The near vertices in two halves, one after the other, so that the sorted sides of only
    // half the mesh are held at a time (they are the peak of the memory profile). Both halves
    // use one buffer, grown to the larger half.
    let mut buffer = Vec::new();
    let mut counts = EdgeCounts {
        unpaired: Some(0),
        ..EdgeCounts::default()
    };
    for (lo, hi) in [(0, nv / 2), (nv / 2, nv)] {
        let c;
        let near = lo as u32..hi as u32;
        (c, buffer) = match tris.len() <= DIRECTED_TRIANGLES {
            true => link_sides::<true>(tris, near, &across, buffer),
            false => link_sides::<false>(tris, near, &across, buffer),
        };
        counts = counts.add(c);
    }
    // Collected in place: the table becomes plain numbers without a copy.
    let across = across.into_iter().map(AtomicU32::into_inner).collect();
    (across, counts)
}

/// Links the sides whose smaller vertex lies in `near` to the next triangle around the same
/// edge, in `across`; returns the counts of those edges, and `filed`, the buffer the sides
/// were sorted in, for the next call.
fn link_sides<const DIRECTED: bool>(
    tris: &[[u32; 3]],
    near: std::ops::Range<u32>,
    across: &[AtomicU32],
    mut filed: Vec<AtomicU64>,
) -> (EdgeCounts, Vec<AtomicU64>) {
    // The three sides of a triangle as (smaller vertex, larger vertex, whether the side runs
    // from the smaller to the larger).
    let ends = |tri: &[u32; 3]| -> [(u32, u32, bool); 3] {
        let [a, b, c] = *tri;
        [
            (a.min(b), a.max(b), a < b),
            (b.min(c), b.max(c), b < c),
            (c.min(a), c.max(a), c < a),
        ]
    };
    // A side's key: its far vertex, then its number, then (when the numbers leave room) its
    // direction in the lowest bit. Sorted, the keys of a vertex are grouped by far vertex,
    // and by number within a group, either way.
    let shift = u32::from(DIRECTED);
    let key = |hi: u32, side: u64, forward: bool| {
        (u64::from(hi) << 32) | side << shift | u64::from(forward & DIRECTED)
    };
    let side_of = |key: u64| key as u32 >> shift;
    let nv = (near.end - near.start) as usize;
    // Each side (3 t + k) is filed under its smaller vertex: count, prefix-sum, fill. The
    // triangles are split into one run per thread, each counted and filed on its own; a run's
    // sides follow the previous run's at every vertex, so each bucket lists its sides in
    // triangle order, as one pass would.
    let per_run = tris.len().div_ceil(rayon::current_num_threads()).max(1);
    let mut slots: Vec<Vec<u32>> = tris
        .par_chunks(per_run)
        .map(|run| {
            let mut count = vec![0u32; nv];
            for tri in run {
                for (lo, _, _) in ends(tri) {
                    if near.contains(&lo) {
                        count[(lo - near.start) as usize] += 1;
                    }
                }
            }
            count
        })
        .collect();
    // start[v]: the first slot of vertex v; each run's count becomes its first slot at v.
    let mut start = vec![0u32; nv + 1];
    let mut next = 0u32;
    for v in 0..nv {
        start[v] = next;
        for run in &mut slots {
            let n = run[v];
            run[v] = next;
            next += n;
        }
    }
    start[nv] = next;
    // (far vertex << 32 | side) per side, grouped by near vertex. Each slot is written by
    // one run only; relaxed atomic stores let the runs share the table without locks.
    filed.clear();
    filed.reserve_exact(next as usize);
    filed.par_extend((0..next).into_par_iter().map(|_| AtomicU64::new(0)));
    tris.par_chunks(per_run)
        .zip(slots.par_iter_mut())
        .enumerate()
        .for_each(|(r, (run, slot))| {
            for (i, tri) in run.iter().enumerate() {
                let t = (r * per_run + i) as u64;
                for (k, (lo, hi, forward)) in ends(tri).into_iter().enumerate() {
                    if near.contains(&lo) {
                        let at = &mut slot[(lo - near.start) as usize];
                        filed[*at as usize]
                            .store(key(hi, 3 * t + k as u64, forward), Ordering::Relaxed);
                        *at += 1;
                    }
                }
            }
        });
    drop(slots);
    // Vertices in blocks, the blocks in parallel; each block's sides are a disjoint slice.
    const BLOCK: usize = 16 * 1024;
    let mut blocks: Vec<(usize, &mut [AtomicU64])> = Vec::with_capacity(nv / BLOCK + 1);
    let mut rest: &mut [AtomicU64] = &mut filed;
    let mut v0 = 0;
    while v0 < nv {
        let v1 = (v0 + BLOCK).min(nv);
        let (block, tail) = rest.split_at_mut((start[v1] - start[v0]) as usize);
        blocks.push((v0, block));
        rest = tail;
        v0 = v1;
    }
    let counts = blocks
        .into_par_iter()
        .map(|(v0, block)| {
            let base = start[v0] as usize;
            let (mut edges, mut open, mut non_manifold, mut unpaired) = (0u64, 0u64, 0u64, 0u64);
            let v1 = (v0 + BLOCK).min(nv);
            let mut bucket = Vec::new();
            for v in v0..v1 {
                let filed = &mut block[start[v] as usize - base..start[v + 1] as usize - base];
                // Grouped by the far vertex; sides in triangle order within a group.
                bucket.clear();
                bucket.extend(filed.iter_mut().map(|key| *key.get_mut()));
                sort_small(&mut bucket);
                let mut i = 0;
                while i < bucket.len() {
                    let far = bucket[i] >> 32;
                    let mut j = i + 1;
                    while j < bucket.len() && bucket[j] >> 32 == far {
                        j += 1;
                    }
                    edges += 1;
                    // An edge is paired when as many of its sides run one way as the other
                    // (a side from a vertex to itself runs neither way: it is never paired).
                    match j - i {
                        2 => unpaired += !(bucket[i] ^ bucket[i + 1]) & 1,
                        1 => {
                            open += 1;
                            unpaired += 1;
                        }
                        n => {
                            non_manifold += 1;
                            let forward = bucket[i..j].iter().filter(|&&k| k & 1 == 1).count();
                            unpaired += u64::from(2 * forward != n);
                        }
                    }
                    if j - i > 1 {
                        for m in i..j {
                            let side = side_of(bucket[m]);
                            let next = side_of(bucket[if m + 1 < j { m + 1 } else { i }]);
                            across[side as usize].store(next / 3, Ordering::Relaxed);
                        }
                    }
                    i = j;
                }
            }
            EdgeCounts {
                edges,
                open,
                non_manifold,
                unpaired: DIRECTED.then_some(unpaired),
            }
        })
        .reduce(
            || EdgeCounts {
                unpaired: DIRECTED.then_some(0),
                ..EdgeCounts::default()
            },
            EdgeCounts::add,
        );
    (counts, filed)
}

/// Sorts a vertex's sides: by insertion when there are few (a vertex of a closed mesh files
/// about six), where the general sort spends more on choosing its method than on sorting.
#[inline]
fn sort_small(bucket: &mut [u64]) {
    if bucket.len() > 16 {
        bucket.sort_unstable();
        return;
    }
    for i in 1..bucket.len() {
        let x = bucket[i];
        let mut j = i;
        while j > 0 && bucket[j - 1] > x {
            bucket[j] = bucket[j - 1];
            j -= 1;
        }
        bucket[j] = x;
    }
}

/// The representative of `x` in a union-find forest stored as parent links, halving the
/// path on the way up.
pub(crate) fn root(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

/// Union-find over vertices: the parent links after joining the corners of every triangle.
pub(crate) fn joined_vertices(mesh: &Mesh) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..mesh.vertices.len() as u32).collect();
    for tri in &mesh.triangles {
        let mut r0 = root(&mut parent, tri[0]);
        for &v in &tri[1..] {
            let r = root(&mut parent, v);
            if r != r0 {
                let (lo, hi) = (r.min(r0), r.max(r0));
                parent[hi as usize] = lo;
                r0 = lo;
            }
        }
    }
    parent
}

/// The number of bodies: sets of triangles linked through shared vertices. Each is one
/// root of the union-find forest with at least one other vertex below it (a triangle joins
/// three distinct vertices, so a vertex that some triangle uses is never alone in its set,
/// and a vertex alone in its set, left by a collapsed facet or handed over unused, is no
/// body): counted on the vertices rather than on another pass over the triangles. A root
/// with a set of two or more has one of them linked to it directly.
///
/// With several bodies, also whether one has a negative signed volume: each triangle's
/// moment summed to its body's root, the last root's slot kept (a body's triangles run
/// together in most files), on the forest already made, beside the neighbour table.
fn body_count(mesh: &Mesh) -> (u64, bool) {
    let mut parent = joined_vertices(mesh);
    let mut below = vec![false; parent.len()];
    for (v, &p) in parent.iter().enumerate() {
        if p != v as u32 {
            below[p as usize] = true;
        }
    }
    let count = parent
        .iter()
        .zip(&below)
        .enumerate()
        .filter(|&(v, (&p, &below))| below && p == v as u32)
        .count() as u64;
    drop(below);
    if count <= 1 {
        return (count, false);
    }
    let origin = mesh.bounds().centre();
    let mut slot = rustc_hash::FxHashMap::<u32, usize>::default();
    let mut volume: Vec<f64> = Vec::new();
    let (mut last_root, mut last_slot) = (u32::MAX, 0);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let r = root(&mut parent, tri[0]);
        if r != last_root {
            last_slot = *slot.entry(r).or_insert_with(|| {
                volume.push(0.0);
                volume.len() - 1
            });
            last_root = r;
        }
        let [a, b, c] = mesh.corners(t).map(|p| p - origin);
        volume[last_slot] += a.dot(b.cross(c));
    }
    (count, volume.iter().any(|&v| v < 0.0))
}

/// The body of each triangle, numbered from 0 in order of first appearance (computed on
/// demand: the analysis needs only the count, in [`Topology::bodies`]).
pub fn body_of_triangle(mesh: &Mesh) -> Vec<u32> {
    let mut parent = joined_vertices(mesh);
    let mut label = vec![u32::MAX; mesh.vertices.len()];
    let mut count = 0u32;
    mesh.triangles
        .iter()
        .map(|tri| {
            let r = root(&mut parent, tri[0]) as usize;
            if label[r] == u32::MAX {
                label[r] = count;
                count += 1;
            }
            label[r]
        })
        .collect()
}

/// The body of each vertex, numbered as [`body_of_triangle`] numbers the bodies (a vertex
/// of no triangle: 0), in one array of the vertices' size: the union-find's links are
/// turned into the labels in place (each vertex linked straight to its set's root, each
/// root given its body's number with the top bit set, then every vertex its root's), where
/// the bodies of the triangles and of the vertices would take both arrays and the forest's
/// two.
pub fn body_of_vertex(mesh: &Mesh) -> Vec<u32> {
    const ROOT: u32 = 1 << 31;
    let mut label = joined_vertices(mesh);
    debug_assert!(label.len() < ROOT as usize);
    for v in 0..label.len() as u32 {
        let r = root(&mut label, v);
        label[v as usize] = r;
    }
    // Each root its body's number, in order of first appearance over the triangles.
    let mut count = 0u32;
    for tri in &mesh.triangles {
        // A root numbered already holds its number, not its own index.
        let r = match label[tri[0] as usize] {
            l if l & ROOT != 0 => tri[0] as usize,
            l => l as usize,
        };
        if label[r] & ROOT == 0 {
            label[r] = ROOT | count;
            count += 1;
        }
    }
    // Every other vertex of a triangle takes its root's number (the roots' slots are read,
    // not written, in this pass); a vertex of no triangle is its own root, unnumbered.
    for v in 0..label.len() {
        let r = label[v];
        if r & ROOT == 0 {
            let at_root = label[r as usize];
            label[v] = if at_root & ROOT != 0 { at_root } else { 0 };
        }
    }
    for l in &mut label {
        *l &= !ROOT;
    }
    label
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::DVec3;

    fn tetrahedron() -> Mesh {
        Mesh {
            vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        }
    }

    #[test]
    fn closed_tetrahedron_has_six_edges_and_symmetric_neighbours() {
        let topology = Topology::new(&tetrahedron());
        assert_eq!(topology.edges, 6);
        assert_eq!(topology.open_edges, 0);
        assert_eq!(topology.non_manifold_edges, 0);
        assert_eq!(topology.bodies, 1);
        assert_eq!(topology.edge_sides().count(), 6);
        for t in 0..4 {
            for n in topology.neighbours(t) {
                assert!(topology.neighbours(n as usize).contains(&(t as u32)));
            }
        }
    }

    #[test]
    fn orientation_is_consistent_only_when_every_edge_runs_both_ways() {
        let mut mesh = tetrahedron();
        assert!(Topology::new(&mesh).closed_and_oriented(&mesh));
        // All facets turned round: still consistent (the solid's facets all face in).
        for tri in &mut mesh.triangles {
            tri.swap(1, 2);
        }
        assert!(Topology::new(&mesh).closed_and_oriented(&mesh));
        // One facet turned round: its three edges now run the same way as a neighbour's.
        mesh.triangles[0].swap(1, 2);
        assert!(!Topology::new(&mesh).closed_and_oriented(&mesh));
        // One facet removed: open.
        let mut open = tetrahedron();
        open.triangles.pop();
        assert!(!Topology::new(&open).closed_and_oriented(&open));
    }

    #[test]
    fn edges_pair_up_when_as_many_sides_run_each_way() {
        let mut mesh = tetrahedron();
        let topology = Topology::new(&mesh);
        assert_eq!(topology.unpaired_edges, Some(0));
        // One facet turned round: its three edges are run the same way twice.
        mesh.triangles[0].swap(1, 2);
        assert_eq!(Topology::new(&mesh).unpaired_edges, Some(3));
        // Every facet doubled, one copy turned round: four sides an edge (non-manifold),
        // two each way, paired; not oriented.
        let mut doubled = tetrahedron();
        let turned: Vec<[u32; 3]> = doubled
            .triangles
            .iter()
            .map(|t| [t[0], t[2], t[1]])
            .collect();
        doubled.triangles.extend(turned);
        let topology = Topology::new(&doubled);
        assert_eq!(topology.non_manifold_edges, 6);
        assert_eq!(topology.unpaired_edges, Some(0));
        assert!(!topology.closed_and_oriented(&doubled));
        // A facet without area on an edge of the solid: its side from a vertex to itself runs
        // neither way (unpaired), and its other two sides, on one edge, run it both ways.
        let mut flat = tetrahedron();
        let [a, b, _] = flat.triangles[0];
        flat.triangles.push([a, a, b]);
        let topology = Topology::new(&flat);
        assert_eq!(topology.unpaired_edges, Some(1));
        // The orientation is then checked side by side, as before the count.
        assert_eq!(
            topology.closed_and_oriented(&flat),
            oriented_from_both_sides(&topology, &flat)
        );
    }

    /// The check from both sides of every edge, which `closed_and_oriented` does from one.
    fn oriented_from_both_sides(topology: &Topology, mesh: &Mesh) -> bool {
        topology.open_edges == 0
            && topology.non_manifold_edges == 0
            && mesh.triangles.iter().enumerate().all(|(t, tri)| {
                (0..3).all(|k| {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let n = topology.across[3 * t + k];
                    n != NO_TRIANGLE && {
                        let other = mesh.triangles[n as usize];
                        (0..3).any(|j| other[j] == b && other[(j + 1) % 3] == a)
                    }
                })
            })
    }

    #[test]
    fn orientation_checked_from_one_side_of_each_edge_agrees_with_both_sides() {
        // Closed samples as made, then with each of their first facets turned round on its
        // own, and with a facet and one of its neighbours turned round together.
        for info in crate::samples::SAMPLES {
            let mesh = crate::samples::sample(info.name).expect("a sample");
            let topology = Topology::new(&mesh);
            let mut cases = vec![mesh.clone()];
            for f in 0..mesh.triangles.len().min(40) {
                let mut turned = mesh.clone();
                turned.triangles[f].swap(1, 2);
                cases.push(turned.clone());
                if let Some(&n) = topology.neighbours(f).first() {
                    turned.triangles[n as usize].swap(1, 2);
                    cases.push(turned);
                }
            }
            for case in &cases {
                let topology = Topology::new(case);
                assert_eq!(
                    topology.closed_and_oriented(case),
                    oriented_from_both_sides(&topology, case),
                    "{}",
                    info.name
                );
            }
            assert!(
                Topology::new(&mesh).closed_and_oriented(&mesh),
                "{}",
                info.name
            );
        }
    }

    /// Asserts that the topology's neighbours and edge counts are the brute force's, and
    /// gives its open and non-manifold edge counts.
    fn matches_brute_force(mesh: &Mesh, label: &str) -> (u64, u64) {
        let (neighbours, edges, open, non_manifold, unpaired) = brute_force(mesh);
        let topology = Topology::new(mesh);
        let found: Vec<[u32; 3]> = (0..neighbours.len())
            .map(|t| topology.neighbours(t))
            .collect();
        assert_eq!(found, neighbours, "{label}");
        assert_eq!(
            (
                topology.edges,
                topology.open_edges,
                topology.non_manifold_edges,
                topology.unpaired_edges,
            ),
            (edges, open, non_manifold, Some(unpaired)),
            "{label}"
        );
        (open, non_manifold)
    }

    /// Every edge's triangles from a map keyed by the edge, the plain way.
    fn brute_force(mesh: &Mesh) -> (Vec<[u32; 3]>, u64, u64, u64, u64) {
        let key = |a: u32, b: u32| (a.min(b), a.max(b));
        let mut on_edge: std::collections::BTreeMap<(u32, u32), Vec<u32>> = Default::default();
        // Per edge, the sides run from its smaller vertex to its larger less the others.
        let mut balance: std::collections::BTreeMap<(u32, u32), i64> = Default::default();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                on_edge.entry(key(a, b)).or_default().push(t as u32);
                // A side from a vertex to itself runs neither way: never paired.
                *balance.entry(key(a, b)).or_default() += match a.cmp(&b) {
                    std::cmp::Ordering::Less => 1,
                    std::cmp::Ordering::Greater => -1,
                    std::cmp::Ordering::Equal => 1 << 20,
                };
            }
        }
        let neighbours = mesh
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                std::array::from_fn(|k| {
                    let group = &on_edge[&key(tri[k], tri[(k + 1) % 3])];
                    let at = group.iter().position(|&s| s == t as u32).unwrap();
                    match group.len() {
                        1 => NO_TRIANGLE,
                        n => group[(at + 1) % n],
                    }
                })
            })
            .collect();
        let sizes = || on_edge.values().map(Vec::len);
        (
            neighbours,
            on_edge.len() as u64,
            sizes().filter(|&n| n == 1).count() as u64,
            sizes().filter(|&n| n > 2).count() as u64,
            balance.values().filter(|&&b| b != 0).count() as u64,
        )
    }

    #[test]
    fn neighbours_match_a_map_of_edges_on_ragged_meshes() {
        // Random triangles over few vertices: open, shared and heavily non-manifold edges,
        // busy vertices, and more triangles than one block of the parallel search.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % u64::from(n)) as u32
        };
        for vertices in [4u32, 12, 60, 3000] {
            let mut triangles = Vec::new();
            while triangles.len() < 20_000 {
                let tri = [next(vertices), next(vertices), next(vertices)];
                if tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2] {
                    triangles.push(tri);
                }
            }
            let mesh = Mesh {
                vertices: vec![DVec3::ZERO; vertices as usize],
                triangles,
            };
            matches_brute_force(&mesh, &format!("{vertices} vertices"));
        }
    }

    #[test]
    fn neighbours_of_few_sides_a_vertex_match_a_map_of_edges() {
        // A closed torus of quads (about six sides a vertex: the insertion sort), its vertices
        // numbered in a scrambled order; then with some triangles repeated, some turned and
        // some removed, so that small vertices also hold open and non-manifold edges.
        let (n, m) = (40u32, 30u32);
        // 997 is prime to n m: a one-to-one scramble.
        let number = |i: u32, j: u32| ((i % n) * m + (j % m)) * 997 % (n * m);
        let mut triangles = Vec::new();
        for i in 0..n {
            for j in 0..m {
                let (a, b, c, d) = (
                    number(i, j),
                    number(i + 1, j),
                    number(i + 1, j + 1),
                    number(i, j + 1),
                );
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
        let closed = triangles.clone();
        let mut ragged = triangles.clone();
        for t in (0..triangles.len()).step_by(7) {
            ragged.push(triangles[t]);
        }
        for t in (0..triangles.len()).step_by(11) {
            ragged[t].swap(0, 1);
        }
        ragged.retain(|tri| tri.iter().sum::<u32>() % 13 != 0);
        for (name, triangles) in [("closed", closed), ("ragged", ragged)] {
            let mesh = Mesh {
                vertices: vec![DVec3::ZERO; (n * m) as usize],
                triangles,
            };
            let (open, non_manifold) = matches_brute_force(&mesh, name);
            if name == "closed" {
                assert_eq!((open, non_manifold), (0, 0));
            } else {
                assert!(open > 0 && non_manifold > 0);
            }
        }
    }

    /// Bodies counted on the roots of the vertices' forest are those counted on the
    /// triangles (the count this replaced), with vertices no triangle uses among them.
    #[test]
    fn bodies_counted_on_the_forest_match_those_counted_on_the_triangles() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |n: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % u64::from(n)) as u32
        };
        for (vertices, triangles) in [(10u32, 2), (200, 40), (3000, 900), (3000, 3000), (50, 400)] {
            let mut tris = Vec::new();
            while tris.len() < triangles {
                let tri = [next(vertices), next(vertices), next(vertices)];
                if tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2] {
                    tris.push(tri);
                }
            }
            let mesh = Mesh {
                vertices: vec![DVec3::ZERO; vertices as usize],
                triangles: tris,
            };
            let mut parent = joined_vertices(&mesh);
            let mut seen = std::collections::BTreeSet::new();
            for tri in &mesh.triangles {
                seen.insert(root(&mut parent, tri[0]));
            }
            assert_eq!(
                body_count(&mesh).0,
                seen.len() as u64,
                "{vertices} vertices"
            );
            // Each vertex's body is the body of the triangles it is a corner of (numbered as
            // `body_of_triangle` numbers them), 0 for a vertex of none.
            let mut expected = vec![0u32; vertices as usize];
            for (tri, &b) in mesh.triangles.iter().zip(&body_of_triangle(&mesh)) {
                for &v in tri {
                    expected[v as usize] = b;
                }
            }
            assert_eq!(body_of_vertex(&mesh), expected, "{vertices} vertices");
        }
    }

    #[test]
    fn open_and_non_manifold_edges_are_counted() {
        let mut mesh = tetrahedron();
        mesh.triangles.pop();
        let topology = Topology::new(&mesh);
        assert_eq!((topology.edges, topology.open_edges), (6, 3));
        assert_eq!(topology.edge_sides().count(), 3);
        // A fin on edge 0-1: three triangles share it.
        let mut mesh = tetrahedron();
        mesh.vertices.push(DVec3::new(0.5, -1.0, 0.0));
        mesh.triangles.push([0, 1, 4]);
        let topology = Topology::new(&mesh);
        assert_eq!(topology.non_manifold_edges, 1);
        assert_eq!(topology.open_edges, 2);
        assert_eq!(topology.edge_sides().count(), 5);
    }
}
