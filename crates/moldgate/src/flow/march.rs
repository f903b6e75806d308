//! Shortest flow paths through the solid cells: the arrival field of a melt front.
//!
//! The field T solves the eikonal equation |grad T| = c(x) (c is the cost of a millimetre
//! of path at x: 1 for flow length, the flow resistance for fill order) by first-order fast
//! marching (Sethian) over the six face neighbours, as the front is accepted in order of T.
//! Each cell also takes the best straight step from any of its 26 neighbours,
//! T(u) + |u - v| (c(u) + c(v)) / 2, so that walls one cell thick, whose cells touch only at
//! edges or corners, still pass the melt. Fast marching alone would stop at such a wall;
//! the straight steps alone (Dijkstra on the 26-neighbour graph) overestimate lengths by up
//! to 8 % in directions between the axes and diagonals, and that error does not shrink as
//! cells get smaller. The first-order error of fast marching does.
//!
//! Cells of a source are seeded with their exact straight distance to the source point
//! (within 1.5 cells), which removes most of fast marching's error near a point source.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::math::DVec3;

use super::voxel::{neighbour_offsets, Voxels};

/// A source of the melt: a point, seeded into the cells around it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Source {
    /// The point, mm.
    pub point: DVec3,
    /// The cell that holds it (see [`Voxels::cell_near`]).
    pub cell: u32,
}

/// An arrival field: T per solid cell (`f64::INFINITY` where the melt does not reach), and
/// for fields with several sources, which source reached each cell first.
#[derive(Debug, Clone)]
pub struct Field {
    /// Arrival value per cell: mm of path, weighted by the cost.
    pub t: Vec<f64>,
    /// Index of the source whose front arrived first, per cell (`u32::MAX` if unreached).
    pub source: Vec<u32>,
}

/// A heap entry: the value rounded up to f32 in the high half (the bits of a non-negative
/// f32 order like the number), the cell in the low half. Entries pop in order of value, then
/// of cell, so the march is deterministic; the exact value stays in the field.
#[inline]
fn key(t: f64, cell: u32) -> Reverse<u64> {
    let mut f = t as f32;
    if (f as f64) < t {
        f = f32::from_bits(f.to_bits() + 1);
    }
    Reverse(((f.to_bits() as u64) << 32) | cell as u64)
}

/// Marches the fronts of `sources` through `voxels`. `cost` gives the cost per mm of each
/// cell (`None`: 1 everywhere, the flow length).
pub fn march(voxels: &Voxels, sources: &[Source], cost: Option<&[f32]>) -> Field {
    // One loop per kind of cost, so that the cost of a cell is a plain load (or the
    // constant 1) inside the loop; both give the same numbers as a cost of 1 per cell.
    match cost {
        None => march_with(voxels, sources, |_| 1.0, |_, _| false).0,
        Some(c) => march_with(voxels, sources, |i| c[i as usize] as f64, |_, _| false).0,
    }
}

/// Marches like [`march`], but stops as soon as `stop(cell, t)` is true for a cell just
/// accepted (cells are accepted in order of their value, and an accepted value is final).
/// The searches use it when they need only the near part of a field: the nearest candidate,
/// or every cell of a share. Returns the field, with every cell not accepted set to
/// unreached (infinite, source `u32::MAX`), and the value of the last cell accepted
/// (infinite when the march ran to its end). Every accepted value has the same bits as in
/// the whole field, and a cell left out has a value of at least the one returned, to within
/// the f32 rounding of the queue's keys (a relative 2.4e-7).
pub fn march_until(
    voxels: &Voxels,
    sources: &[Source],
    cost: Option<&[f32]>,
    stop: impl FnMut(u32, f64) -> bool,
) -> (Field, f64) {
    let (mut field, stopped) = match cost {
        None => march_with(voxels, sources, |_| 1.0, stop),
        Some(c) => march_with(voxels, sources, |i| c[i as usize] as f64, stop),
    };
    match stopped {
        None => (field, f64::INFINITY),
        Some((reach, known)) => {
            for (c, k) in known.iter().enumerate() {
                if !k {
                    field.t[c] = f64::INFINITY;
                    field.source[c] = u32::MAX;
                }
            }
            (field, reach)
        }
    }
}

/// Seeds the march: the source cell and its neighbours within 1.5 cells of the point, at
/// their straight distance times the mean cost; the source cell itself always, even if the
/// point is off its centre.
fn seed(
    voxels: &Voxels,
    sources: &[Source],
    c: &impl Fn(u32) -> f64,
    t: &mut [f64],
    source: &mut [u32],
    heap: &mut BinaryHeap<Reverse<u64>>,
) {
    let h = voxels.h;
    let offsets = neighbour_offsets();
    for (s, src) in sources.iter().enumerate() {
        let mut seed_cell = |cell: u32| {
            let d = voxels.centre(cell).distance(src.point);
            if d <= 1.5 * h {
                let v = d * 0.5 * (c(src.cell) + c(cell));
                if v < t[cell as usize] {
                    t[cell as usize] = v;
                    source[cell as usize] = s as u32;
                    heap.push(key(v, cell));
                }
            }
        };
        seed_cell(src.cell);
        for &(o, _) in &offsets {
            if let Some(nb) = voxels.neighbour(src.cell, o) {
                seed_cell(nb);
            }
        }
        if t[src.cell as usize].is_infinite() {
            let v = voxels.centre(src.cell).distance(src.point) * c(src.cell);
            t[src.cell as usize] = v;
            source[src.cell as usize] = s as u32;
            heap.push(key(v, src.cell));
        }
    }
}

/// The march; when `stop` ends it early, also the last value accepted and which cells were.
fn march_with(
    voxels: &Voxels,
    sources: &[Source],
    c: impl Fn(u32) -> f64,
    mut stop: impl FnMut(u32, f64) -> bool,
) -> (Field, Option<(f64, Vec<bool>)>) {
    let n = voxels.len();
    let h = voxels.h;
    let mut t = vec![f64::INFINITY; n];
    let mut source = vec![u32::MAX; n];
    // The accepted value of each cell (infinite until accepted), with one more slot that
    // stands for "no neighbour": the fast-marching update reads its face neighbours from
    // here without a test per neighbour.
    let mut accepted = vec![f64::INFINITY; n + 1];
    let mut known = vec![false; n];
    let mut heap = BinaryHeap::new();
    let offsets = neighbour_offsets();

    seed(voxels, sources, &c, &mut t, &mut source, &mut heap);

    // Half the step length of each of the 26 neighbours (the straight step costs its
    // length times the mean of the two cells' costs), and which of them are face
    // neighbours.
    let half_step: [f64; 26] = std::array::from_fn(|k| offsets[k].1 * h * 0.5);
    let is_face: [bool; 26] = std::array::from_fn(|k| offsets[k].1 * h == h);
    let table = &voxels.table;
    let faces = &voxels.faces;
    let none = n as u32;
    while let Some(Reverse(entry)) = heap.pop() {
        let v = entry as u32;
        if known[v as usize] {
            continue;
        }
        known[v as usize] = true;
        let tv = t[v as usize];
        accepted[v as usize] = tv;
        if stop(v, tv) {
            return (Field { t, source }, Some((tv, known)));
        }
        let cv = c(v);
        let sv = source[v as usize];
        let row = &table[v as usize];
        for k in 0..26 {
            let u = row[k];
            if u == u32::MAX || known[u as usize] {
                continue;
            }
            let cu = c(u);
            // Straight step from v.
            let mut best = tv + half_step[k] * (cv + cu);
            // Fast-marching update of u from its known face neighbours (the accepted
            // value of a neighbour that is not known yet, or absent, is infinite).
            if is_face[k] {
                let f = &faces[u as usize];
                let at = |slot: usize| accepted[f[slot].min(none) as usize];
                let a = [at(0).min(at(1)), at(2).min(at(3)), at(4).min(at(5))];
                best = best.min(eikonal(a, h * cu));
            }
            if best < t[u as usize] {
                t[u as usize] = best;
                source[u as usize] = sv;
                heap.push(key(best, u));
            }
        }
    }
    (Field { t, source }, None)
}

/// The first-order upwind solution of sum_k (T - a_k)^2 = f^2 over the finite a_k, using as
/// many of the smallest as keep T above them.
fn eikonal(mut a: [f64; 3], f: f64) -> f64 {
    a.sort_by(f64::total_cmp);
    if a[0].is_infinite() {
        return f64::INFINITY;
    }
    let mut t = a[0] + f;
    if a[1] < t {
        let d = a[0] - a[1];
        let disc = 2.0 * f * f - d * d;
        if disc >= 0.0 {
            t = 0.5 * (a[0] + a[1] + disc.sqrt());
        }
        if a[2] < t {
            let s = a[0] + a[1] + a[2];
            let q = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
            let disc = s * s - 3.0 * (q - f * f);
            if disc >= 0.0 {
                t = (s + disc.sqrt()) / 3.0;
            }
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eikonal_matches_the_one_two_and_three_dimensional_closed_forms() {
        let inf = f64::INFINITY;
        assert_eq!(eikonal([inf, inf, inf], 1.0), inf);
        assert_eq!(eikonal([2.0, inf, inf], 1.0), 3.0);
        // Two equal neighbours: T - a = f / sqrt 2.
        assert!((eikonal([0.0, 0.0, inf], 1.0) - 0.5f64.sqrt()).abs() < 1e-12);
        // Three equal: f / sqrt 3.
        assert!((eikonal([0.0, 0.0, 0.0], 1.0) - (1.0f64 / 3.0).sqrt()).abs() < 1e-12);
        // A far second neighbour is ignored.
        assert_eq!(eikonal([0.0, 5.0, inf], 1.0), 1.0);
    }

    /// The march as first written (one loop for both kinds of cost, every test inside it):
    /// the oracle of the faster loop, which must give the same bits.
    fn reference_march(voxels: &Voxels, sources: &[Source], cost: Option<&[f32]>) -> Field {
        let n = voxels.len();
        let h = voxels.h;
        let c = |i: u32| cost.map_or(1.0, |c| c[i as usize] as f64);
        let mut t = vec![f64::INFINITY; n];
        let mut source = vec![u32::MAX; n];
        let mut known = vec![false; n];
        let mut heap = BinaryHeap::new();
        let offsets = neighbour_offsets();

        seed(voxels, sources, &c, &mut t, &mut source, &mut heap);

        // Step lengths of the 26 neighbours, and for each face neighbour (axis k, side), the
        // positions in the table of the two face neighbours of a cell along each axis.
        let step: Vec<f64> = offsets.iter().map(|&(_, len)| len * h).collect();
        let face_pair: [[usize; 2]; 3] = std::array::from_fn(|k| {
            let find = |sgn: i32| {
                offsets
                    .iter()
                    .position(|&(o, _)| (0..3).all(|j| o[j] == if j == k { sgn } else { 0 }))
                    .expect("face neighbour")
            };
            [find(-1), find(1)]
        });
        let table = &voxels.table;
        while let Some(Reverse(entry)) = heap.pop() {
            let v = entry as u32;
            if known[v as usize] {
                continue;
            }
            known[v as usize] = true;
            let tv = t[v as usize];
            let cv = c(v);
            let sv = source[v as usize];
            let row = &table[v as usize];
            for (k, &u) in row.iter().enumerate() {
                if u == u32::MAX || known[u as usize] {
                    continue;
                }
                let cu = c(u);
                // Straight step from v.
                let mut best = tv + step[k] * 0.5 * (cv + cu);
                // Fast-marching update of u from its known face neighbours.
                if step[k] == h {
                    let ru = &table[u as usize];
                    let mut a = [f64::INFINITY; 3];
                    for (axis, pair) in face_pair.iter().enumerate() {
                        for &slot in pair {
                            let w = ru[slot];
                            if w != u32::MAX && known[w as usize] {
                                a[axis] = a[axis].min(t[w as usize]);
                            }
                        }
                    }
                    best = best.min(eikonal(a, h * cu));
                }
                if best < t[u as usize] {
                    t[u as usize] = best;
                    source[u as usize] = sv;
                    heap.push(key(best, u));
                }
            }
        }
        Field { t, source }
    }

    #[test]
    fn march_gives_the_same_fields_as_the_reference_loop() {
        use crate::samples::sample;
        for name in ["plate", "cover", "cap", "bracket"] {
            let mesh = sample(name).expect("sample");
            let v = Voxels::new(&mesh, 1.0);
            // A cost that varies from cell to cell, as a wall-dependent one does.
            let cost: Vec<f32> = (0..v.len()).map(|i| 1.0 + (i % 7) as f32 * 0.37).collect();
            let at = |c: u32| Source {
                point: v.centre(c) + DVec3::new(0.21, -0.13, 0.08),
                cell: c,
            };
            let n = v.len() as u32;
            for sources in [vec![at(0)], vec![at(n / 3), at(n - 1)]] {
                for c in [None, Some(&cost[..])] {
                    let (new, old) = (march(&v, &sources, c), reference_march(&v, &sources, c));
                    assert_eq!(new.source, old.source, "{name}");
                    assert!(
                        new.t
                            .iter()
                            .zip(&old.t)
                            .all(|(a, b)| a.to_bits() == b.to_bits()),
                        "{name}: the fields differ"
                    );
                }
            }
        }
    }

    #[test]
    fn a_march_stopped_early_keeps_the_accepted_values_and_leaves_out_only_farther_cells() {
        use crate::samples::sample;
        for name in ["plate", "cover", "bracket"] {
            let mesh = sample(name).expect("sample");
            let v = Voxels::new(&mesh, 1.0);
            let cost: Vec<f32> = (0..v.len()).map(|i| 1.0 + (i % 5) as f32 * 0.29).collect();
            let src = [Source {
                point: v.centre(3),
                cell: 3,
            }];
            for c in [None, Some(&cost[..])] {
                let whole = march(&v, &src, c);
                let max = whole.t.iter().copied().fold(0.0, f64::max);
                for share in [0.1, 0.5, 0.9] {
                    let limit = share * max;
                    let (part, reach) = march_until(&v, &src, c, |_, t| t > limit);
                    assert!(reach > limit && reach <= max, "{name}: reach {reach}");
                    let mut kept = 0;
                    for (a, b) in part.t.iter().zip(&whole.t) {
                        if a.is_finite() {
                            kept += 1;
                            assert_eq!(a.to_bits(), b.to_bits(), "{name}: an accepted value");
                        } else {
                            // Left out: at least the reach, to the f32 rounding of the keys.
                            assert!(*b >= reach * (1.0 - 2.4e-7), "{name}: {b} < {reach}");
                        }
                    }
                    assert!(kept > 0 && kept < v.len(), "{name}: {kept} cells kept");
                }
                // A stop that never comes gives the whole field.
                let (all, reach) = march_until(&v, &src, c, |_, _| false);
                assert!(reach.is_infinite());
                assert!(all
                    .t
                    .iter()
                    .zip(&whole.t)
                    .all(|(a, b)| a.to_bits() == b.to_bits()));
            }
        }
    }
}
