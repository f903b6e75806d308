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

use rayon::prelude::*;

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
        (self.second > f64::NEG_INFINITY).then(|| self.first - self.second)
    }

    #[inline]
    fn add(&mut self, height: f64, triangle: u32) {
        if height > self.first {
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

/// Casts every ray of each lattice against the triangles, in parallel over lattices.
///
/// `projected` holds each vertex as (u, w, height). The result has one `Vec<Hit>` per
/// lattice, indexed `j * n_u + i`.
pub fn cast(projected: &[DVec3], triangles: &[[u32; 3]], lattices: &[RayLattice]) -> Vec<Vec<Hit>> {
    lattices
        .par_iter()
        .map(|lattice| cast_one(projected, triangles, lattice))
        .collect()
}

fn cast_one(projected: &[DVec3], triangles: &[[u32; 3]], lattice: &RayLattice) -> Vec<Hit> {
    let mut hits = vec![Hit::MISS; lattice.n_u * lattice.n_w];
    for (t, tri) in triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|v| projected[v as usize]);
        draw_triangle(a, b, c, t as u32, lattice, &mut hits);
    }
    hits
}

/// The edge function of edge p->q at s, evaluated from the edge's lexicographically smaller
/// end so that the two triangles sharing the edge get bit-identical magnitudes.
#[inline]
fn edge_function(p: DVec2, q: DVec2, s: DVec2) -> f64 {
    if (p.x, p.y) < (q.x, q.y) {
        orient2d(p, q, s)
    } else {
        -orient2d(q, p, s)
    }
}

/// Whether a counter-clockwise triangle owns the points on its edge p->q: the top-left rule
/// (left edges go down, top edges go left, with w pointing up).
#[inline]
fn owns_edge(p: DVec2, q: DVec2) -> bool {
    q.y < p.y || (q.y == p.y && q.x < p.x)
}

/// The range of lattice indices whose coordinate `origin + i * spacing` lies in [lo, hi].
#[inline]
fn index_range(origin: f64, spacing: f64, n: usize, lo: f64, hi: f64) -> Option<(usize, usize)> {
    let at = |i: i64| origin + i as f64 * spacing;
    let mut i0 = ((lo - origin) / spacing).ceil().max(0.0) as i64;
    let mut i1 = ((hi - origin) / spacing).floor().min(n as f64 - 1.0) as i64;
    // Division rounds; fix the ends against the exact sample positions.
    if i0 > 0 && at(i0 - 1) >= lo {
        i0 -= 1;
    }
    if at(i0) < lo {
        i0 += 1;
    }
    if i1 + 1 < n as i64 && at(i1 + 1) <= hi {
        i1 += 1;
    }
    if i1 >= 0 && at(i1) > hi {
        i1 -= 1;
    }
    (i0 <= i1 && i1 >= 0 && i0 < n as i64).then_some((i0 as usize, i1 as usize))
}

#[inline]
fn draw_triangle(a: DVec3, b: DVec3, c: DVec3, t: u32, lattice: &RayLattice, hits: &mut [Hit]) {
    let (pa, mut pb, mut pc) = (a.truncate(), b.truncate(), c.truncate());
    let (ha, mut hb, mut hc) = (a.z, b.z, c.z);
    let area2 = orient2d(pa, pb, pc);
    if area2 == 0.0 {
        return; // seen edge-on
    }
    if area2 < 0.0 {
        std::mem::swap(&mut pb, &mut pc);
        std::mem::swap(&mut hb, &mut hc);
    }
    let lo = pa.min(pb).min(pc);
    let hi = pa.max(pb).max(pc);
    let o = lattice.origin;
    let Some((i0, i1)) = index_range(o.x, lattice.spacing, lattice.n_u, lo.x, hi.x) else {
        return;
    };
    let Some((j0, j1)) = index_range(o.y, lattice.spacing, lattice.n_w, lo.y, hi.y) else {
        return;
    };
    let (own_ab, own_bc, own_ca) = (owns_edge(pa, pb), owns_edge(pb, pc), owns_edge(pc, pa));
    let inside = |e: f64, owned: bool| e > 0.0 || (e == 0.0 && owned);
    for j in j0..=j1 {
        let y = o.y + j as f64 * lattice.spacing;
        let row = j * lattice.n_u;
        for i in i0..=i1 {
            let s = DVec2::new(o.x + i as f64 * lattice.spacing, y);
            let e_bc = edge_function(pb, pc, s);
            let e_ca = edge_function(pc, pa, s);
            let e_ab = edge_function(pa, pb, s);
            if inside(e_bc, own_bc) && inside(e_ca, own_ca) && inside(e_ab, own_ab) {
                let height = (e_bc * ha + e_ca * hb + e_ab * hc) / (e_bc + e_ca + e_ab);
                hits[row + i].add(height, t);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let hits = &cast(&v, &tris, &[lattice(9, 0.5)])[0];
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
        let hits = &cast(&v, &[[0, 1, 2]], &[lattice(5, 1.0)])[0];
        for (k, h) in hits.iter().enumerate() {
            let (x, y) = ((k % 5) as f64, (k / 5) as f64);
            let z = (x + 1.0) + 2.0 * (y + 1.0);
            assert!((h.first - z).abs() < 1e-12, "{x} {y}: {}", h.first);
            assert_eq!(h.thickness(), None);
        }
    }

    #[test]
    fn index_range_is_exact_at_sample_positions() {
        assert_eq!(index_range(0.0, 0.25, 100, 0.75, 0.75), Some((3, 3)));
        // 3 * 0.1 rounds above 0.3: the sample is not in [0.3, 0.3], but it is in its own
        // position's range.
        assert_eq!(index_range(0.0, 0.1, 100, 0.3, 0.3), None);
        let at3 = 3.0 * 0.1;
        assert_eq!(index_range(0.0, 0.1, 100, at3, at3), Some((3, 3)));
        assert_eq!(index_range(0.0, 0.1, 100, 0.31, 0.39), None);
        assert_eq!(index_range(0.0, 1.0, 10, -5.0, 50.0), Some((0, 9)));
        assert_eq!(index_range(0.0, 1.0, 10, 10.5, 50.0), None);
        assert_eq!(index_range(0.0, 1.0, 10, -5.0, -0.5), None);
    }
}
