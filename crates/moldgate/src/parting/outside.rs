//! Which edges of one body lie on its outline seen along D, and which of them at the part's
//! +D end there: the body's edges between the two sides drawn into a raster over its
//! projection, the cells outside them found from the raster's border.
//!
//! The outline of a body's projection is made of its edges between the two sides (the
//! boundary of the faces turned towards +D, projected: every other face lies over or under
//! one of those, up to the walls along D, which cover no area). So those edges, drawn cell by
//! cell (every cell a segment passes through, a 4-connected run), close the outline in the
//! raster, and a flood from the border over the cells no edge passes through reaches exactly
//! the cells outside it. An edge is on the outline where one of its cells touches such a
//! cell; a single point test beside the edge is not used, as on finely tessellated rounded
//! corners a neighbouring facet bulges past the edge by less than a micrometre.

use rustc_hash::FxHashMap;

use crate::math::DVec2;

/// Cells along the longer side of one body's raster (the cell is its extent over this).
pub(super) const CELLS: usize = 1024;
/// Cells of all the bodies' rasters together, at most: a part of up to 64 bodies draws
/// each in the full [`CELLS`] x [`CELLS`]; a file of more (thousands of loose pieces) shares
/// this among them, so that it is not drawn and flooded at a whole part's cost per piece.
pub(super) const RASTER_CELLS_BUDGET: usize = 64 * CELLS * CELLS;

/// Cells along the longer side of each body's raster for a part of `bodies` bodies:
/// [`CELLS`] for up to 64 bodies, fewer past that (the square root of their share of
/// [`RASTER_CELLS_BUDGET`]), at least 64.
pub(super) fn cells_for(bodies: usize) -> usize {
    let share = RASTER_CELLS_BUDGET / bodies.max(1);
    (share as f64).sqrt().floor().clamp(64.0, CELLS as f64) as usize
}

/// Empty cells of margin round the body's projection.
const MARGIN: usize = 2;

/// One body's raster of its edges between the sides.
pub(super) struct Outside {
    lo: DVec2,
    cell: f64,
    n_u: usize,
    n_w: usize,
    /// Per cell, row by row: [`EMPTY`], [`EDGE`] (an edge passes through it) or
    /// [`OUTSIDE`] (no edge does and the border reaches it), and once the band is marked
    /// the bits of [`Outside::mark_band`]. One byte a cell, and every flag of the cell in
    /// it rather than in rasters of their own: the raster of a large part has about a
    /// million cells, and `locate` builds it beside the rays.
    state: Vec<u8>,
    /// For the cells an edge passes through (a small share of the raster, about the edges'
    /// length in cells): the least depth below the +D end of such an edge.
    lowest: FxHashMap<u32, f32>,
    /// One bit a cell, rows of [`Outside::words`] words: the cell touches the outside (it
    /// or one of its eight neighbours is outside). An eighth of the raster's bytes, made
    /// once, so that the rim test of a point is one look-up rather than nine.
    touch: Vec<u64>,
    /// Words of 64 cells to a row of the bit rasters.
    words: usize,
}

const EMPTY: u8 = 0;
const EDGE: u8 = 1;
const OUTSIDE: u8 = 2;
/// Within the band's width of a cell a rim edge passes through.
const NEAR_RIM: u8 = 4;
/// In the band: [`NEAR_RIM`] and within the reach of the outside in both axes.
const BAND: u8 = 32;

/// An edge between the sides in frame coordinates: its ends in the plane and their depths
/// below the part's +D end (-p.D: less is nearer that end).
#[derive(Clone, Copy)]
pub(super) struct Segment {
    pub a: DVec2,
    pub b: DVec2,
    pub depth_a: f64,
    pub depth_b: f64,
}

impl Outside {
    /// The raster of `segments` (one body's edges between the sides), with the outside
    /// flooded from its border.
    #[cfg(test)]
    pub(super) fn new(segments: impl Iterator<Item = Segment> + Clone) -> Outside {
        Outside::with_cells(segments, CELLS)
    }

    /// [`Outside::new`] with `cells` along the longer side instead of [`CELLS`].
    pub(super) fn with_cells(
        segments: impl Iterator<Item = Segment> + Clone,
        cells: usize,
    ) -> Outside {
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for s in segments.clone() {
            lo = lo.min(s.a).min(s.b);
            hi = hi.max(s.a).max(s.b);
        }
        let extent = (hi - lo).max_element().max(1e-9);
        let cell = extent / cells.max(1) as f64;
        let lo = lo - DVec2::splat(MARGIN as f64 * cell);
        let n_u = (((hi.x - lo.x) / cell).ceil() as usize + MARGIN + 1).max(1);
        let n_w = (((hi.y - lo.y) / cell).ceil() as usize + MARGIN + 1).max(1);
        let mut raster = Outside {
            lo,
            cell,
            n_u,
            n_w,
            state: vec![EMPTY; n_u * n_w],
            lowest: FxHashMap::default(),
            touch: Vec::new(),
            words: n_u.div_ceil(64),
        };
        for s in segments {
            let low = s.depth_a.min(s.depth_b) as f32;
            let (state, lowest) = (&mut raster.state, &mut raster.lowest);
            cells_on(lo, cell, n_u, n_w, s.a, s.b, |c| {
                state[c] = EDGE;
                lowest
                    .entry(c as u32)
                    .and_modify(|l| *l = l.min(low))
                    .or_insert(low);
            });
        }
        raster.flood();
        let mut touch = raster.outside_rows(1);
        raster.spread_over_rows(&mut touch, 1);
        raster.touch = touch;
        raster
    }

    /// The outside cells as bits, a row of [`Outside::words`] words per raster row, each
    /// row spread along itself by `reach` cells both ways (`reach` below 64).
    fn outside_rows(&self, reach: usize) -> Vec<u64> {
        let words = self.words;
        let mut bits = vec![0u64; words * self.n_w];
        for (row, out) in self
            .state
            .chunks_exact(self.n_u)
            .zip(bits.chunks_exact_mut(words))
        {
            for (cells, word) in row.chunks(64).zip(out.iter_mut()) {
                *word = outside_bits(cells);
            }
            spread_along(out, reach);
        }
        bits
    }

    /// Spreads rows of bits (as [`Outside::outside_rows`] makes them) over the `reach` rows
    /// above and below each, within the raster.
    fn spread_over_rows(&self, bits: &mut Vec<u64>, reach: usize) {
        let words = self.words;
        let mut out = vec![0u64; bits.len()];
        for w in 0..self.n_w {
            let target = &mut out[w * words..(w + 1) * words];
            for y in w.saturating_sub(reach)..(w + reach + 1).min(self.n_w) {
                for (t, &b) in target.iter_mut().zip(&bits[y * words..(y + 1) * words]) {
                    *t |= b;
                }
            }
        }
        *bits = out;
    }

    /// Marks the cells no edge passes through that the border reaches, by steps to the four
    /// neighbours (a 4-connected run of edge cells is not crossed). A scanline fill: each
    /// seed fills its whole run of empty cells along the row and leaves one seed per empty
    /// run of the rows above and below it, so the stack holds runs, not cells.
    fn flood(&mut self) {
        let (n_u, n_w) = (self.n_u, self.n_w);
        let state = &mut self.state;
        let mut stack: Vec<(u32, u32)> = Vec::new();
        for u in 0..n_u as u32 {
            stack.push((u, 0));
            stack.push((u, n_w as u32 - 1));
        }
        for w in 0..n_w as u32 {
            stack.push((0, w));
            stack.push((n_u as u32 - 1, w));
        }
        while let Some((u, w)) = stack.pop() {
            let (u, w) = (u as usize, w as usize);
            let row = w * n_u;
            if state[row + u] != EMPTY {
                continue;
            }
            let (mut l, mut r) = (u, u);
            while l > 0 && state[row + l - 1] == EMPTY {
                l -= 1;
            }
            while r + 1 < n_u && state[row + r + 1] == EMPTY {
                r += 1;
            }
            state[row + l..=row + r].fill(OUTSIDE);
            for next in [w.wrapping_sub(1), w + 1] {
                if next >= n_w {
                    continue;
                }
                let next_row = next * n_u;
                let mut x = l;
                while x <= r {
                    if state[next_row + x] == EMPTY {
                        stack.push((x as u32, next as u32));
                        while x <= r && state[next_row + x] == EMPTY {
                            x += 1;
                        }
                    } else {
                        x += 1;
                    }
                }
            }
        }
    }

    /// Whether `s` is on the outline at the +D end of the part there: one of its cells
    /// touches the outside (its eight neighbours), and in one of its cells no edge lies
    /// nearer that end than it by more than `tolerance` (on a vertical band, the edges below
    /// its +D end share its cells with the edge at that end).
    pub(super) fn on_rim(&self, s: &Segment, tolerance: f64) -> bool {
        let n = ((s.a.distance(s.b) / (0.5 * self.cell)).ceil() as usize).clamp(1, 1 << 16);
        let sample = |k: usize| {
            let (t0, t1) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
            (self.cell_of(s.a.lerp(s.b, 0.5 * (t0 + t1))), t0, t1)
        };
        // Most edges between the sides are inside the outline (the rims of holes, ribs,
        // threads): the test of the outside's cells, which reads only the raster, settles
        // them before any look-up of the least depths.
        let touches = (0..n).any(|k| sample(k).0.is_some_and(|c| self.touches_outside(c)));
        touches
            && (0..n).any(|k| {
                let (Some(c), t0, t1) = sample(k) else {
                    return false;
                };
                let h = lerp(s.depth_a, s.depth_b, t0).min(lerp(s.depth_a, s.depth_b, t1));
                let lowest = self
                    .lowest
                    .get(&(c as u32))
                    .map_or(f64::INFINITY, |&l| l as f64);
                h <= lowest + tolerance
            })
    }

    /// Whether `p` lies outside the outline (outside the raster too).
    pub(super) fn is_outside(&self, p: DVec2) -> bool {
        self.cell_of(p).is_none_or(|c| self.state[c] & OUTSIDE != 0)
    }

    /// The raster's cell side in mm.
    pub(super) fn cell(&self) -> f64 {
        self.cell
    }

    /// Frees what only [`Outside::on_rim`] reads (the least depths of the edge cells, about
    /// a megabyte on the 352k part, and the cells touching the outside), once the rim edges
    /// are found: the band and the cycle are made without them, beside the rays.
    pub(super) fn rims_found(&mut self) {
        self.lowest = FxHashMap::default();
        self.touch = Vec::new();
    }

    /// Marks the band round the rim: the cells within `cells` cells (in both axes) of a cell
    /// that one of `rim` (the rim edges) passes through; [`Outside::in_band`] then tells
    /// whether a point lies in it. The band is measured from the rim edges, not from the
    /// outside: where the outline steps out by about the band's width (a tab standing a few
    /// tenths of a millimetre proud of a wall), the rim edges along the wall behind the tab
    /// lie more than the width from the outside, and a band measured from the outside would
    /// lose them and break the ring there.
    ///
    /// The band is also kept within `2 * cells + 1` cells of the outside: a long rim edge
    /// may touch the outside at one end and run far inside at the other (on the knob, an
    /// edge from the outline along the foot of a tab into the ring), and a band round the
    /// whole of such an edge would let the cycle leave the outline along it.
    ///
    /// Every mark is a bit of the cell's one byte; the outside's reach is found on rows of
    /// bits (an eighth of the raster), spread along the rows and then over them.
    pub(super) fn mark_band(&mut self, rim: &[Segment], cells: usize) {
        let (n_u, n_w) = (self.n_u, self.n_w);
        let state = &mut self.state;
        // Rim cells are few (about the outline's length in cells), so each marks its square
        // of side 2 cells + 1 directly, without a pass over the whole raster.
        for s in rim {
            cells_on(self.lo, self.cell, n_u, n_w, s.a, s.b, |c| {
                let (u, w) = (c % n_u, c / n_u);
                for y in w.saturating_sub(cells)..(w + cells + 1).min(n_w) {
                    let row = y * n_u;
                    for x in
                        &mut state[row + u.saturating_sub(cells)..row + (u + cells + 1).min(n_u)]
                    {
                        *x |= NEAR_RIM;
                    }
                }
            });
        }
        // The outside's reach: a square of side 2 reach + 1 round each outside cell, as rows
        // of bits spread along the rows and then over the rows. Only the rows that hold a
        // cell near a rim edge are spread over, and only those cells are marked.
        let reach = 2 * cells + 1;
        let words = self.words;
        let rows = self.outside_rows(reach);
        let mut reached = vec![0u64; words];
        for (w, row) in self.state.chunks_exact_mut(n_u).enumerate() {
            if !row.iter().any(|&x| x & NEAR_RIM != 0) {
                continue;
            }
            reached.fill(0);
            for y in w.saturating_sub(reach)..(w + reach + 1).min(n_w) {
                for (r, &b) in reached.iter_mut().zip(&rows[y * words..(y + 1) * words]) {
                    *r |= b;
                }
            }
            for (u, x) in row.iter_mut().enumerate() {
                if *x & NEAR_RIM != 0 && reached[u / 64] >> (u % 64) & 1 != 0 {
                    *x |= BAND;
                }
            }
        }
    }

    /// Whether a point of the plane lies in the band marked by [`Outside::mark_band`].
    pub(super) fn in_band(&self, p: DVec2) -> bool {
        self.cell_of(p).is_some_and(|c| self.state[c] & BAND != 0)
    }

    fn cell_of(&self, p: DVec2) -> Option<usize> {
        let d = (p - self.lo) / self.cell;
        // For d >= 0 the conversion's truncation is the floor (and a call to `floor` is a
        // library call on the baseline x86-64 target, in the rim test's inner loop); a
        // negative or NaN coordinate is off the raster.
        if !(d.x >= 0.0 && d.y >= 0.0) {
            return None;
        }
        let (u, w) = (d.x as usize, d.y as usize);
        (u < self.n_u && w < self.n_w).then(|| w * self.n_u + u)
    }

    /// Whether cell `c` or one of its eight neighbours is outside.
    fn touches_outside(&self, c: usize) -> bool {
        let (u, w) = (c % self.n_u, c / self.n_u);
        self.touch[w * self.words + u / 64] >> (u % 64) & 1 != 0
    }
}

/// The bits of the outside cells among up to 64 cells (cell k at bit k): eight cells at a
/// time, each byte's [`OUTSIDE`] bit gathered into one byte by a multiplication (byte i's
/// lowest bit lands in bit 56 + i of the product, and no two of them carry into each
/// other).
fn outside_bits(cells: &[u8]) -> u64 {
    const LOW_BITS: u64 = 0x0101_0101_0101_0101;
    const GATHER: u64 = 0x0102_0408_1020_4080;
    let mut word = 0;
    let mut eights = cells.chunks_exact(8);
    for (k, eight) in eights.by_ref().enumerate() {
        let x = u64::from_le_bytes(eight.try_into().expect("eight cells"));
        let outside = (x >> OUTSIDE.trailing_zeros()) & LOW_BITS;
        word |= (outside.wrapping_mul(GATHER) >> 56) << (8 * k);
    }
    let done = cells.len() / 8 * 8;
    for (k, &x) in eights.remainder().iter().enumerate() {
        word |= u64::from(x & OUTSIDE != 0) << (done + k);
    }
    word
}

/// Sets in a row of bits (cell k at bit k % 64 of word k / 64) every bit within `reach`
/// (below 64) of a set bit. The spread towards higher cells may set bits past the row's
/// last cell, which are never read; the spread towards lower cells starts from the row's
/// own bits, so none comes back from there.
fn spread_along(row: &mut [u64], reach: usize) {
    debug_assert!(reach < 64);
    let spread = |mut acc: Vec<u64>, up: bool| {
        // Shifts by 0..covered are in `acc`; each step doubles them, the last one reaching
        // exactly `reach`.
        let mut covered = 1;
        while covered <= reach {
            let step = covered.min(reach + 1 - covered) as u32;
            if up {
                for i in (0..acc.len()).rev() {
                    let carry = if i > 0 { acc[i - 1] >> (64 - step) } else { 0 };
                    acc[i] |= acc[i] << step | carry;
                }
            } else {
                for i in 0..acc.len() {
                    let carry = acc.get(i + 1).map_or(0, |&next| next << (64 - step));
                    acc[i] |= acc[i] >> step | carry;
                }
            }
            covered += step as usize;
        }
        acc
    };
    let up = spread(row.to_vec(), true);
    let down = spread(row.to_vec(), false);
    for ((r, u), d) in row.iter_mut().zip(up).zip(down) {
        *r = u | d;
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Calls `f` with every cell the segment from `a` to `b` passes through, in order, each a
/// side neighbour of the one before (a grid walk that steps one axis at a time and ends in
/// the cell of `b` whatever the rounding).
fn cells_on(
    lo: DVec2,
    cell: f64,
    n_u: usize,
    n_w: usize,
    a: DVec2,
    b: DVec2,
    mut f: impl FnMut(usize),
) {
    let index = |x: f64, n: usize| (x.floor().max(0.0) as usize).min(n - 1) as i64;
    let (pa, pb) = ((a - lo) / cell, (b - lo) / cell);
    let (mut i, mut j) = (index(pa.x, n_u), index(pa.y, n_w));
    let (i_end, j_end) = (index(pb.x, n_u), index(pb.y, n_w));
    let d = pb - pa;
    let (si, sj) = (
        if i_end > i { 1 } else { -1 },
        if j_end > j { 1 } else { -1 },
    );
    let crossing = |p: f64, k: i64, s: i64, dp: f64| {
        if dp == 0.0 {
            f64::INFINITY
        } else {
            let edge = if s > 0 { (k + 1) as f64 } else { k as f64 };
            ((edge - p) / dp).max(0.0)
        }
    };
    let (mut t_u, mut t_w) = (crossing(pa.x, i, si, d.x), crossing(pa.y, j, sj, d.y));
    let (dt_u, dt_w) = (
        if d.x == 0.0 {
            f64::INFINITY
        } else {
            1.0 / d.x.abs()
        },
        if d.y == 0.0 {
            f64::INFINITY
        } else {
            1.0 / d.y.abs()
        },
    );
    f(j as usize * n_u + i as usize);
    while i != i_end || j != j_end {
        if j == j_end || (i != i_end && t_u <= t_w) {
            i += si;
            t_u += dt_u;
        } else {
            j += sj;
            t_w += dt_w;
        }
        f(j as usize * n_u + i as usize);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn segment(a: (f64, f64), b: (f64, f64), h: f64) -> Segment {
        Segment {
            a: DVec2::new(a.0, a.1),
            b: DVec2::new(b.0, b.1),
            depth_a: h,
            depth_b: h,
        }
    }

    /// A square of side 10 at depth 0, a smaller square inside it (a hole's rim) and, on
    /// the square's right side, a segment deeper (an edge down the wall).
    #[test]
    fn the_outer_square_is_the_rim_not_the_hole_nor_the_edge_below_it() {
        let square = |s: f64, h: f64| {
            [
                segment((-s, -s), (s, -s), h),
                segment((s, -s), (s, s), h),
                segment((s, s), (-s, s), h),
                segment((-s, s), (-s, -s), h),
            ]
        };
        let mut all: Vec<Segment> = square(5.0, 0.0).to_vec();
        all.extend(square(2.0, 0.0));
        let deeper = segment((5.0, -4.0), (5.0, 4.0), 3.0);
        all.push(deeper);
        let raster = Outside::new(all.iter().copied());
        for s in &square(5.0, 0.0) {
            assert!(raster.on_rim(s, 0.01));
        }
        for s in &square(2.0, 0.0) {
            assert!(
                !raster.on_rim(s, 0.01),
                "a hole's rim is inside the outline"
            );
        }
        assert!(!raster.on_rim(&deeper, 0.01), "below the +D end");
    }

    /// A tab standing 4 cells proud of the right side of a square, over a fifth of its
    /// length (as on the PSU cover's box): behind the tab the side is 4 cells from the
    /// outside, yet the side is a rim edge (it touches the outside above and below the tab),
    /// so the band, measured from the rim edges, keeps it; measured from the outside it
    /// would not, and the band would break there.
    #[test]
    fn the_band_keeps_the_rim_behind_a_tab_standing_out_by_its_width() {
        let side = 5.0;
        let cell = (2.0 * side + 0.04) / CELLS as f64;
        let t = 4.0 * cell;
        let mut all = vec![
            segment((-side, -side), (side, -side), 0.0),
            segment((side, -side), (side, side), 0.0),
            segment((side, side), (-side, side), 0.0),
            segment((-side, side), (-side, -side), 0.0),
        ];
        all.extend([
            segment((side, -1.0), (side + t, -1.0), 0.0),
            segment((side + t, -1.0), (side + t, 1.0), 0.0),
            segment((side + t, 1.0), (side, 1.0), 0.0),
        ]);
        let mut raster = Outside::new(all.iter().copied());
        let rim: Vec<Segment> = all
            .iter()
            .copied()
            .filter(|s| raster.on_rim(s, 1e-3))
            .collect();
        assert_eq!(rim.len(), all.len(), "every segment is on the outline");
        raster.mark_band(&rim, 3);
        let near = |p| raster.in_band(p);
        assert!(
            near(DVec2::new(side - 0.5 * raster.cell(), 0.0)),
            "the side behind the tab"
        );
        assert!(near(DVec2::new(side + t, 0.0)), "the tab's face");
        assert!(!near(DVec2::new(0.0, 0.0)), "the middle of the square");
        assert!(
            !near(DVec2::new(side + t + 5.0 * raster.cell(), 0.0)),
            "beyond the band"
        );
    }

    /// Segments from a seeded generator: a closed ring with inner rings (holes) and loose
    /// strokes, depths at random, over a raster a few hundred cells wide.
    fn random_segments(seed: u64) -> Vec<Segment> {
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut all = Vec::new();
        for ring in 0..4 {
            let (cx, cy) = (next() * 4.0 - 2.0, next() * 4.0 - 2.0);
            let radius = if ring == 0 { 10.0 } else { 0.5 + next() * 3.0 };
            let n = 5 + (next() * 40.0) as usize;
            let point = |k: usize| {
                let a = k as f64 / n as f64 * std::f64::consts::TAU;
                (cx + radius * a.cos(), cy + radius * 0.7 * a.sin())
            };
            for k in 0..n {
                all.push(segment(point(k), point(k + 1), next() * 3.0));
            }
        }
        for _ in 0..30 {
            let a = (next() * 16.0 - 8.0, next() * 12.0 - 6.0);
            let b = (a.0 + next() * 2.0 - 1.0, a.1 + next() * 2.0 - 1.0);
            all.push(segment(a, b, next()));
        }
        all
    }

    #[test]
    fn outside_cells_gather_into_their_bits() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for len in [0usize, 1, 7, 8, 9, 63, 64] {
            let cells: Vec<u8> = (0..len)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    // Every flag combination a cell may hold.
                    (state % 64) as u8
                })
                .collect();
            let expected = cells
                .iter()
                .enumerate()
                .fold(0u64, |w, (k, &x)| w | u64::from(x & OUTSIDE != 0) << k);
            assert_eq!(outside_bits(&cells), expected, "{len} cells");
        }
    }

    #[test]
    fn rows_of_bits_spread_as_every_shift_would_spread_them() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for len in [1usize, 2, 3, 7] {
            for reach in [0usize, 1, 2, 7, 31, 63] {
                let row: Vec<u64> = (0..len)
                    .map(|_| {
                        state ^= state << 13;
                        state ^= state >> 7;
                        state ^= state << 17;
                        // Sparse bits, so that the spreads do not fill every word.
                        state & state.rotate_left(17) & state.rotate_left(29)
                    })
                    .collect();
                let mut spread = row.clone();
                spread_along(&mut spread, reach);
                let bit = |r: &[u64], k: usize| r[k / 64] >> (k % 64) & 1 != 0;
                for k in 0..64 * len {
                    let lo = k.saturating_sub(reach);
                    let hi = (k + reach).min(64 * len - 1);
                    let expected = (lo..=hi).any(|j| bit(&row, j));
                    assert_eq!(bit(&spread, k), expected, "len {len} reach {reach} bit {k}");
                }
            }
        }
    }

    /// The band marked by four passes over the raster's bytes (the marking the rows of bits
    /// replaced): the outside's reach along each row, then along each column above and
    /// below.
    fn band_by_passes(raster: &Outside, reach: usize) -> Vec<bool> {
        let (n_u, n_w) = (raster.n_u, raster.n_w);
        let outside = |u: usize, w: usize| raster.state[w * n_u + u] & OUTSIDE != 0;
        let row_reach: Vec<bool> = (0..n_u * n_w)
            .map(|c| {
                let (u, w) = (c % n_u, c / n_u);
                (u.saturating_sub(reach)..(u + reach + 1).min(n_u)).any(|x| outside(x, w))
            })
            .collect();
        (0..n_u * n_w)
            .map(|c| {
                let (u, w) = (c % n_u, c / n_u);
                raster.state[c] & NEAR_RIM != 0
                    && (w.saturating_sub(reach)..(w + reach + 1).min(n_w))
                        .any(|y| row_reach[y * n_u + u])
            })
            .collect()
    }

    #[test]
    fn touch_and_band_bits_match_the_cells_around_each_cell() {
        for seed in 1..6 {
            let all = random_segments(seed);
            let mut raster = Outside::new(all.iter().copied());
            let (n_u, n_w) = (raster.n_u, raster.n_w);
            let mut touching = 0;
            for c in 0..n_u * n_w {
                let (u, w) = ((c % n_u) as isize, (c / n_u) as isize);
                let expected = (-1..=1).any(|dw| {
                    (-1..=1).any(|du| {
                        let (x, y) = (u + du, w + dw);
                        x >= 0
                            && y >= 0
                            && (x as usize) < n_u
                            && (y as usize) < n_w
                            && raster.state[y as usize * n_u + x as usize] & OUTSIDE != 0
                    })
                });
                assert_eq!(raster.touches_outside(c), expected, "seed {seed} cell {c}");
                touching += usize::from(expected);
            }
            assert!(touching > 0 && touching < n_u * n_w);
            let rim: Vec<Segment> = all
                .iter()
                .copied()
                .filter(|s| raster.on_rim(s, 1e-3))
                .collect();
            assert!(!rim.is_empty(), "seed {seed}");
            for cells in [1, 3] {
                let mut marked = Outside::new(all.iter().copied());
                marked.mark_band(&rim, cells);
                let expected = band_by_passes(&marked, 2 * cells + 1);
                let found: Vec<bool> = marked.state.iter().map(|&x| x & BAND != 0).collect();
                assert_eq!(found, expected, "seed {seed}, {cells} cells");
                assert!(found.iter().any(|&b| b) && found.iter().any(|&b| !b));
            }
            raster.mark_band(&rim, 3);
        }
    }

    #[test]
    fn a_diagonal_walk_steps_by_side_neighbours_to_the_last_cell() {
        let mut cells = Vec::new();
        cells_on(
            DVec2::ZERO,
            1.0,
            10,
            10,
            DVec2::new(0.5, 0.5),
            DVec2::new(7.2, 3.9),
            |c| cells.push(c),
        );
        assert_eq!(*cells.last().unwrap(), 3 * 10 + 7);
        for w in cells.windows(2) {
            let (a, b) = (w[0] as i64, w[1] as i64);
            assert!((a - b).abs() == 1 || (a - b).abs() == 10, "{cells:?}");
        }
    }
}
