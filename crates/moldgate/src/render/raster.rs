//! The z-buffer: orthographic cameras and triangles drawn with a depth test, per-vertex field
//! values interpolated across each triangle and Lambert shading per facet.

use crate::math::{DVec2, DVec3};
use crate::mesh::{Mesh, Topology};

use super::canvas::Rgb;

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

/// What the z-buffer holds for one panel, at `ss` samples per pixel along each axis.
///
/// A sample is 9 bytes in two arrays that start as zeros, and a zero sample means "no part
/// here": the arrays are allocated zeroed (fresh pages from the system, which it zeroes
/// only when they are first written) rather than filled, so the background costs neither
/// a fill pass nor its pages. The arrays cover only the box of samples the part's vertices
/// project into, grown by one sample and out to whole pixels (clamped to the panel): every
/// sample outside it is empty, and a part that fills a third of its panel then zeroes and
/// colours a third of the samples.
pub struct Layer {
    pub rect: PixelRect,
    pub ss: u32,
    /// The box's first column and row of samples in the panel (multiples of `ss`).
    x0: usize,
    y0: usize,
    /// The box's width and height in samples (multiples of `ss`).
    w: usize,
    h: usize,
    /// The nearest surface: its depth as an order-keeping key ([`depth_key`]) in the high
    /// 32 bits, the complement of its facet's index in the low 32 (so that of two facets at
    /// the same depth the first drawn is the larger sample and stays), 0 where the part is
    /// absent. One compare of one word is the depth test.
    sample: Vec<u64>,
    /// Colour-map entry 0..=255 of the field value there.
    lut: Vec<u8>,
    /// Lambert factor per facet, negated when the facet has no field value (drawn grey).
    shade: Vec<f32>,
}

/// The mesh as the views draw it, built once for both: the triangles in the mesh's order,
/// each with its unit normal, and the vertices renumbered in the order the triangles first
/// use them, so that consecutive triangles read neighbouring entries of the projected
/// vertices. (Drawing the triangles in a spatial order instead, Morton order of the
/// centroids, was slower on the 352k-triangle housing: its front and back faces then
/// alternate and the depth test's outcome with them.)
pub struct DrawOrder {
    /// The mesh index of each triangle drawn, in drawing order.
    place: Vec<u32>,
    /// Each triangle's corners, as indices into `positions`.
    corners: Vec<[u32; 3]>,
    /// Vertex positions in first-use order.
    positions: Vec<DVec3>,
    /// The colour-map coordinate of each of them.
    t: Vec<f32>,
    /// Whether the facets whose normal points away from the viewer are skipped (set by
    /// [`DrawOrder::cull_back_faces`]).
    cull: bool,
    /// Whether the facets of every body face into it (all turned round for the test).
    all_inward: bool,
    /// Per triangle drawn, whether its body's facets face into it; empty when no body's
    /// do, or when all do.
    inward: Vec<bool>,
}

/// Unit normal of the triangle (a, b, c) by its corner order, zero when degenerate.
/// Computed where it is used rather than kept: a stored normal per triangle is 8 MB of
/// fresh pages on the 352k-triangle part, which the system zeroes at a cost larger than the
/// arithmetic.
#[inline]
fn unit_normal(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    (b - a).cross(c - a).normalize_or_zero()
}

impl DrawOrder {
    /// The drawing order of `mesh`, with `t`, the colour-map coordinate per vertex.
    pub fn new(mesh: &Mesh, t: &[f32]) -> DrawOrder {
        use rayon::prelude::*;
        let place = morton_order(mesh);
        let mut new_index = vec![u32::MAX; mesh.vertices.len()];
        let mut first_use: Vec<u32> = Vec::with_capacity(mesh.vertices.len());
        // The triangles gathered in drawing order on all threads (scattered reads), then
        // their corners renumbered in place in one pass.
        let mut corners: Vec<[u32; 3]> = place
            .par_iter()
            .map(|&k| mesh.triangles[k as usize])
            .collect();
        for tri in &mut corners {
            for v in tri.iter_mut() {
                let slot = &mut new_index[*v as usize];
                if *slot == u32::MAX {
                    *slot = first_use.len() as u32;
                    first_use.push(*v);
                }
                *v = *slot;
            }
        }
        let positions: Vec<DVec3> = first_use
            .iter()
            .map(|&v| mesh.vertices[v as usize])
            .collect();
        let t = first_use.iter().map(|&v| t[v as usize]).collect();
        DrawOrder {
            place,
            corners,
            positions,
            t,
            cull: false,
            all_inward: false,
            inward: Vec::new(),
        }
    }

    /// Skips, in every view, the facets turned away from the viewer, as [`Facing::of`]
    /// finds them; returns whether it does.
    #[cfg(test)]
    pub fn cull_back_faces(&mut self, mesh: &Mesh, topology: &Topology) -> bool {
        self.set_facing(Facing::of(mesh, topology))
    }

    /// Skips the facets `facing` (of the same mesh, found beside this order) says; returns
    /// whether it skips any.
    pub fn set_facing(&mut self, facing: Facing) -> bool {
        self.cull = facing.cull;
        self.all_inward = facing.all_inward;
        self.inward = if facing.inward.is_empty() {
            Vec::new()
        } else {
            self.place
                .iter()
                .map(|&k| facing.inward[k as usize])
                .collect()
        };
        self.cull
    }
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

/// The triangles of `mesh` in Morton order of the cells of their centroids in a 32^3
/// lattice over the part's box, by index within a cell (a counting sort: one pass to count,
/// one to file). Consecutive triangles then lie close together, and so do the samples they
/// cover in either view: the depth test reads samples the cache holds. The order does not
/// change the picture, as a sample keeps the nearest facet and, at one depth, the one first
/// in the mesh, whatever the order they come in.
fn morton_order(mesh: &Mesh) -> Vec<u32> {
    use rayon::prelude::*;
    const BITS: u32 = 5;
    let b = crate::math::Aabb::of_points(&mesh.vertices);
    let extent = (b.max - b.min).max_element().max(1e-300);
    let spread = |v: u32| -> usize {
        (0..BITS).fold(0, |code, bit| {
            code | (((v >> bit) & 1) as usize) << (3 * bit)
        })
    };
    let top = ((1u32 << BITS) - 1) as f64;
    let scale = top / extent;
    let cell: Vec<u16> = mesh
        .triangles
        .par_iter()
        .map(|tri| {
            let c = tri.iter().fold(crate::math::DVec3::ZERO, |s, &v| {
                s + mesh.vertices[v as usize]
            }) / 3.0;
            let q = ((c - b.min) * scale)
                .clamp(crate::math::DVec3::ZERO, crate::math::DVec3::splat(top));
            (spread(q.x as u32) | spread(q.y as u32) << 1 | spread(q.z as u32) << 2) as u16
        })
        .collect();
    let mut start = vec![0u32; 1 << (3 * BITS)];
    for &c in &cell {
        start[c as usize] += 1;
    }
    let mut sum = 0;
    for s in &mut start {
        (*s, sum) = (sum, sum + *s);
    }
    let mut place = vec![0u32; cell.len()];
    for (k, &c) in cell.iter().enumerate() {
        let slot = &mut start[c as usize];
        place[*slot as usize] = k as u32;
        *slot += 1;
    }
    place
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
    let bits = (z + 0.0).to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | 0x8000_0000
    }
}

/// The depth of a key of [`depth_key`].
#[inline]
fn key_depth(key: u32) -> f32 {
    f32::from_bits(if key >> 31 == 1 {
        key & 0x7fff_ffff
    } else {
        !key
    })
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

/// Draws the mesh, as `order` lists it, into a z-buffer covering `rect` of the canvas;
/// `light` is the unit direction towards the light. Where two triangles give a sample the same depth, the one listed first in the
/// mesh keeps it, so the picture does not depend on the drawing order.
pub fn rasterise(
    order: &DrawOrder,
    camera: &Camera,
    rect: PixelRect,
    ss: u32,
    light: DVec3,
) -> Layer {
    let (panel_w, panel_h) = ((rect.w * ss) as usize, (rect.h * ss) as usize);
    let s = ss as f64;
    // Vertices in sample coordinates (pixel centres at +0.5) and depth.
    let projected: Vec<[f32; 3]> = order
        .positions
        .iter()
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
    // vertices. It is grown by one sample so that no sample drawn lies on its edge (except
    // at the panel's edge), which keeps the outline test at its edges the panel's, and out
    // to whole pixels so that a pixel's samples are all in it or all outside.
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for p in &projected {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
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
    let mut layer = Layer {
        rect,
        ss,
        x0,
        y0,
        w,
        h,
        sample: vec![0; w * h],
        lut: vec![0; w * h],
        shade: vec![0.0; order.corners.len()],
    };
    // The triangles' columns and rows clamped to the box, which only cuts what the panel
    // would: the same samples as clamping to the panel.
    let (first_x, last_x) = (x0 as f32, (x0 + w) as f32 - 1.0);
    let (first_y, last_y) = (y0 as f32, (y0 + h) as f32 - 1.0);
    let t = &order.t;
    let cull = order.cull;
    for (drawn, (&place, corners)) in order.place.iter().zip(&order.corners).enumerate() {
        let place = place as usize;
        let [ia, ib, ic] = corners.map(|i| i as usize);
        let n = unit_normal(
            order.positions[ia],
            order.positions[ib],
            order.positions[ic],
        );
        if cull {
            let towards = n.dot(camera.toward);
            let inward = order.all_inward || order.inward.get(drawn).copied().unwrap_or(false);
            // A back face of a closed body: a front face is nearer wherever it is.
            if (if inward { -towards } else { towards }) < 0.0 {
                continue;
            }
        }
        let (a, b, c) = (projected[ia], projected[ib], projected[ic]);
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area.abs() < 1e-12 || !area.is_finite() {
            continue; // seen edge-on, or degenerate
        }
        let min_x = floor(a[0].min(b[0]).min(c[0])).max(first_x);
        let max_x = ceil(a[0].max(b[0]).max(c[0])).min(last_x);
        let min_y = floor(a[1].min(b[1]).min(c[1])).max(first_y);
        let max_y = ceil(a[1].max(b[1]).max(c[1])).min(last_y);
        if min_x > max_x || min_y > max_y {
            continue;
        }
        // Lambert: the facet normal against the light, both sides lit (meshes are not
        // always consistently oriented).
        let shade = (AMBIENT + DIFFUSE * n.dot(light).abs()) as f32;
        let inv = 1.0 / area;
        let (ta, tb, tc) = (t[ia], t[ib], t[ic]);
        // A value missing at one corner is missing over the whole facet (it would be NaN
        // at every sample): the facet is drawn grey.
        let has_value = !(ta.is_nan() || tb.is_nan() || tc.is_nan());
        layer.shade[place] = if has_value { shade } else { -shade };
        let facet = !(place as u32) as u64;
        // Barycentric weights from edge functions, normalised by the signed area so either
        // winding works; stepped along each row.
        let dwa = -(c[1] - b[1]) * inv;
        let dwb = -(a[1] - c[1]) * inv;
        let (dz_a, dz_b) = (a[2] - c[2], b[2] - c[2]);
        let (dt_a, dt_b) = (ta - tc, tb - tc);
        // The box's columns of the triangle's samples, the same in every row.
        let (first, end) = (min_x as usize - x0, max_x as usize + 1 - x0);
        for y in min_y as usize..max_y as usize + 1 {
            let py = y as f32 + 0.5;
            let px = min_x + 0.5;
            let mut wa = ((c[0] - b[0]) * (py - b[1]) - (c[1] - b[1]) * (px - b[0])) * inv;
            let mut wb = ((a[0] - c[0]) * (py - c[1]) - (a[1] - c[1]) * (px - c[0])) * inv;
            let row = (y - y0) * w;
            let samples = &mut layer.sample[row + first..row + end];
            let luts = &mut layer.lut[row + first..row + end];
            // A sliver of overlap rather than a crack where two triangles meet: samples on a
            // shared edge would otherwise be missed by both when rounding goes against them
            // (the depth test settles the overlap).
            let inside = |wa: f32, wb: f32| {
                wa >= -EDGE_SLACK && wb >= -EDGE_SLACK && wa + wb <= 1.0 + EDGE_SLACK
            };
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
    layer
}

/// Tolerance of the inside test, in barycentric units.
const EDGE_SLACK: f32 = 1e-4;

/// Light kept on faces turned away from the light.
const AMBIENT: f64 = 0.32;
/// Light added on faces turned to it.
const DIFFUSE: f64 = 0.68;

impl Layer {
    /// Depth at canvas position (x, y) pixels: the sample under it, `None` off the part.
    pub fn depth_at(&self, x: f64, y: f64) -> Option<f32> {
        let sx = ((x - self.rect.x as f64) * self.ss as f64).floor() - self.x0 as f64;
        let sy = ((y - self.rect.y as f64) * self.ss as f64).floor() - self.y0 as f64;
        if sx < 0.0 || sy < 0.0 || sx >= self.w as f64 || sy >= self.h as f64 {
            return None; // off the panel, or in it outside the part's box: no sample there
        }
        let key = (self.sample[sy as usize * self.w + sx as usize] >> 32) as u32;
        (key != 0).then(|| key_depth(key))
    }

    /// Whether a point at canvas (x, y) with depth `depth` is in front of, or within
    /// `tolerance` mm of, the surface drawn there.
    pub fn visible(&self, x: f64, y: f64, depth: f64, tolerance: f64) -> bool {
        match self.depth_at(x, y) {
            Some(d) => depth + tolerance >= d as f64,
            None => true,
        }
    }

    /// Colours the panel into `rgba`, the bytes of an opaque RGBA picture `stride` pixels
    /// wide, at the panel's place in it (what lies beyond the picture is left out): each
    /// sample coloured (its `lut` entry times its facet's shade, `no_value` for a facet
    /// without a field value; [`OUTLINE_FACTOR`] instead of the shade on an outline, where
    /// the depth jumps by more than `crease_mm` to a neighbour or the part ends there) over
    /// `background`, and the samples of each pixel averaged. Bands of rows in parallel.
    ///
    /// Each band turns the depth keys of its rows of samples (and one row above and below)
    /// into depths once, a row of depths padded at both ends with its end values and an
    /// absent neighbour row standing in for itself, so that a missing neighbour is never
    /// a jump; an empty sample's depth is NaN, which is a jump from any depth. The colour
    /// of a sample and the sums of a pixel are computed as they always were, in the same
    /// order, so the bytes do not change (a unit test holds them to the sample-by-sample
    /// colouring).
    pub fn paint(&self, rgba: &mut [u8], stride: usize, colours: &Colours) {
        use rayon::prelude::*;
        let rect = self.rect;
        let (left, top) = (rect.x as usize, rect.y as usize);
        let rows_in_picture = rgba.len() / (4 * stride).max(1);
        if stride == 0 || left >= stride || top >= rows_in_picture {
            return;
        }
        let columns = (rect.w as usize).min(stride - left);
        let rows = (rect.h as usize).min(rows_in_picture - top);
        let ss = self.ss as usize;
        // The part's box in pixels of the panel; every pixel outside it is the background
        // (the mean of equal whole numbers is exact).
        let (bx0, by0) = ((self.x0 / ss).min(columns), self.y0 / ss);
        let (bx1, by1) = ((self.x0 / ss + self.w / ss).min(columns), by0 + self.h / ss);
        let bg = colours.background;
        let bg_rgba = [bg[0], bg[1], bg[2], 255];
        let region = &mut rgba[4 * stride * top..4 * stride * (top + rows)];
        region
            .par_chunks_mut(4 * stride * PAINT_BAND)
            .enumerate()
            .for_each(|(band, chunk)| {
                let first = band * PAINT_BAND;
                let count = chunk.len() / (4 * stride);
                // The band's rows inside the box, in pixels of the panel.
                let (inside0, inside1) = (first.max(by0), (first + count).min(by1));
                let depths = (inside0 < inside1)
                    .then(|| self.depth_rows((inside0 - by0) * ss, (inside1 - by0) * ss));
                let mut scratch = (Vec::new(), Vec::new());
                for (r, row) in chunk.chunks_exact_mut(4 * stride).enumerate() {
                    let py = first + r;
                    let out = &mut row[4 * left..4 * (left + columns)];
                    let Some(depths) = depths.as_ref().filter(|_| py >= by0 && py < by1) else {
                        out.chunks_exact_mut(4)
                            .for_each(|p| p.copy_from_slice(&bg_rgba));
                        continue;
                    };
                    let (before, rest) = out.split_at_mut(4 * bx0);
                    let (part, after) = rest.split_at_mut(4 * (bx1 - bx0));
                    for p in before.chunks_exact_mut(4).chain(after.chunks_exact_mut(4)) {
                        p.copy_from_slice(&bg_rgba);
                    }
                    let s0 = (py - by0) * ss; // the pixel's first row of samples in the box
                    let d0 = (py - inside0) * ss + 1; // and its row in `depths`
                    self.colour_row(depths, (s0, d0), part, colours, &mut scratch);
                }
            });
    }

    /// The depths of the box's rows of samples `s0..s1`, with the row above and the row
    /// below (the first or last row itself at the box's edge), each padded at both ends
    /// with its end values: `(s1 - s0 + 2)` rows of `w + 2`. Empty samples are NaN.
    fn depth_rows(&self, s0: usize, s1: usize) -> Vec<f32> {
        let w = self.w;
        let mut out = Vec::with_capacity((s1 - s0 + 2) * (w + 2));
        let above = s0.saturating_sub(1);
        let below = if s1 < self.h { s1 } else { s1 - 1 };
        for s in std::iter::once(above)
            .chain(s0..s1)
            .chain(std::iter::once(below))
        {
            let keys = &self.sample[s * w..(s + 1) * w];
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
        out
    }

    /// Colours the pixels of one row of the box into `out` (RGBA): the pixel's first row of
    /// samples `s0` in the box and `d0` in `depths` (from [`Layer::depth_rows`]); `scratch`
    /// holds a row of outline marks and the colours of the pixel's rows of samples.
    fn colour_row(
        &self,
        depths: &[f32],
        (s0, d0): (usize, usize),
        out: &mut [u8],
        c: &Colours,
        scratch: &mut (Vec<bool>, Vec<[f32; 3]>),
    ) {
        let (w, ss) = (self.w, self.ss as usize);
        let pw = w + 2;
        let (outline, colours) = scratch;
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
            let samples = &self.sample[(s0 + dy) * w..(s0 + dy + 1) * w];
            let luts = &self.lut[(s0 + dy) * w..(s0 + dy + 1) * w];
            let colours = &mut colours[dy * w..(dy + 1) * w];
            for (((colour, &sample), &lut), &mark) in colours
                .iter_mut()
                .zip(samples)
                .zip(luts)
                .zip(outline.iter())
            {
                *colour = if sample == 0 {
                    bg
                } else {
                    let shade = self.shade[!(sample as u32) as usize];
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

/// How a panel's samples are coloured ([`Layer::paint`]).
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

/// Rows of pixels coloured by one task of [`Layer::paint`].
const PAINT_BAND: usize = 8;

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
                    let both = rasterise(&DrawOrder::new(m, &t), &camera, rect, 2, DVec3::Z);
                    let mut order = DrawOrder::new(m, &t);
                    assert!(order.cull_back_faces(m, topology), "{name}");
                    let front = rasterise(&order, &camera, rect, 2, DVec3::Z);
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
        let t = vec![0.0; open.vertices.len()];
        assert!(!DrawOrder::new(&open, &t).cull_back_faces(&open, &topology));
    }

    /// The colouring sample by sample as it was first written (each sample's outline test
    /// reading its four neighbours' keys): the oracle of [`Layer::paint`].
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

    /// The banded colouring gives the bytes of the sample-by-sample one, on samples seen
    /// along an axis and obliquely, with a field missing on some facets, with creases
    /// small and large, a panel placed inside a larger picture, and a panel cut by the
    /// picture's edge.
    #[test]
    fn painting_in_bands_gives_the_colours_of_each_sample() {
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
            let mut order = DrawOrder::new(mesh, &t);
            order.cull_back_faces(mesh, &part.topology);
            for camera in [oblique, square_camera()] {
                let camera = Camera {
                    centre: DVec2::new(
                        ((b.min + b.max) * 0.5).dot(camera.right),
                        ((b.min + b.max) * 0.5).dot(camera.up),
                    ),
                    scale: 120.0 / (b.max - b.min).length(),
                    ..camera
                };
                for (rect, picture_w, picture_h) in [
                    (
                        PixelRect {
                            x: 0,
                            y: 0,
                            w: 200,
                            h: 200,
                        },
                        200,
                        200,
                    ),
                    (
                        PixelRect {
                            x: 13,
                            y: 7,
                            w: 190,
                            h: 171,
                        },
                        230,
                        190,
                    ),
                    (
                        PixelRect {
                            x: 40,
                            y: 30,
                            w: 200,
                            h: 200,
                        },
                        180,
                        150,
                    ),
                ] {
                    let camera = Camera {
                        origin: DVec2::new(rect.x as f64 + 95.0, rect.y as f64 + 90.0),
                        ..camera
                    };
                    let layer = rasterise(&order, &camera, rect, 2, DVec3::Z);
                    for crease_mm in [0.0, 0.05, 1.0] {
                        let colours = Colours {
                            lut: &lut,
                            no_value: [165.0, 160.0, 150.0],
                            background: [244, 245, 248],
                            crease_mm,
                        };
                        let mut rgba = vec![7u8; 4 * picture_w * picture_h];
                        layer.paint(&mut rgba, picture_w, &colours);
                        let expected = pixels_one_by_one(&layer, &colours);
                        let mut painted = 0;
                        for y in 0..picture_h {
                            for x in 0..picture_w {
                                let got = &rgba[4 * (y * picture_w + x)..][..4];
                                let (px, py) = (
                                    x.wrapping_sub(rect.x as usize),
                                    y.wrapping_sub(rect.y as usize),
                                );
                                if px < rect.w as usize && py < rect.h as usize {
                                    let e = expected[py * rect.w as usize + px];
                                    assert_eq!(got, [e[0], e[1], e[2], 255], "{name} ({x}, {y})");
                                    painted += usize::from(e != colours.background);
                                } else {
                                    assert_eq!(
                                        got, [7; 4],
                                        "{name} ({x}, {y}) is outside the panel"
                                    );
                                }
                            }
                        }
                        assert!(painted > 1000, "{name}: {painted}");
                    }
                }
            }
        }
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
        let order = DrawOrder::new(&mesh, &t);
        let layer = rasterise(&order, &square_camera(), rect, 2, DVec3::Z);
        let covered = layer.sample.iter().filter(|&&s| s != 0).count();
        // Union of two 40x40-pixel squares overlapping by 20x20, at 2x2 samples per pixel.
        assert_eq!(covered, 4 * (1600 + 1600 - 400));
        let high = layer
            .sample
            .iter()
            .filter(|&&s| (s >> 32) as u32 == depth_key(2.0))
            .count();
        assert_eq!(high, 4 * 1600);
        // In the overlap the value is the higher square's.
        assert_eq!(layer.depth_at(55.0, 45.0), Some(2.0));
        assert_eq!(layer.depth_at(25.0, 75.0), Some(1.0));
        assert_eq!(layer.depth_at(95.0, 95.0), None);
        assert!(layer.visible(55.0, 45.0, 2.0, 0.0));
        assert!(!layer.visible(55.0, 45.0, 1.5, 0.1));
    }
}
