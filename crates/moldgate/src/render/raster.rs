//! The z-buffer: orthographic cameras and triangles drawn with a depth test, per-vertex field
//! values interpolated across each triangle and Lambert shading per facet.

use glam::Vec4;

use crate::math::{DVec2, DVec3};
use crate::mesh::{Mesh, Topology};

use super::canvas::Rgb;
use super::pool::{Pool, Pooled};

/// An orthographic camera mapping millimetres to pixels of the canvas.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Screen right, unit.
    pub right: DVec3,
    /// Screen up, unit.
    pub up: DVec3,
    /// Towards the viewer (the view looks along `-toward`); right x up = toward.
    pub toward: DVec3,
    /// (right, up) coordinates, mm, shown at `origin`.
    pub centre: DVec2,
    /// Pixels per millimetre.
    pub scale: f64,
    /// Canvas pixel where `centre` is drawn.
    pub origin: DVec2,
}

impl Camera {
    /// Canvas position of `p` (x right, y down), pixels.
    #[inline]
    pub fn to_pixel(&self, p: DVec3) -> DVec2 {
        DVec2::new(
            self.origin.x + (p.dot(self.right) - self.centre.x) * self.scale,
            self.origin.y - (p.dot(self.up) - self.centre.y) * self.scale,
        )
    }

    /// Distance towards the viewer, mm (larger is nearer).
    #[inline]
    pub fn depth(&self, p: DVec3) -> f64 {
        p.dot(self.toward)
    }
}

/// An integer rectangle of the canvas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelRect {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width.
    pub w: u32,
    /// Height.
    pub h: u32,
}

/// Unit normal of the triangle (a, b, c) by its corner order, zero when degenerate.
/// Computed where it is used rather than kept: a stored normal per triangle is 8 MB of
/// fresh pages on the 352k-triangle part, which the system zeroes at a cost larger than the
/// arithmetic.
#[inline]
fn unit_normal(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    (b - a).cross(c - a).normalize_or_zero()
}

/// Which facets the views skip, found from the mesh alone (so beside the drawing order).
pub struct Facing {
    /// Whether the facets turned away from the viewer are skipped.
    cull: bool,
    /// Whether the facets of every body face into it.
    all_inward: bool,
    /// Per triangle of the mesh, whether its body's facets face into it; empty when no
    /// body's do, or when all do.
    inward: Vec<bool>,
}

impl Facing {
    /// Which facets every view skips: those turned away from the viewer, when `topology`
    /// (of the same mesh) says the mesh is closed and consistently oriented, none
    /// otherwise. Each body then bounds a solid, and a ray from the viewer meets a facet of a
    /// body where it enters that body before any facet where it leaves it: the nearest
    /// surface of every sample is a front face, so the back faces (about half the
    /// triangles, and more than half of the samples drawn) cannot show. Which side is the
    /// front comes from each body's signed volume (by the divergence theorem, positive when
    /// its facets face out): for a body wound inwards the test is turned round (its shading
    /// is the same, both sides being lit alike).
    pub fn of(mesh: &Mesh, topology: &Topology) -> Facing {
        use rayon::prelude::*;
        let none = Facing {
            cull: false,
            all_inward: false,
            inward: Vec::new(),
        };
        if !topology.closed_and_oriented(mesh) {
            return none;
        }
        let b = crate::math::Aabb::of_points(&mesh.vertices);
        let origin = (b.min + b.max) * 0.5;
        let size = (b.max - b.min).length();
        // Six times the volume of the tetrahedron (box centre, a, b, c), in fixed blocks so
        // that the sums do not depend on the threads.
        let tetrahedron = |tri: &[u32; 3]| {
            let [a, b, c] = tri.map(|v| mesh.vertices[v as usize] - origin);
            a.dot(b.cross(c))
        };
        let body = (topology.bodies > 1).then(|| crate::mesh::topology::body_of_triangle(mesh));
        let volumes: Vec<f64> = match &body {
            None => {
                let blocks: Vec<f64> = mesh
                    .triangles
                    .par_chunks(4096)
                    .map(|block| block.iter().map(tetrahedron).sum())
                    .collect();
                vec![blocks.iter().sum()]
            }
            Some(body) => {
                let bodies = body.iter().max().map_or(0, |&k| k as usize + 1);
                let mut volumes = vec![0.0; bodies];
                for (tri, &k) in mesh.triangles.iter().zip(body) {
                    volumes[k as usize] += tetrahedron(tri);
                }
                volumes
            }
        };
        if volumes.iter().any(|v| v.abs() <= 1e-9 * size * size * size) {
            return none; // a body enclosing no volume has no outside to tell
        }
        let inward: Vec<bool> = volumes.iter().map(|&v| v < 0.0).collect();
        let (all_inward, inward) = match &body {
            None => (inward[0], Vec::new()),
            Some(_) if inward.iter().all(|&i| i) => (true, Vec::new()),
            Some(_) if !inward.iter().any(|&i| i) => (false, Vec::new()),
            Some(body) => (false, body.iter().map(|&k| inward[k as usize]).collect()),
        };
        Facing {
            cull: true,
            all_inward,
            inward,
        }
    }
}

impl Facing {
    /// The same facets for a surface whose triangle `i` lies in mesh triangle `parent[i]`
    /// (a refined surface, [`crate::display::Display`]): each piece faces as its mesh
    /// triangle does.
    pub fn of_pieces(self, parent: &[u32]) -> Facing {
        let inward = if self.inward.is_empty() {
            Vec::new()
        } else {
            parent.iter().map(|&t| self.inward[t as usize]).collect()
        };
        Facing { inward, ..self }
    }
}

/// `x.floor()` for finite `x` within the range of `i32`, without the library call it
/// compiles to on the baseline x86-64.
#[inline]
fn floor(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// `x.ceil()`, as [`floor`].
#[inline]
fn ceil(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t < x {
        t + 1.0
    } else {
        t
    }
}

/// An unsigned key of a finite depth that orders as the depths do (larger is nearer), and
/// is never 0: the key of the empty sample. `-0.0` and `0.0` get one key.
#[inline]
fn depth_key(z: f32) -> u32 {
    crate::math::ordered_bits(z + 0.0)
}

/// The depth of a key of [`depth_key`].
#[inline]
fn key_depth(key: u32) -> f32 {
    crate::math::from_ordered_bits(key)
}

/// `x.round()` for `0 <= x < 2^24`, without the library call it compiles to on the
/// baseline x86-64: the fraction `x - trunc(x)` is exact in this range.
#[inline]
pub(super) fn round_non_negative(x: f32) -> f32 {
    let whole = x as u32 as f32;
    whole + f32::from(u8::from(x - whole >= 0.5))
}

/// Colour-map entry of a colour-map coordinate (clamped to 0..=1; not NaN).
#[inline]
pub(super) fn lut_index(t: f32) -> u8 {
    round_non_negative(t.clamp(0.0, 1.0) * 255.0) as u8
}

/// One panel to draw: where it goes in the picture, how it looks at the part, how its
/// samples are coloured, and the depths its overlays look up.
pub struct Panel<'a> {
    /// The camera.
    pub camera: Camera,
    /// The panel's rectangle in the picture.
    pub rect: PixelRect,
    /// Unit direction towards the light.
    pub light: DVec3,
    /// How the samples are coloured.
    pub colours: Colours<'a>,
    /// The places whose depth the overlays need, asked before drawing ([`Depths::ask`]) and
    /// answered by [`draw_projected`].
    pub depths: Depths,
}

/// The depth of the part at the places the overlays ask for, so that they can tell hidden
/// from visible without a z-buffer of the whole panel: the places are asked before the
/// panel is drawn, and each band of rows answers those in its rows while its samples are
/// at hand.
#[derive(Debug, Clone)]
pub struct Depths {
    rect: PixelRect,
    ss: u32,
    /// The samples asked for, as row << 32 | column of the panel's samples, sorted, each
    /// once (after [`Depths::prepare`]).
    at: Vec<u64>,
    /// The depth key ([`depth_key`]) of the nearest surface at each, 0 where the part is
    /// absent.
    key: Vec<u32>,
}

impl Depths {
    /// No places yet, in the panel `rect` drawn at `ss` samples per pixel along each axis.
    pub fn new(rect: PixelRect, ss: u32) -> Depths {
        Depths {
            rect,
            ss,
            at: Vec::new(),
            key: Vec::new(),
        }
    }

    /// The panel's sample under canvas position (x, y) pixels, `None` off the panel.
    fn sample(&self, x: f64, y: f64) -> Option<u64> {
        let s = self.ss as f64;
        let sx = ((x - self.rect.x as f64) * s).floor();
        let sy = ((y - self.rect.y as f64) * s).floor();
        let inside = |v: f64, n: u32| v >= 0.0 && v < n as f64 * s;
        (inside(sx, self.rect.w) && inside(sy, self.rect.h))
            .then_some((sy as u64) << 32 | sx as u64)
    }

    /// Asks for the depth at canvas position (x, y) pixels, which [`Depths::depth_at`] then
    /// gives once the panel is drawn.
    pub fn ask(&mut self, x: f64, y: f64) {
        if let Some(at) = self.sample(x, y) {
            self.at.push(at);
        }
    }

    /// [`Depths::ask`] at (x, y) and at the eight places one pixel around it, for
    /// [`Depths::visible_around`].
    pub fn ask_around(&mut self, x: f64, y: f64) {
        for (dx, dy) in AROUND {
            self.ask(x + dx, y + dy);
        }
    }

    /// Whether a point at (x, y), asked for with [`Depths::ask_around`], is visible
    /// ([`Depths::visible`]) there or one pixel around: a point on the edge of a step (a
    /// gate whose disc reaches the face above it) shows beside the step's upper face, whose
    /// edge may cover the sample under the point itself.
    pub fn visible_around(&self, x: f64, y: f64, depth: f64, tolerance: f64) -> bool {
        AROUND
            .iter()
            .any(|(dx, dy)| self.visible(x + dx, y + dy, depth, tolerance))
    }

    /// Sorts the places asked for, before drawing.
    fn prepare(&mut self) {
        self.at.sort_unstable();
        self.at.dedup();
        self.key = vec![0; self.at.len()];
    }

    /// Depth at canvas position (x, y) pixels, asked for before drawing: the nearest
    /// surface's at the sample under it, `None` off the part (or not asked for).
    pub fn depth_at(&self, x: f64, y: f64) -> Option<f32> {
        let at = self.sample(x, y)?;
        let i = self.at.binary_search(&at);
        debug_assert!(i.is_ok(), "the depth at ({x}, {y}) was not asked for");
        let key = self.key[i.ok()?];
        (key != 0).then(|| key_depth(key))
    }

    /// Whether a point at canvas (x, y), asked for before drawing, with depth `depth` is in
    /// front of, or within `tolerance` mm of, the surface drawn there.
    pub fn visible(&self, x: f64, y: f64, depth: f64, tolerance: f64) -> bool {
        match self.depth_at(x, y) {
            Some(d) => depth + tolerance >= d as f64,
            None => true,
        }
    }
}

/// A point and the eight places one pixel around it, canvas pixels.
const AROUND: [(f64, f64); 9] = [
    (0.0, 0.0),
    (-1.0, 0.0),
    (1.0, 0.0),
    (0.0, -1.0),
    (0.0, 1.0),
    (-1.0, -1.0),
    (1.0, -1.0),
    (-1.0, 1.0),
    (1.0, 1.0),
];

/// A panel's view of the mesh, found before its bands are drawn: the vertices projected and
/// the box of samples they reach.
pub struct Projection {
    rect: PixelRect,
    ss: usize,
    /// Each mesh vertex in sample coordinates of the panel (pixel centres at +0.5) and its
    /// depth.
    vertex: Vec<[f32; 3]>,
    /// The box's first column and row of samples in the panel (multiples of `ss`).
    x0: usize,
    y0: usize,
    /// The box's width and height in samples (multiples of `ss`).
    w: usize,
    h: usize,
}

impl Projection {
    #[inline(never)]
    pub fn new(mesh: &Mesh, camera: &Camera, rect: PixelRect, ss: u32) -> Projection {
        use rayon::prelude::*;
        let (panel_w, panel_h) = ((rect.w * ss) as usize, (rect.h * ss) as usize);
        let s = ss as f64;
        let vertex: Vec<[f32; 3]> = mesh
            .vertices
            .par_iter()
            .map(|&p| {
                let q = camera.to_pixel(p);
                [
                    ((q.x - rect.x as f64) * s) as f32,
                    ((q.y - rect.y as f64) * s) as f32,
                    camera.depth(p) as f32,
                ]
            })
            .collect();
        // The box of samples any triangle can reach: each triangle's rows and columns lie
        // within the floor and ceiling of its corners' coordinates, so within those of all
        // vertices. It is grown by one sample so that no sample drawn lies on its edge
        // (except at the panel's edge), which keeps the outline test at its edges the
        // panel's, and out to whole pixels so that a pixel's samples are all in it or all
        // outside. (Least and greatest in blocks on all threads: the same whatever the
        // order.)
        let empty = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        let (lo, hi) = vertex
            .par_chunks(1 << 14)
            .map(|block| {
                let (mut lo, mut hi) = empty;
                for p in block {
                    for k in 0..2 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
                (lo, hi)
            })
            .reduce(
                || empty,
                |(a_lo, a_hi), (b_lo, b_hi)| {
                    (
                        [a_lo[0].min(b_lo[0]), a_lo[1].min(b_lo[1])],
                        [a_hi[0].max(b_hi[0]), a_hi[1].max(b_hi[1])],
                    )
                },
            );
        let ssz = ss as usize;
        let span = |lo: f32, hi: f32, n: usize| -> (usize, usize) {
            let last = n as f32 - 1.0;
            let first = (floor(lo.clamp(-1.0, last)) - 1.0).clamp(0.0, last) as usize;
            let end = (ceil(hi.clamp(0.0, last + 1.0)) + 1.0).clamp(0.0, last) as usize + 1;
            (first / ssz * ssz, end.div_ceil(ssz) * ssz)
        };
        let (x0, x1) = span(lo[0], hi[0], panel_w);
        let (y0, y1) = span(lo[1], hi[1], panel_h);
        let (w, h) = (x1 - x0, y1.max(y0) - y0);
        let w = if h == 0 { 0 } else { w };
        Projection {
            rect,
            ss: ssz,
            vertex,
            x0,
            y0,
            w,
            h,
        }
    }

    /// The first and last row of samples of the box that triangle `corners` may cover in
    /// this panel, `None` when it is seen edge-on or degenerate (as [`Projection::setup`]
    /// finds them, without the rest of its set-up).
    #[inline(always)]
    fn rows(&self, corners: [u32; 3]) -> Option<(usize, usize)> {
        let [a, b, c] = corners.map(|i| self.vertex[i as usize]);
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area.abs() < 1e-12 || !area.is_finite() {
            return None;
        }
        let (first_y, last_y) = (self.y0 as f32, (self.y0 + self.h) as f32 - 1.0);
        let min_y = floor(a[1].min(b[1]).min(c[1])).max(first_y);
        let max_y = ceil(a[1].max(b[1]).max(c[1])).min(last_y);
        (min_y <= max_y).then_some((min_y as u32 as usize, max_y as u32 as usize))
    }

    /// Triangle `corners` as this panel draws it, `None` when it draws none of its samples
    /// (seen edge-on, degenerate, or outside the box).
    #[inline(always)]
    fn setup(&self, corners: [u32; 3], t: &[f32]) -> Option<Setup> {
        let [ia, ib, ic] = corners.map(|i| i as usize);
        let (a, b, c) = (self.vertex[ia], self.vertex[ib], self.vertex[ic]);
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area.abs() < 1e-12 || !area.is_finite() {
            return None; // seen edge-on, or degenerate
        }
        // The triangles' columns and rows clamped to the box, which only cuts what the
        // panel would: the same samples as clamping to the panel.
        let (first_x, last_x) = (self.x0 as f32, (self.x0 + self.w) as f32 - 1.0);
        let (first_y, last_y) = (self.y0 as f32, (self.y0 + self.h) as f32 - 1.0);
        let min_x = floor(a[0].min(b[0]).min(c[0])).max(first_x);
        let max_x = ceil(a[0].max(b[0]).max(c[0])).min(last_x);
        let min_y = floor(a[1].min(b[1]).min(c[1])).max(first_y);
        let max_y = ceil(a[1].max(b[1]).max(c[1])).min(last_y);
        if min_x > max_x || min_y > max_y {
            return None;
        }
        let (ta, tb, tc) = (t[ia], t[ib], t[ic]);
        Some(Setup {
            a,
            b,
            c,
            inv: 1.0 / area,
            t: [ta, tb, tc],
            min_x,
            max_x,
            rows: (min_y as u32 as usize, max_y as u32 as usize),
        })
    }
}

/// A triangle ready to draw in one panel: its corners in sample coordinates, the
/// reciprocal of its signed area, its corners' colour-map coordinates, and the columns and
/// rows of samples it may cover (clamped to the box).
struct Setup {
    a: [f32; 3],
    b: [f32; 3],
    c: [f32; 3],
    inv: f32,
    t: [f32; 3],
    min_x: f32,
    max_x: f32,
    /// First and last row.
    rows: (usize, usize),
}

impl Setup {
    /// Draws the triangle's rows `rows` (within its own) into `buffer`, rows of `w` samples
    /// from the box's first column `x0`, the first of them the box's row `first_row`: the
    /// depth test keeps the largest sample, `(depth key) << 32 | !facet`, and with it the
    /// facet's colour-map entry there and its `shade`. Every sample is computed from its
    /// row's first column, whichever rows are drawn, so that a band of rows gets the
    /// samples the whole panel would.
    ///
    /// A row of at most [`MASKED_ROW`] samples is stepped across once, keeping each
    /// sample's weights in `steps` and whether it is inside as a bit, and its run of
    /// samples (the first block of set bits) is then drawn from those weights: the same
    /// weights and the same run as stepping sample by sample until the run ends, without a
    /// branch on where the run starts (which the processor cannot foresee), and with the
    /// depth test's writes chosen rather than branched to. Rows of at most
    /// [`GROUPED_ROW`] samples (most triangles of a fine mesh) are stepped four at a time,
    /// one row in each lane of a vector: each lane takes the steps its row takes alone, so
    /// the weights are the same to the bit.
    #[inline]
    fn draw_rows(
        &self,
        (facet, shade): (u32, f32),
        rows: std::ops::Range<usize>,
        buffer: &mut Buffer,
        (x0, w, first_row): (usize, usize, usize),
        steps: &mut Steps,
    ) {
        let (a, b, c, inv) = (self.a, self.b, self.c, self.inv);
        let [ta, tb, tc] = self.t;
        // A value missing at one corner is missing over the whole facet (it would be NaN
        // at every sample): the facet is drawn grey.
        let has_value = !(ta.is_nan() || tb.is_nan() || tc.is_nan());
        let facet = !facet as u64;
        // Barycentric weights from edge functions, normalised by the signed area so either
        // winding works; stepped along each row.
        let dwa = -(c[1] - b[1]) * inv;
        let dwb = -(a[1] - c[1]) * inv;
        let (dz_a, dz_b) = (a[2] - c[2], b[2] - c[2]);
        let (dt_a, dt_b) = (ta - tc, tb - tc);
        // The box's columns of the triangle's samples, the same in every row.
        let min_x = self.min_x;
        let (first, end) = (
            min_x as u32 as usize - x0,
            self.max_x as u32 as usize + 1 - x0,
        );
        // A sliver of overlap rather than a crack where two triangles meet: samples on a
        // shared edge would otherwise be missed by both when rounding goes against them
        // (the depth test settles the overlap). One test, not three branches.
        // (Both weights at least `-EDGE_SLACK` as their lesser is: the same test, one
        // comparison fewer; a NaN weight fails it either way, through the sum.)
        let inside = |wa: f32, wb: f32| {
            let least = if wa < wb { wa } else { wb };
            (least >= -EDGE_SLACK) & (wa + wb <= 1.0 + EDGE_SLACK)
        };
        let n = end - first;
        // Draws a row's run of samples, the first block of set `bits` (a triangle's row is
        // one run), from the buffer's sample `at` on, sample `k`'s weights `weights`: the
        // depth test's writes chosen rather than branched to.
        macro_rules! draw_run {
            ($at:expr, $bits:expr, |$k:ident| $weights:expr) => {{
                let bits: u64 = $bits;
                let from = bits.trailing_zeros() as usize;
                let len = (!(bits >> from)).trailing_zeros() as usize;
                let at = $at + from;
                let samples = &mut buffer.sample[at..at + len];
                let luts = &mut buffer.lut[at..at + len];
                let shades = &mut buffer.shade[at..at + len];
                for i in 0..len {
                    let [wa, wb]: [f32; 2] = {
                        let $k = from + i;
                        $weights
                    };
                    let z = depth_key(c[2] + wa * dz_a + wb * dz_b);
                    let sample = (z as u64) << 32 | facet;
                    let old = samples[i];
                    let nearer = sample > old;
                    samples[i] = if nearer { sample } else { old };
                    shades[i] = if nearer { shade } else { shades[i] };
                    if has_value {
                        let lut = lut_index(tc + wa * dt_a + wb * dt_b);
                        luts[i] = if nearer { lut } else { luts[i] };
                    }
                }
            }};
        }
        if n <= GROUPED_ROW {
            let px = min_x + 0.5;
            // Each row's edge functions at its first sample, as a row alone computes them:
            // the part that varies with the row, less the part that does not.
            let (across_a, across_b) = (c[0] - b[0], a[0] - c[0]);
            let (along_a, along_b) = ((c[1] - b[1]) * (px - b[0]), (a[1] - c[1]) * (px - c[0]));
            let (dwa4, dwb4) = (Vec4::splat(dwa), Vec4::splat(dwb));
            let (low, high) = (Vec4::splat(-EDGE_SLACK), Vec4::splat(1.0 + EDGE_SLACK));
            let group = &mut steps.group;
            for y in rows.clone().step_by(4) {
                let py = Vec4::new(
                    y as f32 + 0.5,
                    (y + 1) as f32 + 0.5,
                    (y + 2) as f32 + 0.5,
                    (y + 3) as f32 + 0.5,
                );
                let mut wa = (Vec4::splat(across_a) * (py - Vec4::splat(b[1]))
                    - Vec4::splat(along_a))
                    * Vec4::splat(inv);
                let mut wb = (Vec4::splat(across_b) * (py - Vec4::splat(c[1]))
                    - Vec4::splat(along_b))
                    * Vec4::splat(inv);
                // Each sample's four bits (one a row) enter at the top and move down four
                // places a sample: sample k's are bits 4k..4k + 4 at the end.
                let mut nibbles = 0u64;
                for step in &mut group[..n] {
                    *step = [wa.to_array(), wb.to_array()];
                    // The lesser weight as `inside` takes it (the second when either is
                    // NaN, which fails through the sum either way).
                    let least = wa.min(wb);
                    let inside = least.cmpge(low) & (wa + wb).cmple(high);
                    nibbles = nibbles >> 4 | u64::from(inside.bitmask()) << 60;
                    wa += dwa4;
                    wb += dwb4;
                }
                let nibbles = nibbles >> (4 * (GROUPED_ROW - n));
                // A lane is a row: it picks the row's bits and its weights out of every
                // step kept, not the items of one slice.
                #[allow(clippy::needless_range_loop)]
                for lane in 0..(rows.end - y).min(4) {
                    let bits = every_fourth(nibbles >> lane);
                    if bits == 0 {
                        continue;
                    }
                    let row = (y + lane - first_row) * w;
                    draw_run!(row + first, bits, |k| [
                        group[k][0][lane],
                        group[k][1][lane]
                    ]);
                }
            }
            return;
        }
        let steps = &mut steps.row;
        for y in rows {
            let py = y as f32 + 0.5;
            let px = min_x + 0.5;
            let mut wa = ((c[0] - b[0]) * (py - b[1]) - (c[1] - b[1]) * (px - b[0])) * inv;
            let mut wb = ((a[0] - c[0]) * (py - c[1]) - (a[1] - c[1]) * (px - c[0])) * inv;
            let row = (y - first_row) * w;
            if n <= MASKED_ROW {
                // The weights are stepped from the row's first column, so every sample
                // sees the sums the sample-by-sample stepping gives it. Each sample's bit
                // enters at the top and moves down a place a sample (a shift by a
                // constant, not by the sample's place): sample k's is bit k at the end.
                let mut bits = 0u64;
                for step in &mut steps[..n] {
                    *step = [wa, wb];
                    bits = bits >> 1 | u64::from(inside(wa, wb)) << 63;
                    wa += dwa;
                    wb += dwb;
                }
                let bits = bits >> (MASKED_ROW - n);
                if bits == 0 {
                    continue;
                }
                draw_run!(row + first, bits, |k| steps[k]);
                continue;
            }
            let samples = &mut buffer.sample[row + first..row + end];
            let luts = &mut buffer.lut[row + first..row + end];
            let shades = &mut buffer.shade[row + first..row + end];
            // The weights are stepped from the row's first column in both loops, so every
            // sample sees the same sums whichever loop reaches it.
            let mut k = 0;
            while k < samples.len() && !inside(wa, wb) {
                wa += dwa;
                wb += dwb;
                k += 1;
            }
            // A triangle's row is one run of samples: it ends at the first one outside.
            while k < samples.len() && inside(wa, wb) {
                let z = depth_key(c[2] + wa * dz_a + wb * dz_b);
                let sample = (z as u64) << 32 | facet;
                if sample > samples[k] {
                    samples[k] = sample;
                    shades[k] = shade;
                    if has_value {
                        luts[k] = lut_index(tc + wa * dt_a + wb * dt_b);
                    }
                }
                wa += dwa;
                wb += dwb;
                k += 1;
            }
        }
    }
}

/// The longest row of a triangle's box that [`Setup::draw_rows`] draws through a mask of
/// its samples inside (a bit each).
const MASKED_ROW: usize = 64;

/// The longest row of a triangle's box that [`Setup::draw_rows`] steps four rows at a time
/// (four bits a sample in one word).
const GROUPED_ROW: usize = 16;

/// The weights [`Setup::draw_rows`] keeps of a row's samples, and of four rows' (a lane
/// each), reused from triangle to triangle.
pub(super) struct Steps {
    row: [[f32; 2]; MASKED_ROW],
    group: [[[f32; 4]; 2]; GROUPED_ROW],
}

impl Default for Steps {
    fn default() -> Steps {
        Steps {
            row: [[0.0; 2]; MASKED_ROW],
            group: [[[0.0; 4]; 2]; GROUPED_ROW],
        }
    }
}

/// Bits 0, 4, 8, ... 60 of `x` as bits 0 to 15.
#[inline]
fn every_fourth(x: u64) -> u64 {
    let x = x & 0x1111_1111_1111_1111;
    let x = (x | x >> 3) & 0x0303_0303_0303_0303;
    let x = (x | x >> 6) & 0x000f_000f_000f_000f;
    let x = (x | x >> 12) & 0x0000_00ff_0000_00ff;
    (x | x >> 24) & 0xffff
}

/// Whether facet `k` with unit normal `n` is drawn by a camera looking along `-toward`:
/// not when `facing` skips back faces and it is one.
#[inline]
fn front(facing: Option<&Facing>, k: usize, n: DVec3, toward: DVec3) -> bool {
    match facing {
        Some(f) if f.cull => {
            let towards = n.dot(toward);
            let inward = f.all_inward || f.inward.get(k).copied().unwrap_or(false);
            // A back face of a closed body: a front face is nearer wherever it is.
            (if inward { -towards } else { towards }) >= 0.0
        }
        _ => true,
    }
}

/// Rows of pixels drawn and coloured by one task of [`draw_projected`].
const BAND: usize = 16;

/// Triangles binned by one task of [`draw_projected`].
const BIN_CHUNK: usize = 1 << 14;

/// The triangles of one block of the mesh that each band of one panel draws: band `j`'s
/// are `entry[start[j]..start[j + 1]]`, in the mesh's order.
struct Bins {
    start: Vec<u32>,
    entry: Vec<u32>,
}

/// A band's samples, rows of the box's width: the depth test's word (depth key << 32 |
/// !facet, 0 where the part is absent), the colour-map entry of the field there and the
/// facet's Lambert factor (negated when it has no field value). An entry and a factor are
/// read only where the sample is not empty, so only where its facet wrote them: they are
/// never cleared.
#[derive(Default)]
struct Buffer {
    sample: Vec<u64>,
    lut: Vec<u8>,
    shade: Vec<f32>,
}

/// A task's buffers, reused from band to band (and from task to task: [`Pooled`]).
#[derive(Default)]
struct Scratch {
    buffer: Buffer,
    depths: Vec<f32>,
    outline: Vec<bool>,
    colours: Vec<[f32; 3]>,
}

/// [`draw_projected`] with each panel's projection made here, at `ss` x `ss` samples per
/// pixel.
#[cfg(test)]
pub fn draw(
    mesh: &Mesh,
    t: &[f32],
    facing: Option<&Facing>,
    panels: &mut [Panel],
    ss: u32,
    rgba: &mut [u8],
    stride: usize,
) {
    let projections: Vec<Projection> = panels
        .iter()
        .map(|p| Projection::new(mesh, &p.camera, p.rect, ss))
        .collect();
    draw_projected(mesh, t, facing, panels, &projections, rgba, stride);
}

/// Draws `mesh` into the panels of the picture whose opaque RGBA bytes are `rgba`,
/// `stride` pixels a row, each seen as its [`Projection`] (made beforehand, beside other
/// work), and answers each panel's [`Depths`]. `t` is the colour-map coordinate of each
/// vertex (NaN: no value), `facing` the facets to skip. Panels lie side by side; rows of a
/// panel below the picture are not drawn (and their depths not answered).
///
/// No z-buffer of a whole panel is kept: the picture's rows are drawn in bands of [`BAND`]
/// rows of pixels on all threads, each band drawing the triangles that reach its rows of
/// samples (and the row above and below, for the outline test) into buffers each thread
/// reuses ([`Pooled`]), then colouring its pixels and answering the depths asked for in
/// its rows while the samples are in the cache. Each triangle's band is found once
/// beforehand (blocks of the mesh on all threads). A sample keeps the nearest facet and, at one depth, the first
/// in the mesh, and every row of a triangle is computed from its own coordinate, so a band
/// holds exactly the samples a z-buffer of the whole panel would: the picture does not
/// depend on the bands nor the threads.
pub fn draw_projected(
    mesh: &Mesh,
    t: &[f32],
    facing: Option<&Facing>,
    panels: &mut [Panel],
    projections: &[Projection],
    rgba: &mut [u8],
    stride: usize,
) {
    use rayon::prelude::*;
    let rows_in_picture = rgba.len() / (4 * stride).max(1);
    let top = panels.iter().map(|p| p.rect.y as usize).min().unwrap_or(0);
    let bottom = panels
        .iter()
        .map(|p| (p.rect.y + p.rect.h) as usize)
        .max()
        .unwrap_or(0)
        .min(rows_in_picture);
    for p in panels.iter_mut() {
        p.depths.prepare();
    }
    if stride == 0 || top >= bottom {
        return;
    }
    let bands = (bottom - top).div_ceil(BAND);
    let count = projections.len();
    // Each facet's Lambert factor per panel (negated when it has no field value), and the
    // bands of each block of triangles.
    let mut shade = vec![0.0f32; mesh.triangles.len() * count];
    // Each running task's lists of spans are made once ([`Pooled`]).
    let pool: Pool<Vec<Vec<(u32, u32, u32)>>> = Pool::default();
    let bins: Vec<Vec<Bins>> = mesh
        .triangles
        .par_chunks(BIN_CHUNK)
        .zip(shade.par_chunks_mut(BIN_CHUNK * count))
        .enumerate()
        .map_init(
            || Pooled::take(&pool),
            |spans, (block, (triangles, shade))| {
                let first = block * BIN_CHUNK;
                spans.resize_with(count, Vec::new);
                spans.iter_mut().for_each(Vec::clear);
                for (i, &corners) in triangles.iter().enumerate() {
                    let [ia, ib, ic] = corners.map(|v| mesh.vertices[v as usize]);
                    let n = unit_normal(ia, ib, ic);
                    for (k, (panel, p)) in panels.iter().zip(projections).enumerate() {
                        if !front(facing, first + i, n, panel.camera.toward) {
                            continue;
                        }
                        let Some((lo, hi)) = p.rows(corners) else {
                            continue;
                        };
                        // Lambert: the facet normal against the light, both sides lit (meshes
                        // are not always consistently oriented).
                        let lit = (AMBIENT + DIFFUSE * n.dot(panel.light).abs()) as f32;
                        // A value missing at one corner is missing over the whole facet.
                        let has_value = !corners.iter().any(|&v| t[v as usize].is_nan());
                        shade[i * count + k] = if has_value { lit } else { -lit };
                        // The bands whose rows, or the row above or below them, it reaches.
                        let offset = (p.rect.y as usize - top) * p.ss;
                        let per_band = BAND * p.ss;
                        let band = |row: usize| {
                            if per_band.is_power_of_two() {
                                row >> per_band.trailing_zeros()
                            } else {
                                row / per_band
                            }
                        };
                        let span = (
                            band((offset + lo).saturating_sub(1)),
                            band(offset + hi + 1).min(bands - 1),
                        );
                        spans[k].push(((first + i) as u32, span.0 as u32, span.1 as u32));
                    }
                }
                spans
                    .iter()
                    .map(|spans| {
                        let mut start = vec![0u32; bands + 1];
                        for &(_, lo, hi) in spans {
                            for j in lo..=hi {
                                start[j as usize + 1] += 1;
                            }
                        }
                        for j in 0..bands {
                            start[j + 1] += start[j];
                        }
                        let mut next = start.clone();
                        let mut entry = vec![0u32; start[bands] as usize];
                        for &(k, lo, hi) in spans {
                            for j in lo..=hi {
                                let slot = &mut next[j as usize];
                                entry[*slot as usize] = k;
                                *slot += 1;
                            }
                        }
                        Bins { start, entry }
                    })
                    .collect()
            },
        )
        .collect();
    let shade = &shade;
    let bins = &bins;
    let region = &mut rgba[4 * stride * top..4 * stride * bottom];
    let pool: Pool<Scratch> = Pool::default();
    let answers: Vec<Vec<(usize, Vec<u32>)>> = region
        .par_chunks_mut(4 * stride * BAND)
        .enumerate()
        .map_init(
            || Pooled::take(&pool),
            |pooled, (band, chunk)| {
                let scratch: &mut Scratch = pooled;
                let rows = top + band * BAND..top + band * BAND + chunk.len() / (4 * stride);
                panels
                    .iter()
                    .zip(projections)
                    .enumerate()
                    .map(|(k, (panel, p))| {
                        let band = Band {
                            mesh,
                            t,
                            p,
                            shade: (shade, k, count),
                            bins: bins.iter().map(|b| &b[k]).collect(),
                            index: band,
                        };
                        band.draw(rows.clone(), chunk, stride, panel, scratch)
                    })
                    .collect()
            },
        )
        .collect();
    for band in answers {
        for (panel, (first, keys)) in panels.iter_mut().zip(band) {
            panel.depths.key[first..first + keys.len()].copy_from_slice(&keys);
        }
    }
}

/// One band of one panel: what [`draw_projected`] draws it from.
struct Band<'a> {
    mesh: &'a Mesh,
    t: &'a [f32],
    p: &'a Projection,
    /// The Lambert factors, this panel's index among them and the number of panels.
    shade: (&'a [f32], usize, usize),
    bins: Vec<&'a Bins>,
    index: usize,
}

impl Band<'_> {
    /// Draws and colours the band: the picture's rows `rows`, whose bytes are `chunk`.
    /// Returns the first of the panel's depths in these rows and their keys.
    fn draw(
        &self,
        rows: std::ops::Range<usize>,
        chunk: &mut [u8],
        stride: usize,
        panel: &Panel,
        scratch: &mut Scratch,
    ) -> (usize, Vec<u32>) {
        let p = self.p;
        let rect = p.rect;
        let ss = p.ss;
        let (left, top) = (rect.x as usize, rect.y as usize);
        // The panel's rows of pixels in the band.
        let (p0, p1) = (
            rows.start.max(top) - top,
            rows.end.min(top + rect.h as usize).max(top) - top,
        );
        let depths = &panel.depths;
        let asked = |row: usize| depths.at.partition_point(|&at| at < (row as u64) << 32);
        let (first, last) = (asked(p0 * ss), asked(p1 * ss));
        let mut keys = vec![0u32; last - first];
        if p0 >= p1 || left >= stride {
            return (first, keys);
        }
        let columns = (rect.w as usize).min(stride - left);
        // The part's box in pixels of the panel; every pixel outside it is the background
        // (the mean of equal whole numbers is exact).
        let (bx0, by0) = ((p.x0 / ss).min(columns), p.y0 / ss);
        let (bx1, by1) = ((p.x0 / ss + p.w / ss).min(columns), by0 + p.h / ss);
        let bg = panel.colours.background;
        let bg_rgba = [bg[0], bg[1], bg[2], 255];
        // The band's rows of pixels inside the box.
        let (inside0, inside1) = (p0.max(by0), p1.min(by1));
        if inside0 < inside1 {
            let (r0, r1) = (inside0 * ss, inside1 * ss);
            let (e0, e1) = (r0.saturating_sub(1).max(p.y0), (r1 + 1).min(p.y0 + p.h));
            let w = p.w;
            self.rasterise((e0, e1), scratch);
            let samples = Samples {
                w,
                ss,
                first_row: e0,
                buffer: &scratch.buffer,
            };
            samples.depth_rows(r0, r1, (p.y0, p.y0 + p.h), &mut scratch.depths);
            for (i, &at) in depths.at[first..last].iter().enumerate() {
                let (row, column) = ((at >> 32) as usize, at as u32 as usize);
                if (r0..r1).contains(&row) && (p.x0..p.x0 + w).contains(&column) {
                    keys[i] = (scratch.buffer.sample[(row - e0) * w + column - p.x0] >> 32) as u32;
                }
            }
            for py in inside0..inside1 {
                let line = (top + py - rows.start) * 4 * stride;
                let out = &mut chunk[line + 4 * left..line + 4 * (left + columns)];
                let (before, rest) = out.split_at_mut(4 * bx0);
                let (part, after) = rest.split_at_mut(4 * (bx1 - bx0));
                for px in before.chunks_exact_mut(4).chain(after.chunks_exact_mut(4)) {
                    px.copy_from_slice(&bg_rgba);
                }
                // The pixel's first row of samples, and its row in the depths.
                let s0 = py * ss;
                let d0 = s0 - r0 + 1;
                samples.colour_row(
                    &scratch.depths,
                    (s0, d0),
                    part,
                    &panel.colours,
                    (&mut scratch.outline, &mut scratch.colours),
                );
            }
        }
        for py in (p0..p1).filter(|py| !(inside0..inside1).contains(py)) {
            let line = (top + py - rows.start) * 4 * stride;
            chunk[line + 4 * left..line + 4 * (left + columns)]
                .chunks_exact_mut(4)
                .for_each(|px| px.copy_from_slice(&bg_rgba));
        }
        (first, keys)
    }

    /// Draws the triangles of the band into `scratch`'s samples of the box's rows `e0..e1`,
    /// emptied first.
    #[inline(never)]
    fn rasterise(&self, (e0, e1): (usize, usize), scratch: &mut Scratch) {
        let p = self.p;
        let w = p.w;
        let buffer = &mut scratch.buffer;
        buffer.sample.clear();
        buffer.sample.resize((e1 - e0) * w, 0);
        // Read only where a facet wrote them ([`Buffer`]).
        buffer.lut.resize((e1 - e0) * w, 0);
        buffer.shade.resize((e1 - e0) * w, 0.0);
        let (shade, panel, panels) = self.shade;
        let mut steps = Steps::default();
        for bins in &self.bins {
            let (from, to) = (
                bins.start[self.index] as usize,
                bins.start[self.index + 1] as usize,
            );
            for &k in &bins.entry[from..to] {
                let Some(setup) = p.setup(self.mesh.triangles[k as usize], self.t) else {
                    continue;
                };
                let (lo, hi) = setup.rows;
                let rows = lo.max(e0)..(hi + 1).min(e1);
                if rows.is_empty() {
                    continue;
                }
                let shade = shade[k as usize * panels + panel];
                setup.draw_rows((k, shade), rows, buffer, (p.x0, w, e0), &mut steps);
            }
        }
    }
}

/// Rows of a panel's samples in a band's buffer, the box's columns only.
struct Samples<'a> {
    /// The box's width in samples.
    w: usize,
    ss: usize,
    /// The box's row of the buffer's first.
    first_row: usize,
    buffer: &'a Buffer,
}

impl Samples<'_> {
    /// Into `out`, the depths of the box's rows `r0..r1` with the row above and the row
    /// below (the first or last row itself at the box's edge `rows`), each padded at both
    /// ends with its end values: `(r1 - r0 + 2)` rows of `w + 2`. Empty samples are NaN.
    #[inline(never)]
    fn depth_rows(&self, r0: usize, r1: usize, rows: (usize, usize), out: &mut Vec<f32>) {
        let w = self.w;
        out.clear();
        out.reserve((r1 - r0 + 2) * (w + 2));
        let above = if r0 > rows.0 { r0 - 1 } else { r0 };
        let below = if r1 < rows.1 { r1 } else { r1 - 1 };
        for s in std::iter::once(above)
            .chain(r0..r1)
            .chain(std::iter::once(below))
        {
            let s = s - self.first_row;
            let keys = &self.buffer.sample[s * w..(s + 1) * w];
            let depth = |&k: &u64| {
                let key = (k >> 32) as u32;
                if key == 0 {
                    f32::NAN
                } else {
                    key_depth(key)
                }
            };
            out.push(depth(&keys[0]));
            out.extend(keys.iter().map(depth));
            out.push(depth(&keys[w - 1]));
        }
    }

    /// Colours the pixels of one row of the box into `out` (RGBA): the pixel's first row of
    /// samples `s0` in the box and `d0` in `depths` (from [`Samples::depth_rows`]);
    /// `scratch` holds a row of outline marks and the colours of the pixel's rows of
    /// samples. Each sample is its `lut` entry times its facet's shade (`no_value` for a
    /// facet without a field value; [`OUTLINE_FACTOR`] instead of the shade on an outline,
    /// where the depth jumps by more than `crease_mm` to a neighbour or the part ends
    /// there) over `background`, and each pixel the mean of its samples.
    #[inline(never)]
    fn colour_row(
        &self,
        depths: &[f32],
        (s0, d0): (usize, usize),
        out: &mut [u8],
        c: &Colours,
        (outline, colours): (&mut Vec<bool>, &mut Vec<[f32; 3]>),
    ) {
        let (w, ss) = (self.w, self.ss);
        let pw = w + 2;
        outline.resize(w, false);
        colours.resize(ss * w, [0.0; 3]);
        let bg = c.background.map(|v| v as f32);
        for dy in 0..ss {
            let d = d0 + dy;
            let (above, row, below) = (
                &depths[(d - 1) * pw..d * pw],
                &depths[d * pw..(d + 1) * pw],
                &depths[(d + 1) * pw..(d + 2) * pw],
            );
            // An outline where the depth jumps to one of the four neighbours: NaN (an empty
            // neighbour) is never near, a padded end or a missing row (the sample itself)
            // always is. No branches, so that the rows' marks are computed several at once.
            for (x, mark) in outline.iter_mut().enumerate() {
                let at = row[x + 1];
                let near = |e: f32| (e - at).abs() <= c.crease_mm;
                *mark =
                    !(near(row[x]) & near(row[x + 2]) & near(above[x + 1]) & near(below[x + 1]));
            }
            let s = s0 + dy - self.first_row;
            let samples = &self.buffer.sample[s * w..(s + 1) * w];
            let luts = &self.buffer.lut[s * w..(s + 1) * w];
            let shades = &self.buffer.shade[s * w..(s + 1) * w];
            let colours = &mut colours[dy * w..(dy + 1) * w];
            for ((((colour, &sample), &lut), &shade), &mark) in colours
                .iter_mut()
                .zip(samples)
                .zip(luts)
                .zip(shades)
                .zip(outline.iter())
            {
                *colour = if sample == 0 {
                    bg
                } else {
                    let base = if shade < 0.0 {
                        c.no_value
                    } else {
                        c.lut[lut as usize]
                    };
                    let k = if mark { OUTLINE_FACTOR } else { shade.abs() };
                    base.map(|v| v * k)
                };
            }
        }
        // Each pixel the mean of its samples, summed row by row from the left.
        let n = (ss * ss) as f32;
        for (px, pixel) in out.chunks_exact_mut(4).enumerate() {
            let mut sum = [0.0f32; 3];
            for dy in 0..ss {
                for colour in &colours[dy * w + px * ss..dy * w + (px + 1) * ss] {
                    for k in 0..3 {
                        sum[k] += colour[k];
                    }
                }
            }
            let [r, g, b] = sum.map(|v| (v / n + 0.5).clamp(0.0, 255.0) as u8);
            pixel.copy_from_slice(&[r, g, b, 255]);
        }
    }
}

/// Tolerance of the inside test, in barycentric units.
const EDGE_SLACK: f32 = 1e-4;

/// Light kept on faces turned away from the light.
const AMBIENT: f64 = 0.32;
/// Light added on faces turned to it.
const DIFFUSE: f64 = 0.68;

/// How a panel's samples are coloured ([`Samples::colour_row`]).
pub struct Colours<'a> {
    /// The colour map, 256 entries.
    pub lut: &'a [[f32; 3]; 256],
    /// The colour of a facet without a field value.
    pub no_value: [f32; 3],
    /// The colour where the part is absent.
    pub background: Rgb,
    /// The depth step, mm, between neighbouring samples that draws an outline.
    pub crease_mm: f32,
}

/// Brightness of outline samples.
const OUTLINE_FACTOR: f32 = 0.22;

#[cfg(test)]
mod tests {
    use super::*;

    fn square_camera() -> Camera {
        Camera {
            right: DVec3::X,
            up: DVec3::Y,
            toward: DVec3::Z,
            centre: DVec2::ZERO,
            scale: 10.0,
            origin: DVec2::new(50.0, 50.0),
        }
    }

    /// A z-buffer of a whole panel, as the picture was drawn before its bands: the oracle
    /// of [`draw`]. Its box covers the samples all vertices reach, grown by one and out to
    /// whole pixels.
    struct Layer {
        rect: PixelRect,
        ss: u32,
        x0: usize,
        y0: usize,
        w: usize,
        h: usize,
        sample: Vec<u64>,
        lut: Vec<u8>,
        shade: Vec<f32>,
    }

    impl Layer {
        fn depth_at(&self, x: f64, y: f64) -> Option<f32> {
            let sx = ((x - self.rect.x as f64) * self.ss as f64).floor() - self.x0 as f64;
            let sy = ((y - self.rect.y as f64) * self.ss as f64).floor() - self.y0 as f64;
            if sx < 0.0 || sy < 0.0 || sx >= self.w as f64 || sy >= self.h as f64 {
                return None;
            }
            let key = (self.sample[sy as usize * self.w + sx as usize] >> 32) as u32;
            (key != 0).then(|| key_depth(key))
        }
    }

    /// The whole panel's z-buffer, the triangles drawn one after the other in the mesh's
    /// order (the code the picture had before its bands, less the drawing order, which
    /// does not change a sample).
    fn whole(
        mesh: &Mesh,
        t: &[f32],
        facing: Option<&Facing>,
        camera: &Camera,
        rect: PixelRect,
        ss: u32,
        light: DVec3,
    ) -> Layer {
        // The same vertices and box of samples as the bands (what is compared is the drawing).
        let Projection {
            vertex: projected,
            x0,
            y0,
            w,
            h,
            ..
        } = Projection::new(mesh, camera, rect, ss);
        let mut layer = Layer {
            rect,
            ss,
            x0,
            y0,
            w,
            h,
            sample: vec![0; w * h],
            lut: vec![0; w * h],
            shade: vec![0.0; mesh.triangles.len()],
        };
        let (first_x, last_x) = (x0 as f32, (x0 + w) as f32 - 1.0);
        let (first_y, last_y) = (y0 as f32, (y0 + h) as f32 - 1.0);
        for (place, corners) in mesh.triangles.iter().enumerate() {
            let [ia, ib, ic] = corners.map(|i| i as usize);
            let n = unit_normal(mesh.vertices[ia], mesh.vertices[ib], mesh.vertices[ic]);
            if !front(facing, place, n, camera.toward) {
                continue;
            }
            let (a, b, c) = (projected[ia], projected[ib], projected[ic]);
            let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            if area.abs() < 1e-12 || !area.is_finite() {
                continue;
            }
            let min_x = a[0].min(b[0]).min(c[0]).floor().max(first_x);
            let max_x = a[0].max(b[0]).max(c[0]).ceil().min(last_x);
            let min_y = a[1].min(b[1]).min(c[1]).floor().max(first_y);
            let max_y = a[1].max(b[1]).max(c[1]).ceil().min(last_y);
            if min_x > max_x || min_y > max_y {
                continue;
            }
            let shade = (AMBIENT + DIFFUSE * n.dot(light).abs()) as f32;
            let inv = 1.0 / area;
            let (ta, tb, tc) = (t[ia], t[ib], t[ic]);
            let has_value = !(ta.is_nan() || tb.is_nan() || tc.is_nan());
            layer.shade[place] = if has_value { shade } else { -shade };
            let facet = !(place as u32) as u64;
            let dwa = -(c[1] - b[1]) * inv;
            let dwb = -(a[1] - c[1]) * inv;
            for y in min_y as usize..max_y as usize + 1 {
                let py = y as f32 + 0.5;
                let px = min_x + 0.5;
                let mut wa = ((c[0] - b[0]) * (py - b[1]) - (c[1] - b[1]) * (px - b[0])) * inv;
                let mut wb = ((a[0] - c[0]) * (py - c[1]) - (a[1] - c[1]) * (px - c[0])) * inv;
                let mut entered = false;
                for x in min_x as usize..max_x as usize + 1 {
                    if wa >= -EDGE_SLACK && wb >= -EDGE_SLACK && wa + wb <= 1.0 + EDGE_SLACK {
                        entered = true;
                        let z = depth_key(c[2] + wa * (a[2] - c[2]) + wb * (b[2] - c[2]));
                        let sample = (z as u64) << 32 | facet;
                        let i = (y - y0) * w + x - x0;
                        if sample > layer.sample[i] {
                            layer.sample[i] = sample;
                            if has_value {
                                layer.lut[i] = lut_index(tc + wa * (ta - tc) + wb * (tb - tc));
                            }
                        }
                    } else if entered {
                        break; // a row of a triangle is one run of samples
                    }
                    wa += dwa;
                    wb += dwb;
                }
            }
        }
        layer
    }

    #[test]
    fn depth_keys_order_as_depths_and_round_trip() {
        let depths = [
            -1e9f32, -3.5, -1.0, -1e-30, -0.0, 0.0, 1e-30, 0.25, 1.0, 7.5, 1e9,
        ];
        for pair in depths.windows(2) {
            let (a, b) = (depth_key(pair[0]), depth_key(pair[1]));
            assert!(a != 0 && b != 0);
            if pair[0] == pair[1] {
                assert_eq!(a, b, "{pair:?}");
            } else {
                assert!(a < b, "{pair:?}");
            }
        }
        for d in depths {
            assert_eq!(key_depth(depth_key(d)), d + 0.0);
        }
    }

    /// The samples of a layer drawn with back faces skipped against the same layer with
    /// both sides drawn, on closed samples seen from an oblique camera and along an axis:
    /// the same nearest facet (so the same depth and colour) at all but a few samples on
    /// the outline, also when the mesh is wound inwards. An open mesh is drawn on both
    /// sides.
    #[test]
    fn skipping_back_faces_keeps_the_nearest_surface() {
        let toward = DVec3::new(0.5, -0.45, 0.74).normalize();
        let up = (DVec3::Z - toward * toward.z).normalize();
        let oblique = Camera {
            right: up.cross(toward),
            up,
            toward,
            centre: DVec2::ZERO,
            scale: 4.0,
            origin: DVec2::new(100.0, 100.0),
        };
        let rect = PixelRect {
            x: 0,
            y: 0,
            w: 200,
            h: 200,
        };
        for name in ["cover", "bracket", "cap", "tray"] {
            let part = crate::mesh::from_generated(crate::samples::sample(name).unwrap());
            let mesh = &part.mesh;
            let b = crate::math::Aabb::of_points(&mesh.vertices);
            let t: Vec<f32> = mesh
                .vertices
                .iter()
                .map(|p| (p.z - b.min.z) as f32)
                .collect();
            for camera in [oblique, square_camera()] {
                let camera = Camera {
                    centre: DVec2::new(
                        ((b.min + b.max) * 0.5).dot(camera.right),
                        ((b.min + b.max) * 0.5).dot(camera.up),
                    ),
                    scale: 150.0 / (b.max - b.min).length(),
                    ..camera
                };
                // The facets turned round: the bodies' signed volume is negative, and the
                // facets skipped must be the same (skipping the others would leave the
                // samples of the far side).
                let mut inverted = mesh.clone();
                inverted.triangles.iter_mut().for_each(|tri| tri.swap(1, 2));
                let inverted_topology = crate::mesh::Topology::new(&inverted);
                let at = |l: &Layer, x: usize, y: usize| -> (u64, u8) {
                    let (x, y) = (x.wrapping_sub(l.x0), y.wrapping_sub(l.y0));
                    if x < l.w && y < l.h {
                        (l.sample[y * l.w + x], l.lut[y * l.w + x])
                    } else {
                        (0, 0)
                    }
                };
                let (mut covered, mut differ) = (0, 0);
                for (m, topology) in [(mesh, &part.topology), (&inverted, &inverted_topology)] {
                    let both = whole(m, &t, None, &camera, rect, 2, DVec3::Z);
                    let facing = Facing::of(m, topology);
                    assert!(facing.cull, "{name}");
                    let front = whole(m, &t, Some(&facing), &camera, rect, 2, DVec3::Z);
                    for y in 0..400 {
                        for x in 0..400 {
                            let (a, c) = (at(&both, x, y), at(&front, x, y));
                            covered += usize::from(a.0 != 0);
                            differ += usize::from(a != c);
                        }
                    }
                }
                assert!(covered > 1000, "{name}: {covered}");
                assert!(differ * 1000 <= covered, "{name}: {differ} of {covered}");
            }
        }
        let mut open = crate::samples::sample("cover").unwrap();
        open.triangles.pop();
        let topology = crate::mesh::Topology::new(&open);
        assert!(!Facing::of(&open, &topology).cull);
    }

    /// The colouring sample by sample as it was first written (each sample's outline test
    /// reading its four neighbours' keys): the oracle of [`Samples::colour_row`].
    fn pixels_one_by_one(layer: &Layer, c: &Colours) -> Vec<Rgb> {
        let (w, h) = (layer.w, layer.h);
        let depth = |i: usize| (layer.sample[i] >> 32) as u32;
        let outline = |i: usize, x: usize, y: usize| -> bool {
            let d = key_depth(depth(i));
            let near = |j: usize| {
                let e = depth(j);
                e == 0 || (key_depth(e) - d).abs() > c.crease_mm
            };
            (x > 0 && near(i - 1))
                || (x + 1 < w && near(i + 1))
                || (y > 0 && near(i - w))
                || (y + 1 < h && near(i + w))
        };
        let bg = c.background.map(|v| v as f32);
        let ss = layer.ss as usize;
        let n = (ss * ss) as f32;
        let width = layer.rect.w as usize;
        let mut out = vec![c.background; width * layer.rect.h as usize];
        let (x0, y0) = (layer.x0 / ss, layer.y0 / ss);
        for py in y0..y0 + h / ss {
            for px in 0..w / ss {
                let mut sum = [0.0f32; 3];
                for sy in (py - y0) * ss..(py - y0 + 1) * ss {
                    for sx in px * ss..(px + 1) * ss {
                        let i = sy * w + sx;
                        let colour = if layer.sample[i] == 0 {
                            bg
                        } else {
                            let shade = layer.shade[!(layer.sample[i] as u32) as usize];
                            let base = if shade < 0.0 {
                                c.no_value
                            } else {
                                c.lut[layer.lut[i] as usize]
                            };
                            let k = if outline(i, sx, sy) {
                                OUTLINE_FACTOR
                            } else {
                                shade.abs()
                            };
                            base.map(|v| v * k)
                        };
                        for k in 0..3 {
                            sum[k] += colour[k];
                        }
                    }
                }
                out[py * width + x0 + px] = sum.map(|v| (v / n + 0.5).clamp(0.0, 255.0) as u8);
            }
        }
        out
    }

    /// The panels drawn in bands give the bytes of the whole panel's z-buffer coloured
    /// sample by sample, and the depths it holds where they are asked for: on samples seen
    /// along an axis and obliquely (two panels side by side, as in the picture), a field
    /// missing on some facets, back faces skipped and drawn, creases small and large,
    /// panels inside a larger picture, a panel height that is not a whole number of bands,
    /// and a panel cut by the picture's edge.
    #[test]
    fn drawing_in_bands_gives_the_pixels_and_depths_of_the_whole_panel() {
        let toward = DVec3::new(0.5, -0.45, 0.74).normalize();
        let up = (DVec3::Z - toward * toward.z).normalize();
        let oblique = Camera {
            right: up.cross(toward),
            up,
            toward,
            centre: DVec2::ZERO,
            scale: 4.0,
            origin: DVec2::new(100.0, 100.0),
        };
        let lut: [[f32; 3]; 256] =
            std::array::from_fn(|i| [i as f32, 255.0 - i as f32, (i * 7 % 256) as f32]);
        let rect = |x, y, w, h| PixelRect { x, y, w, h };
        for name in ["cover", "bracket", "tray", "plate"] {
            let part = crate::mesh::from_generated(crate::samples::sample(name).unwrap());
            let mesh = &part.mesh;
            let b = crate::math::Aabb::of_points(&mesh.vertices);
            // A field missing (NaN) on the vertices of the upper tenth.
            let t: Vec<f32> = mesh
                .vertices
                .iter()
                .map(|p| {
                    let f = ((p.z - b.min.z) / (b.max.z - b.min.z)) as f32;
                    if f > 0.9 {
                        f32::NAN
                    } else {
                        f
                    }
                })
                .collect();
            let culled = Facing::of(mesh, &part.topology);
            assert!(culled.cull, "{name}");
            for facing in [Some(&culled), None] {
                for (rects, picture_w, picture_h) in [
                    (vec![rect(0, 0, 200, 200), rect(210, 0, 200, 200)], 410, 200),
                    (
                        vec![rect(13, 7, 190, 171), rect(215, 7, 190, 171)],
                        420,
                        190,
                    ),
                    (vec![rect(40, 30, 200, 200)], 180, 150),
                ] {
                    let cameras: Vec<Camera> = rects
                        .iter()
                        .zip([oblique, square_camera()])
                        .map(|(r, camera)| Camera {
                            centre: DVec2::new(
                                ((b.min + b.max) * 0.5).dot(camera.right),
                                ((b.min + b.max) * 0.5).dot(camera.up),
                            ),
                            scale: 120.0 / (b.max - b.min).length(),
                            origin: DVec2::new(r.x as f64 + 95.0, r.y as f64 + 90.0),
                            ..camera
                        })
                        .collect();
                    let light = DVec3::new(0.3, -0.5, 0.8).normalize();
                    let layers: Vec<Layer> = cameras
                        .iter()
                        .zip(&rects)
                        .map(|(camera, &r)| whole(mesh, &t, facing, camera, r, 2, light))
                        .collect();
                    for crease_mm in [0.0, 0.05, 1.0] {
                        let colours = || Colours {
                            lut: &lut,
                            no_value: [165.0, 160.0, 150.0],
                            background: [244, 245, 248],
                            crease_mm,
                        };
                        // Every sample of every third row asked for, once.
                        let asked = |r: PixelRect| {
                            (0..2 * r.h)
                                .step_by(if crease_mm == 0.0 { 3 } else { 61 })
                                .flat_map(move |sy| {
                                    (0..2 * r.w).map(move |sx| {
                                        (
                                            r.x as f64 + (sx as f64 + 0.5) / 2.0,
                                            r.y as f64 + (sy as f64 + 0.5) / 2.0,
                                        )
                                    })
                                })
                        };
                        let mut panels: Vec<Panel> = cameras
                            .iter()
                            .zip(&rects)
                            .map(|(&camera, &r)| {
                                let mut depths = Depths::new(r, 2);
                                asked(r).for_each(|(x, y)| depths.ask(x, y));
                                Panel {
                                    camera,
                                    rect: r,
                                    light,
                                    colours: colours(),
                                    depths,
                                }
                            })
                            .collect();
                        let mut rgba = vec![7u8; 4 * picture_w * picture_h];
                        draw(mesh, &t, facing, &mut panels, 2, &mut rgba, picture_w);
                        let expected: Vec<Vec<Rgb>> = layers
                            .iter()
                            .map(|l| pixels_one_by_one(l, &colours()))
                            .collect();
                        let mut painted = 0;
                        for y in 0..picture_h {
                            for x in 0..picture_w {
                                let got = &rgba[4 * (y * picture_w + x)..][..4];
                                let within = rects.iter().position(|r| {
                                    (r.x as usize..(r.x + r.w) as usize).contains(&x)
                                        && (r.y as usize..(r.y + r.h) as usize).contains(&y)
                                });
                                let Some(k) = within else {
                                    assert_eq!(got, [7; 4], "{name} ({x}, {y}) is outside");
                                    continue;
                                };
                                let r = rects[k];
                                let (px, py) = (x - r.x as usize, y - r.y as usize);
                                let e = expected[k][py * r.w as usize + px];
                                assert_eq!(got, [e[0], e[1], e[2], 255], "{name} ({x}, {y})");
                                painted += usize::from(e != colours().background);
                            }
                        }
                        assert!(painted > 1000, "{name}: {painted}");
                        let mut found = 0;
                        for (panel, layer) in panels.iter().zip(&layers) {
                            for (x, y) in asked(panel.rect).filter(|&(_, y)| y < picture_h as f64) {
                                let d = panel.depths.depth_at(x, y);
                                assert_eq!(d, layer.depth_at(x, y), "{name} ({x}, {y})");
                                found += usize::from(d.is_some());
                            }
                        }
                        assert!(found > 100, "{name}: {found}");
                    }
                }
            }
        }
    }

    /// Sample by sample, as the rows were drawn before their masks: the oracle of
    /// [`Setup::draw_rows`].
    fn draw_rows_stepping(
        setup: &Setup,
        (facet, shade): (u32, f32),
        rows: std::ops::Range<usize>,
        buffer: &mut Buffer,
        (x0, w, first_row): (usize, usize, usize),
    ) {
        let (a, b, c, inv) = (setup.a, setup.b, setup.c, setup.inv);
        let [ta, tb, tc] = setup.t;
        let has_value = !(ta.is_nan() || tb.is_nan() || tc.is_nan());
        let facet = !facet as u64;
        let (dwa, dwb) = (-(c[1] - b[1]) * inv, -(a[1] - c[1]) * inv);
        let first = setup.min_x as usize - x0;
        let end = setup.max_x as usize + 1 - x0;
        for y in rows {
            let (py, px) = (y as f32 + 0.5, setup.min_x + 0.5);
            let mut wa = ((c[0] - b[0]) * (py - b[1]) - (c[1] - b[1]) * (px - b[0])) * inv;
            let mut wb = ((a[0] - c[0]) * (py - c[1]) - (a[1] - c[1]) * (px - c[0])) * inv;
            let mut entered = false;
            for k in first..end {
                if wa >= -EDGE_SLACK && wb >= -EDGE_SLACK && wa + wb <= 1.0 + EDGE_SLACK {
                    entered = true;
                    let z = depth_key(c[2] + wa * (a[2] - c[2]) + wb * (b[2] - c[2]));
                    let sample = (z as u64) << 32 | facet;
                    let i = (y - first_row) * w + k;
                    if sample > buffer.sample[i] {
                        buffer.sample[i] = sample;
                        buffer.shade[i] = shade;
                        if has_value {
                            buffer.lut[i] = lut_index(tc + wa * (ta - tc) + wb * (tb - tc));
                        }
                    }
                } else if entered {
                    break;
                }
                wa += dwa;
                wb += dwb;
            }
        }
    }

    /// Random triangles (small ones, slivers a sample wide, rows longer than
    /// [`MASKED_ROW`], a field missing at a corner) drawn over samples already drawn: the
    /// rows drawn through masks hold the samples, entries and factors of the stepping
    /// sample by sample, also for rows drawn in parts.
    #[test]
    fn rows_drawn_through_masks_match_stepping_sample_by_sample() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut random = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (w, h) = (160usize, 48usize);
        let (x0, y0) = (4usize, 6usize);
        let mut drawn = 0;
        for round in 0..3000 {
            // Rows stepped four at a time (up to 16 samples), through a mask (up to 64),
            // and sample by sample.
            let size: f32 = [3.0, 12.0, 15.0, 17.0, 40.0, 150.0][round % 6];
            let mut corner = || {
                [
                    x0 as f32 + 5.0 + random() * size,
                    y0 as f32 + 2.0 + random() * size.min(40.0),
                    random() * 10.0 - 5.0,
                ]
            };
            let (a, mut b, c) = (corner(), corner(), corner());
            if round % 7 == 0 {
                // A sliver: the second corner a hair off the first edge.
                b = [(a[0] + c[0]) * 0.5 + 1e-3, (a[1] + c[1]) * 0.5 - 2e-3, b[2]];
            }
            let p = Projection {
                rect: PixelRect {
                    x: 0,
                    y: 0,
                    w: 100,
                    h: 40,
                },
                ss: 2,
                vertex: vec![a, b, c],
                x0,
                y0,
                w,
                h,
            };
            let t = [
                random(),
                if round % 11 == 0 { f32::NAN } else { random() },
                random(),
            ];
            let Some(setup) = p.setup([0, 1, 2], &t) else {
                continue;
            };
            let initial = Buffer {
                sample: (0..w * h)
                    .map(|_| {
                        let z = random() * 10.0 - 5.0;
                        if random() < 0.4 {
                            0
                        } else {
                            (depth_key(z) as u64) << 32 | 7
                        }
                    })
                    .collect(),
                lut: (0..w * h).map(|_| (random() * 255.0) as u8).collect(),
                shade: (0..w * h).map(|_| random()).collect(),
            };
            let copy = || Buffer {
                sample: initial.sample.clone(),
                lut: initial.lut.clone(),
                shade: initial.shade.clone(),
            };
            let (lo, hi) = setup.rows;
            // The whole triangle (the first part empty), then its rows in two parts (as two
            // bands draw them).
            for split in [lo, lo + (hi - lo) / 2] {
                let (mut got, mut expected) = (copy(), copy());
                let mut steps = Steps::default();
                for rows in [lo..split, split..hi + 1] {
                    let place = (x0, w, y0);
                    setup.draw_rows((5, 0.75), rows.clone(), &mut got, place, &mut steps);
                    draw_rows_stepping(&setup, (5, 0.75), rows, &mut expected, place);
                }
                assert_eq!(got.sample, expected.sample, "round {round}");
                assert_eq!(got.lut, expected.lut, "round {round}");
                assert_eq!(got.shade, expected.shade, "round {round}");
                drawn += usize::from(got.sample != initial.sample);
            }
        }
        assert!(drawn > 3000, "{drawn}");
    }

    #[test]
    fn the_rounding_helpers_match_the_library() {
        let mut x = -300.0f32;
        while x < 300.0 {
            assert_eq!(floor(x), x.floor(), "{x}");
            assert_eq!(ceil(x), x.ceil(), "{x}");
            if x >= 0.0 {
                assert_eq!(round_non_negative(x), x.round(), "{x}");
            }
            x += 0.0625 + 1e-3;
        }
        for x in [0.0f32, 0.5, 1.5, 2.5, 254.5, 0.49999997, 127.49999, 255.0] {
            assert_eq!(round_non_negative(x), x.round(), "{x}");
        }
        for t in [0.0f32, 0.001, 0.5, 0.998, 1.0, 1.2, -0.3] {
            assert_eq!(lut_index(t) as f32, (t.clamp(0.0, 1.0) * 255.0).round());
        }
    }

    #[test]
    fn camera_maps_right_and_up_to_screen_right_and_up() {
        let c = square_camera();
        assert_eq!(c.to_pixel(DVec3::ZERO), DVec2::new(50.0, 50.0));
        assert_eq!(c.to_pixel(DVec3::X), DVec2::new(60.0, 50.0));
        assert_eq!(c.to_pixel(DVec3::Y), DVec2::new(50.0, 40.0));
        assert_eq!(c.depth(DVec3::new(1.0, 2.0, 3.0)), 3.0);
    }

    /// Two overlapping squares at different heights: the nearer one wins wherever they
    /// overlap, whatever the drawing order, and the covered area matches the closed form.
    #[test]
    fn depth_test_keeps_the_nearer_surface_and_area_is_exact() {
        let mut mesh = Mesh {
            vertices: vec![],
            triangles: vec![],
        };
        let mut square = |x0: f64, y0: f64, size: f64, z: f64| {
            let b = mesh.vertices.len() as u32;
            for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                mesh.vertices
                    .push(DVec3::new(x0 + x * size, y0 + y * size, z));
            }
            mesh.triangles.push([b, b + 1, b + 2]);
            mesh.triangles.push([b, b + 2, b + 3]);
        };
        square(-3.0, -3.0, 4.0, 1.0); // lower, drawn first
        square(-1.0, -1.0, 4.0, 2.0); // higher
        let t: Vec<f32> = mesh
            .vertices
            .iter()
            .map(|p| if p.z > 1.5 { 1.0 } else { 0.0 })
            .collect();
        let rect = PixelRect {
            x: 0,
            y: 0,
            w: 100,
            h: 100,
        };
        let lut = [[0.0f32; 3]; 256];
        let mut depths = Depths::new(rect, 2);
        let centres = (0..200).flat_map(|sy| {
            (0..200).map(move |sx| ((sx as f64 + 0.5) / 2.0, (sy as f64 + 0.5) / 2.0))
        });
        centres.clone().for_each(|(x, y)| depths.ask(x, y));
        let mut panels = [Panel {
            camera: square_camera(),
            rect,
            light: DVec3::Z,
            colours: Colours {
                lut: &lut,
                no_value: [0.0; 3],
                background: [255; 3],
                crease_mm: 0.1,
            },
            depths,
        }];
        let mut rgba = vec![0u8; 4 * 100 * 100];
        draw(&mesh, &t, None, &mut panels, 2, &mut rgba, 100);
        let depths = &panels[0].depths;
        let found: Vec<f32> = centres.filter_map(|(x, y)| depths.depth_at(x, y)).collect();
        // Union of two 40x40-pixel squares overlapping by 20x20, at 2x2 samples per pixel.
        assert_eq!(found.len(), 4 * (1600 + 1600 - 400));
        assert_eq!(found.iter().filter(|&&d| d == 2.0).count(), 4 * 1600);
        // In the overlap the value is the higher square's.
        assert_eq!(depths.depth_at(55.0, 45.0), Some(2.0));
        assert_eq!(depths.depth_at(25.0, 75.0), Some(1.0));
        assert_eq!(depths.depth_at(95.0, 95.0), None);
        assert!(depths.visible(55.0, 45.0, 2.0, 0.0));
        assert!(!depths.visible(55.0, 45.0, 1.5, 0.1));
        // A point of the lower square at the higher one's edge: the sample under it is the
        // higher face's, the pixel beside it the lower's, where the point shows.
        assert_eq!(depths.depth_at(40.2, 45.0), Some(2.0));
        assert_eq!(depths.depth_at(39.2, 45.0), Some(1.0));
        assert!(!depths.visible(40.2, 45.0, 1.0, 0.1));
        assert!(depths.visible_around(40.2, 45.0, 1.0, 0.1));
        // Under the higher face a pixel and more from its edge, it stays hidden.
        assert!(!depths.visible_around(55.0, 45.0, 1.0, 0.1));
    }
}
