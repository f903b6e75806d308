//! Which points of the projection plane the part covers, and how low it is there: the
//! triangles projected along D, binned in a uniform grid, only in the cells that hold a
//! point to be asked about.

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use crate::math::{DVec2, DVec3};
use crate::mesh::Mesh;

/// A cell that holds no probe point.
const UNASKED: u32 = u32::MAX;

/// The projected triangles in the cells of a uniform grid over the projection plane, in one
/// flat array: `items[start[s]..start[s + 1]]` are the triangles overlapping the cell whose
/// slot is `s`. Only the cells asked about (those holding a probe point given to
/// [`Cover::new`]) have a slot, so the arrays grow with the probes, not with the part.
pub(super) struct Cover<'a> {
    mesh: &'a Mesh,
    /// Each vertex in frame coordinates: (u, w) in the plane, height along D.
    at: &'a [DVec3],
    /// The body of each triangle, when the part has several (a body covers only itself).
    body: Option<&'a [u32]>,
    lo: DVec2,
    cell: f64,
    n_u: usize,
    n_w: usize,
    /// Per cell, row by row: its slot, or [`UNASKED`].
    slot: Vec<u32>,
    /// Where each slot's triangles begin in `items` (one more at the end).
    start: Vec<u32>,
    items: Vec<u32>,
}

impl<'a> Cover<'a> {
    /// Bins every triangle that is not parallel to D (|n.D| >= 1e-6 |n|, the module's rule
    /// for the faces that belong to neither side by their facing alone; a wall along D covers
    /// no area) into the cells that hold one of `probes`. Counted, then filled, both passes
    /// over the triangles in parallel: the order of the triangles within a cell is not fixed,
    /// and does not matter to [`Cover::probe`] (a minimum).
    pub(super) fn new(
        mesh: &'a Mesh,
        at: &'a [DVec3],
        body: Option<&'a [u32]>,
        probes: impl Iterator<Item = DVec2> + Clone,
    ) -> Cover<'a> {
        let plane = |v: u32| at[v as usize].truncate();
        let (lo, hi) = at
            .par_iter()
            .fold(
                || (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(p.truncate()), hi.max(p.truncate())),
            )
            .reduce(
                || (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
        let size = (hi - lo).max(DVec2::splat(1e-12));
        // About two triangles per cell.
        let cells_wanted = (mesh.triangles.len() / 2).clamp(1, 1 << 22) as f64;
        let cell = (size.x * size.y / cells_wanted).sqrt().max(1e-12);
        let n_u = ((size.x / cell).ceil() as usize).clamp(1, 1 << 12);
        let n_w = ((size.y / cell).ceil() as usize).clamp(1, 1 << 12);
        let cell = (size.x / n_u as f64).max(size.y / n_w as f64);
        let mut cover = Cover {
            mesh,
            at,
            body,
            lo,
            cell,
            n_u,
            n_w,
            slot: vec![UNASKED; n_u * n_w],
            start: Vec::new(),
            items: Vec::new(),
        };
        let mut slots = 0u32;
        for p in probes {
            if let Some(c) = cover.cell_of(p) {
                if cover.slot[c] == UNASKED {
                    cover.slot[c] = slots;
                    slots += 1;
                }
            }
        }
        let slot = &cover.slot;
        let counts: Vec<AtomicU32> = (0..=slots).map(|_| AtomicU32::new(0)).collect();
        let covering = |t: usize| -> Option<[DVec2; 3]> {
            let tri = mesh.triangles[t];
            let p = tri.map(plane);
            let n_d = (p[1] - p[0]).perp_dot(p[2] - p[0]);
            let [a, b, c] = mesh.corners(t);
            (n_d.abs() >= 1e-6 * (b - a).cross(c - a).length() && n_d != 0.0).then_some(p)
        };
        (0..mesh.triangles.len()).into_par_iter().for_each(|t| {
            if let Some(p) = covering(t) {
                for_cells(&p, lo, cell, n_u, n_w, &mut |c| {
                    if slot[c] != UNASKED {
                        counts[slot[c] as usize + 1].fetch_add(1, Ordering::Relaxed);
                    }
                });
            }
        });
        let mut start: Vec<u32> = counts.into_iter().map(AtomicU32::into_inner).collect();
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let fill: Vec<AtomicU32> = start.iter().map(|&s| AtomicU32::new(s)).collect();
        let items: Vec<AtomicU32> = (0..start[slots as usize])
            .map(|_| AtomicU32::new(0))
            .collect();
        (0..mesh.triangles.len()).into_par_iter().for_each(|t| {
            if let Some(p) = covering(t) {
                for_cells(&p, lo, cell, n_u, n_w, &mut |c| {
                    if slot[c] != UNASKED {
                        let at = fill[slot[c] as usize].fetch_add(1, Ordering::Relaxed);
                        items[at as usize].store(t as u32, Ordering::Relaxed);
                    }
                });
            }
        });
        cover.start = start;
        cover.items = items.into_iter().map(AtomicU32::into_inner).collect();
        cover
    }

    fn cell_of(&self, p: DVec2) -> Option<usize> {
        let d = p - self.lo;
        if !(d.x >= 0.0 && d.y >= 0.0) {
            return None;
        }
        let (u, w) = ((d.x / self.cell) as usize, (d.y / self.cell) as usize);
        (u < self.n_u && w < self.n_w).then_some(w * self.n_u + u)
    }

    /// The lowest height along D at which a triangle of `body` covers `p` (on its boundary
    /// counts), or `None` where none does. `p` must have been one of the probes.
    pub(super) fn probe(&self, p: DVec2, body: u32) -> Option<f64> {
        let c = self.cell_of(p)?;
        let s = self.slot[c];
        debug_assert!(s != UNASKED, "a point that was not a probe");
        if s == UNASKED {
            return None;
        }
        let mut lowest: Option<f64> = None;
        for &t in &self.items[self.start[s as usize] as usize..self.start[s as usize + 1] as usize]
        {
            if self.body.is_some_and(|b| b[t as usize] != body) {
                continue;
            }
            let [a, b, c] = self.mesh.triangles[t as usize].map(|v| self.at[v as usize]);
            let (pa, pb, pc) = (a.truncate(), b.truncate(), c.truncate());
            let (e0, e1, e2) = (
                (pb - pa).perp_dot(p - pa),
                (pc - pb).perp_dot(p - pb),
                (pa - pc).perp_dot(p - pc),
            );
            let inside =
                (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0);
            if !inside {
                continue;
            }
            // The height of the triangle's plane at p: barycentric weights, each the share of
            // the projected area opposite its corner (all of one sign inside).
            let area = e0 + e1 + e2;
            let h = (e1 * a.z + e2 * b.z + e0 * c.z) / area;
            lowest = Some(lowest.map_or(h, |l: f64| l.min(h)));
        }
        lowest
    }
}

/// Calls `f` with each cell a projected triangle overlaps, row by row: in each row, the x
/// range of the triangle clipped to the row's slab (a thin sliver crossing the grid touches
/// few cells per row, not its whole bounding box).
fn for_cells(
    t: &[DVec2; 3],
    lo: DVec2,
    cell: f64,
    n_u: usize,
    n_w: usize,
    f: &mut dyn FnMut(usize),
) {
    let index = |x: f64, n: usize| (((x / cell).floor().max(0.0)) as usize).min(n - 1);
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
}
