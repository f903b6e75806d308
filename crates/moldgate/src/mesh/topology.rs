//! Edges and bodies of a welded mesh.
//!
//! Edges are not stored one by one: each triangle records the triangle across each of its
//! three edges (4 bytes per edge side), which is all that the parting line and the counts
//! need, at a fifth of the memory of an edge list.

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use super::Mesh;

/// Marks a missing neighbour: the edge is open (used by one triangle only).
pub const NO_TRIANGLE: u32 = u32::MAX;

/// Neighbours, edge counts and connected bodies of a mesh.
#[derive(Debug, Clone, Default)]
pub struct Topology {
    /// For triangle t and k in 0..3, the triangle across the edge from corner k to corner
    /// k + 1, or [`NO_TRIANGLE`] on an open edge. On a non-manifold edge (more than two
    /// triangles), each triangle records the next one around the edge in index order, the
    /// last one the first.
    pub neighbours: Vec<[u32; 3]>,
    /// Distinct undirected edges.
    pub edges: u64,
    /// Edges with one triangle.
    pub open_edges: u64,
    /// Edges with more than two triangles.
    pub non_manifold_edges: u64,
    /// Number of bodies: sets of triangles linked through shared vertices (see
    /// [`body_of_triangle`] for which triangle is in which).
    pub bodies: u64,
}

impl Topology {
    /// Builds the neighbour table (edges grouped under their smaller vertex, no global
    /// sort) and, in parallel with it, the bodies.
    pub fn new(mesh: &Mesh) -> Topology {
        let ((neighbours, edges, open_edges, non_manifold_edges), bodies) =
            rayon::join(|| neighbours(mesh), || body_count(mesh));
        Topology {
            neighbours,
            edges,
            open_edges,
            non_manifold_edges,
            bodies,
        }
    }

    /// Every edge between exactly two triangles once, as (t, k, n): triangle t, its edge from
    /// corner k to corner k + 1, and the triangle n across it, with t < n. Open and
    /// non-manifold edges are left out.
    pub fn edge_sides(&self) -> impl Iterator<Item = (u32, usize, u32)> + '_ {
        let all = &self.neighbours;
        // Without non-manifold edges every neighbour relation is mutual; with them, a
        // triangle's neighbour may point on to a third one, and such pairs are left out.
        let check = self.non_manifold_edges > 0;
        all.iter().enumerate().flat_map(move |(t, across)| {
            (0..3).filter_map(move |k| {
                let n = across[k];
                (n != NO_TRIANGLE
                    && n > t as u32
                    && (!check || all[n as usize].contains(&(t as u32))))
                .then_some((t as u32, k, n))
            })
        })
    }
}

type EdgeTable = (Vec<[u32; 3]>, u64, u64, u64);

fn neighbours(mesh: &Mesh) -> EdgeTable {
    let tris = &mesh.triangles;
    let nv = mesh.vertices.len();
    // Each side is written once, by the thread that owns its near vertex; relaxed atomic
    // stores let the threads share the table without locks.
    let across: Vec<AtomicU32> = (0..3 * tris.len())
        .map(|_| AtomicU32::new(NO_TRIANGLE))
        .collect();
    // The near vertices in two halves, one after the other, so that the sorted sides of only
    // half the mesh are held at a time (they are the peak of the memory profile).
    let mut counts = (0, 0, 0);
    for (lo, hi) in [(0, nv / 2), (nv / 2, nv)] {
        let c = link_sides(tris, lo as u32..hi as u32, &across);
        counts = (counts.0 + c.0, counts.1 + c.1, counts.2 + c.2);
    }
    let (edges, open, non_manifold) = counts;
    let neighbours: Vec<[u32; 3]> = across
        .chunks_exact(3)
        .map(|c| std::array::from_fn(|k| c[k].load(Ordering::Relaxed)))
        .collect();
    (neighbours, edges, open, non_manifold)
}

/// Links the sides whose smaller vertex lies in `near` to the next triangle around the same
/// edge, in `across`; returns the (edges, open, non-manifold) counts of those edges.
fn link_sides(
    tris: &[[u32; 3]],
    near: std::ops::Range<u32>,
    across: &[AtomicU32],
) -> (u64, u64, u64) {
    // The three sides of a triangle as (smaller vertex, larger vertex).
    let ends = |tri: &[u32; 3]| -> [(u32, u32); 3] {
        let [a, b, c] = *tri;
        [
            (a.min(b), a.max(b)),
            (b.min(c), b.max(c)),
            (c.min(a), c.max(a)),
        ]
    };
    let nv = (near.end - near.start) as usize;
    // Each side (3 t + k) is filed under its smaller vertex: count, prefix-sum, fill.
    let mut start = vec![0u32; nv + 1];
    for tri in tris {
        for (lo, _) in ends(tri) {
            if near.contains(&lo) {
                start[(lo - near.start) as usize + 1] += 1;
            }
        }
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    // (far vertex << 32 | side) per side, grouped by near vertex.
    let mut sides = vec![0u64; start[nv] as usize];
    {
        let mut fill = start.clone();
        for (t, tri) in tris.iter().enumerate() {
            for (k, (lo, hi)) in ends(tri).into_iter().enumerate() {
                if near.contains(&lo) {
                    let side = 3 * t as u64 + k as u64;
                    let at = &mut fill[(lo - near.start) as usize];
                    sides[*at as usize] = (u64::from(hi) << 32) | side;
                    *at += 1;
                }
            }
        }
    }
    let side_of = |key: u64| key as u32;
    // Vertices in blocks, the blocks in parallel; each block's sides are a disjoint slice.
    const BLOCK: usize = 16 * 1024;
    let mut blocks: Vec<(usize, &mut [u64])> = Vec::with_capacity(nv / BLOCK + 1);
    let mut rest: &mut [u64] = &mut sides;
    let mut v0 = 0;
    while v0 < nv {
        let v1 = (v0 + BLOCK).min(nv);
        let (block, tail) = rest.split_at_mut((start[v1] - start[v0]) as usize);
        blocks.push((v0, block));
        rest = tail;
        v0 = v1;
    }
    blocks
        .into_par_iter()
        .map(|(v0, block)| {
            let base = start[v0] as usize;
            let (mut edges, mut open, mut non_manifold) = (0u64, 0u64, 0u64);
            let v1 = (v0 + BLOCK).min(nv);
            for v in v0..v1 {
                let bucket = &mut block[start[v] as usize - base..start[v + 1] as usize - base];
                // Grouped by the far vertex; sides in triangle order within a group.
                bucket.sort_unstable();
                let mut i = 0;
                while i < bucket.len() {
                    let far = bucket[i] >> 32;
                    let mut j = i + 1;
                    while j < bucket.len() && bucket[j] >> 32 == far {
                        j += 1;
                    }
                    edges += 1;
                    match j - i {
                        1 => open += 1,
                        2 => {}
                        _ => non_manifold += 1,
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
            (edges, open, non_manifold)
        })
        .reduce(|| (0, 0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2))
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
fn joined_vertices(mesh: &Mesh) -> Vec<u32> {
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

/// The number of bodies: sets of triangles linked through shared vertices.
fn body_count(mesh: &Mesh) -> u64 {
    let mut parent = joined_vertices(mesh);
    let mut seen = vec![false; mesh.vertices.len()];
    let mut count = 0;
    for tri in &mesh.triangles {
        let r = root(&mut parent, tri[0]) as usize;
        count += u64::from(!seen[r]);
        seen[r] = true;
    }
    count
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
        for (t, across) in topology.neighbours.iter().enumerate() {
            for &n in across {
                assert!(topology.neighbours[n as usize].contains(&(t as u32)));
            }
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
