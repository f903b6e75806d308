//! Edges and bodies of a welded mesh.

use super::Mesh;

/// Marks a missing second triangle of an edge.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// An undirected edge with the triangles that use it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Edge {
    /// The smaller vertex index.
    pub a: u32,
    /// The larger vertex index.
    pub b: u32,
    /// The first two triangles using the edge; the second is [`NO_TRIANGLE`] on an open edge.
    pub triangles: [u32; 2],
    /// How many triangles use the edge (more than 2 on a non-manifold edge).
    pub uses: u32,
}

/// Edges, open and non-manifold edge counts, and connected bodies of a mesh.
#[derive(Debug, Clone, Default)]
pub struct Topology {
    /// Every undirected edge once, ordered by (a, b).
    pub edges: Vec<Edge>,
    /// Edges with one triangle.
    pub open_edges: u64,
    /// Edges with more than two triangles.
    pub non_manifold_edges: u64,
    /// Number of bodies: sets of triangles linked through shared vertices.
    pub bodies: u64,
    /// The body of each triangle, numbered from 0 in order of first appearance.
    pub body_of_triangle: Vec<u32>,
}

impl Topology {
    /// Builds the edge table (grouped per smaller vertex, no global sort) and the bodies.
    pub fn new(mesh: &Mesh) -> Topology {
        let nv = mesh.vertices.len();
        // Each undirected edge is filed under its smaller vertex: count, prefix-sum, fill.
        let mut start = vec![0u32; nv + 1];
        for tri in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                start[a.min(b) as usize + 1] += 1;
            }
        }
        for i in 0..nv {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut slots = vec![(0u32, 0u32); 3 * mesh.triangles.len()];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let lo = a.min(b) as usize;
                slots[fill[lo] as usize] = (a.max(b), t as u32);
                fill[lo] += 1;
            }
        }
        drop(fill);
        let mut edges = Vec::with_capacity(slots.len() / 2 + 1);
        let (mut open, mut non_manifold) = (0u64, 0u64);
        for a in 0..nv {
            let bucket = &mut slots[start[a] as usize..start[a + 1] as usize];
            bucket.sort_unstable();
            let mut i = 0;
            while i < bucket.len() {
                let b = bucket[i].0;
                let mut j = i + 1;
                while j < bucket.len() && bucket[j].0 == b {
                    j += 1;
                }
                let uses = (j - i) as u32;
                match uses {
                    1 => open += 1,
                    2 => {}
                    _ => non_manifold += 1,
                }
                edges.push(Edge {
                    a: a as u32,
                    b,
                    triangles: [
                        bucket[i].1,
                        if uses > 1 { bucket[i + 1].1 } else { NO_TRIANGLE },
                    ],
                    uses,
                });
                i = j;
            }
        }
        drop(slots);
        let (bodies, body_of_triangle) = bodies(mesh);
        Topology {
            edges,
            open_edges: open,
            non_manifold_edges: non_manifold,
            bodies,
            body_of_triangle,
        }
    }
}

/// Union-find over vertices: triangles sharing a vertex are in the same body.
fn bodies(mesh: &Mesh) -> (u64, Vec<u32>) {
    let mut parent: Vec<u32> = (0..mesh.vertices.len() as u32).collect();
    fn root(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let up = parent[parent[x as usize] as usize];
            parent[x as usize] = up;
            x = up;
        }
        x
    }
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
    let mut label = vec![u32::MAX; mesh.vertices.len()];
    let mut count = 0u32;
    let body_of_triangle = mesh
        .triangles
        .iter()
        .map(|tri| {
            let r = root(&mut parent, tri[0]) as usize;
            if label[r] == u32::MAX {
                label[r] = count;
                count += 1;
            }
            label[r]
        })
        .collect();
    (count as u64, body_of_triangle)
}
