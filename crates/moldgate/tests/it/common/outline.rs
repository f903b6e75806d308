//! An independent figure for the parting line: the perimeter of the part's outline seen along
//! a direction, from a raster of the projected triangles (not from mesh edges).
//!
//! The triangles are projected on the plane normal to D and sampled on a fine lattice (4 x 4
//! samples per cell); each lattice node gets the share of covered samples around it, holes
//! (uncovered regions that do not reach the raster's border) are filled, and the 0.5
//! contour is traced by marching squares with linear interpolation. Its length is the
//! perimeter of the outer outline of every body, within about a cell (the cell is the longer
//! side of the outline over `cells`).

use moldgate::math::DVec2;
use moldgate::{Frame, Mesh};

/// Perimeter in mm of the outer outline of `mesh` seen along the frame's D, on a raster of
/// `cells` cells along its longer side.
pub fn outline_perimeter(mesh: &Mesh, frame: &Frame, cells: usize) -> f64 {
    const S: usize = 4;
    let q: Vec<DVec2> = mesh.vertices.iter().map(|&v| frame.project(v)).collect();
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for p in &q {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let h = (hi - lo).max_element() / cells as f64;
    // Two empty cells of margin on every side.
    let lo = lo - DVec2::splat(2.0 * h);
    let nu = ((hi.x - lo.x) / h).ceil() as usize + 3;
    let nw = ((hi.y - lo.y) / h).ceil() as usize + 3;
    let (fu, fw) = (nu * S, nw * S);
    let fh = h / S as f64;
    let mut covered = vec![false; fu * fw];
    for tri in &mesh.triangles {
        let [a, b, c] = tri.map(|v| q[v as usize]);
        let area = (b - a).perp_dot(c - a);
        if area == 0.0 {
            continue;
        }
        let (tlo, thi) = (a.min(b).min(c), a.max(b).max(c));
        let i0 = (((tlo.x - lo.x) / fh - 0.5).floor().max(0.0)) as usize;
        let i1 = (((thi.x - lo.x) / fh - 0.5).ceil() as usize).min(fu - 1);
        let j0 = (((tlo.y - lo.y) / fh - 0.5).floor().max(0.0)) as usize;
        let j1 = (((thi.y - lo.y) / fh - 0.5).ceil() as usize).min(fw - 1);
        for j in j0..=j1 {
            // The samples of this row the triangle can cover, from where its edges cross
            // the row, one sample wider on each side than that: each is then tested exactly.
            let y = lo.y + (j as f64 + 0.5) * fh;
            let Some((xl, xh)) = row_span([a, b, c], area, y) else {
                continue;
            };
            let first = ((xl - lo.x) / fh - 0.5).ceil() - 1.0;
            let last = ((xh - lo.x) / fh - 0.5).floor() + 1.0;
            if last < i0 as f64 || first > i1 as f64 {
                continue;
            }
            let (from, to) = (first.max(i0 as f64) as usize, last.min(i1 as f64) as usize);
            // The samples two or more inside those ends are a whole sample inside the span,
            // far beyond its rounding: covered without a test.
            let row = &mut covered[j * fu..(j + 1) * fu];
            let inner_from = (first as isize + 2).max(from as isize) as usize;
            let inner_to = (last as isize - 2).min(to as isize);
            let ends = match inner_to >= inner_from as isize {
                true => {
                    row[inner_from..=inner_to as usize].fill(true);
                    (from..inner_from).chain(inner_to as usize + 1..to + 1)
                }
                false => (from..to + 1).chain(0..0),
            };
            for i in ends {
                // A sample covered already (by a face above or below) needs no test.
                if row[i] {
                    continue;
                }
                let p = DVec2::new(lo.x + (i as f64 + 0.5) * fh, y);
                let e = [
                    (b - a).perp_dot(p - a),
                    (c - b).perp_dot(p - b),
                    (a - c).perp_dot(p - c),
                ];
                if e.iter().all(|&x| x * area >= 0.0) {
                    row[i] = true;
                }
            }
        }
    }
    // Coverage at the lattice nodes: the share of the S x S samples of the cell around each,
    // centred on the node (shifted by half a cell, round the raster's empty margins), summed
    // row of samples by row of samples.
    let wrap = |x: usize, n: usize| if x >= n { x - n } else { x };
    let mut f = vec![0.0f64; nu * nw];
    let mut counts = vec![0usize; nu];
    for w in 0..nw {
        counts.fill(0);
        for j in 0..S {
            let y = wrap(w * S + j + fw - S / 2, fw);
            let row = &covered[y * fu..(y + 1) * fu];
            for (u, n) in counts.iter_mut().enumerate() {
                for i in 0..S {
                    *n += row[wrap(u * S + i + fu - S / 2, fu)] as usize;
                }
            }
        }
        for (u, &n) in counts.iter().enumerate() {
            f[w * nu + u] = n as f64 / (S * S) as f64;
        }
    }
    // Fill holes: flood the outside from the border over nodes below 0.5.
    let mut outside = vec![false; nu * nw];
    let mut stack: Vec<usize> = (0..nu).chain((nu * (nw - 1))..(nu * nw)).collect();
    stack.extend((0..nw).flat_map(|w| [w * nu, w * nu + nu - 1]));
    while let Some(k) = stack.pop() {
        if outside[k] || f[k] >= 0.5 {
            continue;
        }
        outside[k] = true;
        let (u, w) = (k % nu, k / nu);
        if u > 0 {
            stack.push(k - 1);
        }
        if u + 1 < nu {
            stack.push(k + 1);
        }
        if w > 0 {
            stack.push(k - nu);
        }
        if w + 1 < nw {
            stack.push(k + nu);
        }
    }
    for k in 0..f.len() {
        if !outside[k] && f[k] < 0.5 {
            f[k] = 1.0;
        }
    }
    // Marching squares at 0.5.
    let mut length = 0.0;
    for w in 0..nw - 1 {
        for u in 0..nu - 1 {
            let v = [
                f[w * nu + u],
                f[w * nu + u + 1],
                f[(w + 1) * nu + u + 1],
                f[(w + 1) * nu + u],
            ];
            let p = [
                DVec2::new(0.0, 0.0),
                DVec2::new(h, 0.0),
                DVec2::new(h, h),
                DVec2::new(0.0, h),
            ];
            let (mut crossings, mut n) = ([DVec2::ZERO; 4], 0);
            for e in 0..4 {
                let (a, b) = (v[e], v[(e + 1) % 4]);
                if (a >= 0.5) != (b >= 0.5) {
                    let t = (0.5 - a) / (b - a);
                    crossings[n] = p[e].lerp(p[(e + 1) % 4], t);
                    n += 1;
                }
            }
            if n == 2 {
                length += crossings[0].distance(crossings[1]);
            } else if n == 4 {
                length += crossings[0].distance(crossings[1]) + crossings[2].distance(crossings[3]);
            }
        }
    }
    length
}

/// The interval of x where the row at `y` is inside the triangle `t` (signed area `area`),
/// from its three edges' lines (empty when the first exceeds the second), or `None` when an
/// edge along the row leaves it outside.
fn row_span(t: [DVec2; 3], area: f64, y: f64) -> Option<(f64, f64)> {
    let (mut xl, mut xh) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..3 {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        let d = b - a;
        // The edge's test, (b - a) x (p - a) times the sign of the area, is c - s x.
        let s = d.y * area.signum();
        let c = (d.x * (y - a.y) + d.y * a.x) * area.signum();
        if s > 0.0 {
            xh = xh.min(c / s);
        } else if s < 0.0 {
            xl = xl.max(c / s);
        } else if c < 0.0 {
            return None;
        }
    }
    Some((xl, xh))
}
