//! Pictures of an analysis without a GPU: a PNG with two views of the part, coloured by the
//! scene's field, with the gate, the centre of mass, the parting line and the qualifying
//! region drawn over it, a colour bar, scale bars, orientation axes and a title.
//!
//! The part is drawn by our own z-buffer (`raster.rs`) at 2x2 samples per pixel; overlays
//! are tiny-skia's, text is fontdue's with a DejaVu Sans subset shipped in `fonts/` (each
//! glyph rasterised once a picture), and the PNG is deflated at level 1 in bands of rows on
//! all threads (`encode.rs`). The two views are drawn and coloured into the canvas together,
//! band of rows by band of rows on all threads, without a z-buffer of a whole view; the depths
//! the overlays look up (to tell hidden from visible) are asked for before and answered by the
//! bands. Then the overlays of each view are drawn, in a fixed order, so the same scene gives
//! the same bytes on any number of threads. The parting line is stroked as one
//! path per style, its pieces joined and its points thinned to within
//! [`PARTING_TOLERANCE_PX`] of the line (docs/performance.md, "Pictures").
//!
//! ```
//! use moldgate::render::{png, RenderOptions};
//! use moldgate::scene::Scene;
//!
//! let part = moldgate::mesh::from_generated(moldgate::samples::sample("cover").unwrap());
//! let analysis = moldgate::locate(&part, &moldgate::LocateOptions::default()).unwrap();
//! let scene = Scene::new(&part.mesh, &analysis, "cover");
//! let bytes = png(&scene, &RenderOptions::default()).unwrap();
//! assert_eq!(&bytes[1..4], b"PNG");
//! ```

mod canvas;
mod encode;
mod keepout;
mod placed;
mod pool;
mod raster;

use crate::math::{DVec2, DVec3};
use crate::scene::Scene;

use canvas::{wrap, Align, Canvas, Rgb, TextStyle};
pub use placed::PLACED_COLOUR;
use raster::{draw_projected, Colours, Depths, Facing, Panel, Projection};
pub use raster::{Camera, PixelRect};

/// Size of the picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderOptions {
    /// Width in pixels (default 1600; at least [`MIN_SIZE`]`.0`, at most [`MAX_SIDE`]).
    pub width: u32,
    /// Height in pixels (default 900; at least [`MIN_SIZE`]`.1`, at most [`MAX_SIDE`]).
    pub height: u32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 1600,
            height: 900,
        }
    }
}

/// The smallest picture that still has room for the labels, (width, height) pixels.
pub const MIN_SIZE: (u32, u32) = (800, 450);
/// The largest width or height accepted, pixels.
pub const MAX_SIDE: u32 = 8192;

/// Why a picture could not be made.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RenderError {
    /// The requested size is out of range.
    #[error(
        "picture size {width}x{height} is out of range ({}x{} to {MAX_SIDE}x{MAX_SIDE})",
        MIN_SIZE.0,
        MIN_SIZE.1
    )]
    Size {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// The mesh has no triangles.
    #[error("the part has no triangles to draw")]
    EmptyMesh,
    /// The field does not have one value per vertex.
    #[error("the field '{name}' has {got} values for {expected} vertices")]
    FieldLength {
        /// Field name.
        name: String,
        /// Number of vertices.
        expected: usize,
        /// Number of values.
        got: usize,
    },
    /// The PNG encoder failed.
    #[error("cannot encode the PNG: {0}")]
    Encode(String),
}

/// Colour of the gate disc; no colour of the colour map, the outlines or the other
/// overlays is this one.
pub const GATE_COLOUR: [u8; 3] = [230, 25, 45];
/// Colour of samples with no field value.
pub const NO_VALUE_COLOUR: [u8; 3] = [165, 165, 165];
/// Background of the views.
pub const VIEW_BACKGROUND: [u8; 3] = [244, 245, 248];

const WHITE: Rgb = [255, 255, 255];
const BLACK: Rgb = [0, 0, 0];
const INK: Rgb = [25, 25, 30];
const GREY: Rgb = [110, 110, 118];
const FRAME: Rgb = [196, 198, 206];

/// Which way a view looks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewKind {
    /// Along -D onto the +D side, where the gate is: u to the right, w up.
    AlongDemold,
    /// Isometric, D up.
    Isometric,
}

/// One panel of the picture and its camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Which view.
    pub kind: ViewKind,
    /// The panel's rectangle in the picture.
    pub panel: PixelRect,
    /// The camera: [`Camera::to_pixel`] gives where a point of the part is drawn.
    pub camera: Camera,
}

/// A drawn picture, before encoding.
pub struct Picture {
    canvas: Canvas,
    /// The two views, along D first.
    pub views: Vec<View>,
    /// Per view, per gate of the scene: whether the part hides the gate's point there
    /// (drawn faint and dashed, labelled "hidden").
    pub hidden_gates: Vec<Vec<bool>>,
    /// Per view, per gate the designer placed: whether it is hidden there (the part hides
    /// its point, or its face is turned away from the view), drawn dashed and labelled so.
    pub hidden_placed: Vec<Vec<bool>>,
}

impl Picture {
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.canvas.width()
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.canvas.height()
    }

    /// Colour of pixel (x, y); `None` outside the picture.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        (x < self.width() && y < self.height()).then(|| self.canvas.get(x, y))
    }

    /// The PNG file: 8-bit RGBA, no time stamp or text chunks.
    pub fn png(&self) -> Result<Vec<u8>, RenderError> {
        self.canvas.encode_png().map_err(RenderError::Encode)
    }
}

/// Draws the scene and encodes it as a PNG.
pub fn png(scene: &Scene, options: &RenderOptions) -> Result<Vec<u8>, RenderError> {
    render(scene, options)?.png()
}

/// Draws the scene.
pub fn render(scene: &Scene, options: &RenderOptions) -> Result<Picture, RenderError> {
    let (width, height) = (options.width, options.height);
    if width < MIN_SIZE.0 || height < MIN_SIZE.1 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(RenderError::Size { width, height });
    }
    if scene.mesh.triangles.is_empty() {
        return Err(RenderError::EmptyMesh);
    }
    // The triangles drawn: the part's, or the part refined to the field's cells.
    let (mesh, values) = scene.surface();
    if values.len() != mesh.vertices.len() {
        return Err(RenderError::FieldLength {
            name: scene.field.name.clone(),
            expected: mesh.vertices.len(),
            got: values.len(),
        });
    }
    let k = (width as f32 / 1600.0).min(height as f32 / 900.0);
    let layout = Layout::new(width, height, k);
    let range = match &scene.node_field {
        // The map's colours span its nodes' values; the rest of the part is grey.
        Some(f) => FieldRange {
            has_missing: true,
            ..FieldRange::of(&f.per_node)
        },
        // A field on cells spans its cells' values (the range the report quotes), a wall
        // map its facets' (its span).
        None => match (scene.field.cells.is_some() || scene.field.span.is_some())
            .then(|| scene.field.colour_span())
            .flatten()
        {
            Some(([lo, hi], beyond)) => FieldRange {
                min_max: Some((lo, hi)),
                has_missing: values.iter().any(|v| !v.is_finite()),
                beyond,
            },
            _ => FieldRange::of(values),
        },
    };
    let lut = Lut::viridis();

    // The facets to skip and the canvas need neither the views nor each other; the views
    // (their cameras fitted to the part) need the part's extents, found in one pass over
    // its vertices; the depths the overlays look up need the views, and so do the views'
    // projections of the mesh (the field's colour-map coordinates beside them): all found
    // beside one another.
    let ((facing, canvas), (views, diagonal, asked, (t, projections))) = rayon::join(
        || {
            rayon::join(
                || {
                    scene.topology.map(|topology| {
                        let facing = Facing::of(scene.mesh, topology);
                        match &scene.display {
                            Some(d) => facing.of_pieces(&d.parent),
                            None => facing,
                        }
                    })
                },
                || Canvas::new(width, height, WHITE),
            )
        },
        || {
            let kinds = [ViewKind::AlongDemold, ViewKind::Isometric];
            let (extents, bounds) =
                extents(&scene.mesh.vertices, kinds.map(|kind| axes(scene, kind)));
            let views: Vec<View> = kinds
                .into_iter()
                .zip(layout.panels)
                .zip(extents)
                .map(|((kind, panel), extent)| View {
                    kind,
                    panel,
                    camera: fit_camera(
                        scene,
                        kind,
                        extent,
                        layout.plot_area(panel),
                        axes_box(
                            &axis_marks(scene, axes(scene, kind), panel, layout.k),
                            layout.k,
                        ),
                    ),
                })
                .collect();
            let (asked, drawn) = rayon::join(
                || {
                    views
                        .iter()
                        .map(|v| ask_depths(scene, v))
                        .collect::<Vec<_>>()
                },
                || {
                    let t: Vec<f32> = values.iter().map(|&v| range.unit(v)).collect();
                    let projections: Vec<Projection> = views
                        .iter()
                        .map(|v| Projection::new(mesh, &v.camera, v.panel, SAMPLES))
                        .collect();
                    (t, projections)
                },
            );
            (views, (bounds.max - bounds.min).length(), asked, drawn)
        },
    );
    let mut canvas = canvas.ok_or(RenderError::Size { width, height })?;
    let sample_mm = |v: &View| 1.0 / (v.camera.scale * SAMPLES as f64);
    let mut panels: Vec<Panel> = views
        .iter()
        .zip(asked)
        .map(|(v, depths)| Panel {
            camera: v.camera,
            rect: v.panel,
            light: (v.camera.right * -0.4 + v.camera.up * 0.55 + v.camera.toward * 0.75)
                .normalize(),
            colours: Colours {
                lut: &lut.0,
                no_value: NO_VALUE_COLOUR.map(|c| c as f32),
                background: VIEW_BACKGROUND,
                crease_mm: (6.0 * sample_mm(v)).max(0.003 * diagonal) as f32,
            },
            depths,
        })
        .collect();
    // Both panels drawn and coloured into the canvas band by band on all threads, then the
    // overlays of each drawn over it, in a fixed order.
    let stride = canvas.width() as usize;
    draw_projected(
        mesh,
        &t,
        facing.as_ref(),
        &mut panels,
        &projections,
        canvas.pixmap.data_mut(),
        stride,
    );
    // What each view's overlays look up in its depths (the qualifying region's squares,
    // the parting line's runs) on all threads, the views side by side; then drawn in order.
    let tolerance = |v: &View| (4.0 * sample_mm(v)).max(0.005 * diagonal);
    let found: Vec<Found> = {
        use rayon::prelude::*;
        views
            .par_iter()
            .zip(&panels)
            .map(|(view, panel)| Found::of(scene, view, &panel.depths, (tolerance(view), &range)))
            .collect()
    };
    let (mut hidden_gates, mut hidden_placed) = (Vec::new(), Vec::new());
    for ((view, panel), found) in views.iter().zip(&panels).zip(found) {
        let (hidden, placed) = draw_overlays(
            &mut canvas,
            scene,
            view,
            &panel.depths,
            found,
            tolerance(view),
            k,
        );
        hidden_gates.push(hidden);
        hidden_placed.push(placed);
        canvas.stroke_rect(
            view.panel.x as f32 + 0.5,
            view.panel.y as f32 + 0.5,
            view.panel.w as f32 - 1.0,
            view.panel.h as f32 - 1.0,
            FRAME,
            1.0,
        );
    }
    draw_title(&mut canvas, scene, &layout, k);
    draw_side_bar(&mut canvas, scene, &layout, &range, &lut, k);
    Ok(Picture {
        canvas,
        views,
        hidden_gates,
        hidden_placed,
    })
}

/// How far the stroked parting line may stray from its points, pixels.
pub const PARTING_TOLERANCE_PX: f32 = 0.1;

/// Samples per pixel along each axis in the z-buffer (anti-aliasing of the part's edges).
const SAMPLES: u32 = 2;

/// Where everything goes.
struct Layout {
    k: f32,
    title_h: f32,
    panels: [PixelRect; 2],
    side_x: f32,
    side_w: f32,
}

impl Layout {
    fn new(width: u32, height: u32, k: f32) -> Layout {
        let margin = (16.0 * k).round();
        let title_h = (74.0 * k).round();
        let side_w = (250.0 * k).round();
        let panels_w = width as f32 - side_w - 3.0 * margin;
        let panel_w = ((panels_w - margin) / 2.0).floor();
        let panel_h = (height as f32 - title_h - margin).floor();
        let panel = |i: usize| PixelRect {
            x: (margin + i as f32 * (panel_w + margin)) as u32,
            y: title_h as u32,
            w: panel_w as u32,
            h: panel_h as u32,
        };
        Layout {
            k,
            title_h,
            panels: [panel(0), panel(1)],
            side_x: width as f32 - side_w - margin,
            side_w,
        }
    }

    /// The part of a panel the part is fitted into: below the caption, above the scale bar.
    fn plot_area(&self, p: PixelRect) -> [f64; 4] {
        let k = self.k as f64;
        let (left, top, right, bottom) = (24.0 * k, 64.0 * k, 24.0 * k, 70.0 * k);
        [
            p.x as f64 + left,
            p.y as f64 + top,
            (p.w as f64 - left - right).max(10.0),
            (p.h as f64 - top - bottom).max(10.0),
        ]
    }
}

/// The camera axes of a view: (right, up, toward the viewer), right x up = toward.
fn axes(scene: &Scene, kind: ViewKind) -> (DVec3, DVec3, DVec3) {
    let f = scene.frame;
    match kind {
        // The frame has u x w = d, so u right and w up look along -d without mirroring.
        ViewKind::AlongDemold => (f.u, f.w, f.d),
        ViewKind::Isometric => {
            let toward = (f.u - f.w + f.d).normalize();
            let up = (f.d - toward * f.d.dot(toward)).normalize();
            (up.cross(toward), up, toward)
        }
    }
}

/// The camera of a view, fitting the part (whose least and greatest (x, y) on the view's
/// axes are `lo` and `hi`, [`extents`]) and the gate discs into `area` (x, y, w, h),
/// clear of the orientation axes' box `avoid` (x0, y0, x1, y1) in the area's lower right
/// corner: when the part's box would reach into it, the part moves up or left within the
/// area if that clears it, and is drawn smaller beside it (above or to its left, whichever
/// is larger) otherwise.
fn fit_camera(
    scene: &Scene,
    kind: ViewKind,
    (mut lo, mut hi): (DVec2, DVec2),
    area: [f64; 4],
    avoid: [f64; 4],
) -> Camera {
    let (right, up, toward) = axes(scene, kind);
    let mut grow = |p: DVec3| {
        let q = DVec2::new(p.dot(right), p.dot(up));
        lo = lo.min(q);
        hi = hi.max(q);
    };
    for g in scene
        .gates
        .iter()
        .chain(scene.placed.iter().map(|p| &p.marker))
    {
        grow(g.point + right * g.radius_mm);
        grow(g.point - right * g.radius_mm);
        grow(g.point + up * g.radius_mm);
        grow(g.point - up * g.radius_mm);
    }
    let span = (hi - lo).max(DVec2::splat(1e-9));
    let (scale, origin) = clear_of(span, area, avoid);
    Camera {
        right,
        up,
        toward,
        centre: (lo + hi) * 0.5,
        scale,
        origin,
    }
}

/// The scale and the centre on the canvas of a box of `span` (mm) fitted into `area` (x, y,
/// w, h) and kept out of the box `avoid` (x0, y0, x1, y1) at the area's lower right: see
/// [`fit_camera`].
fn clear_of(span: DVec2, area: [f64; 4], avoid: [f64; 4]) -> (f64, DVec2) {
    let [x, y, w, h] = area;
    let fit = |w: f64, h: f64| (w / span.x).min(h / span.y);
    let scale = fit(w, h);
    let centre = DVec2::new(x + 0.5 * w, y + 0.5 * h);
    let half = span * scale * 0.5;
    let (right, bottom) = (centre.x + half.x, centre.y + half.y);
    if right <= avoid[0] || bottom <= avoid[1] {
        return (scale, centre);
    }
    // Moved left or up by the least that clears the box, if the area has room.
    let left_by = right - avoid[0];
    let up_by = bottom - avoid[1];
    let room_x = centre.x - half.x - x;
    let room_y = centre.y - half.y - y;
    let moves = [
        (left_by <= room_x + 1e-9).then_some((left_by, DVec2::new(-left_by, 0.0))),
        (up_by <= room_y + 1e-9).then_some((up_by, DVec2::new(0.0, -up_by))),
    ];
    if let Some((_, shift)) = moves
        .into_iter()
        .flatten()
        .min_by(|a, b| a.0.total_cmp(&b.0))
    {
        return (scale, centre + shift);
    }
    // Smaller: the area left of the box, or the area above it.
    let (w_left, h_above) = ((avoid[0] - x).max(1.0), (avoid[1] - y).max(1.0));
    let (left, above) = (fit(w_left, h), fit(w, h_above));
    if left >= above {
        (left, DVec2::new(x + 0.5 * w_left, y + 0.5 * h))
    } else {
        (above, DVec2::new(x + 0.5 * w, y + 0.5 * h_above))
    }
}

/// The least and greatest (x, y) of `points` projected on each view's right and up axes,
/// and their box, in one pass in blocks on all threads (the least and greatest are the same
/// in any order).
fn extents<const N: usize>(
    points: &[DVec3],
    axes: [(DVec3, DVec3, DVec3); N],
) -> ([(DVec2, DVec2); N], crate::math::Aabb) {
    use rayon::prelude::*;
    let empty = || {
        (
            [(DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)); N],
            crate::math::Aabb::EMPTY,
        )
    };
    points
        .par_chunks(1 << 14)
        .map(|block| {
            let (mut extents, _) = empty();
            for p in block {
                for ((lo, hi), (right, up, _)) in extents.iter_mut().zip(&axes) {
                    let q = DVec2::new(p.dot(*right), p.dot(*up));
                    (*lo, *hi) = (lo.min(q), hi.max(q));
                }
            }
            (extents, crate::math::Aabb::of_points(block))
        })
        .reduce(empty, |(mut a, box_a), (b, box_b)| {
            for ((lo, hi), (c, d)) in a.iter_mut().zip(b) {
                (*lo, *hi) = (lo.min(c), hi.max(d));
            }
            (a, box_a.grown(box_b.min).grown(box_b.max))
        })
}

/// The finite values of the field: their range, and how values map to 0..=1.
#[derive(Debug, Clone, Copy)]
struct FieldRange {
    /// `None` when no value is finite.
    min_max: Option<(f32, f32)>,
    /// Some values are NaN (drawn grey).
    has_missing: bool,
    /// The largest value, when the colours stop below it ([`Field::colour_span`]).
    beyond: Option<f32>,
}

impl FieldRange {
    fn of(values: &[f32]) -> FieldRange {
        let mut min_max: Option<(f32, f32)> = None;
        let mut has_missing = false;
        for &v in values {
            if v.is_finite() {
                min_max = Some(match min_max {
                    None => (v, v),
                    Some((a, b)) => (a.min(v), b.max(v)),
                });
            } else {
                has_missing = true;
            }
        }
        FieldRange {
            min_max,
            has_missing,
            beyond: None,
        }
    }

    /// Colour-map coordinate of `v` (NaN for a missing value; 0.5 for a constant field).
    fn unit(&self, v: f32) -> f32 {
        match self.min_max {
            Some((a, b)) if v.is_finite() => {
                if b > a {
                    ((v - a) / (b - a)).clamp(0.0, 1.0)
                } else {
                    0.5
                }
            }
            _ => f32::NAN,
        }
    }
}

/// Viridis in 256 steps: perceptually even, readable in grey and by most colour-blind
/// readers, and free of the gate's red.
struct Lut([[f32; 3]; 256]);

impl Lut {
    fn viridis() -> Lut {
        let mut table = [[0.0; 3]; 256];
        for (i, e) in table.iter_mut().enumerate() {
            let c = colorous::VIRIDIS.eval_rational(i, 256);
            *e = [c.r as f32, c.g as f32, c.b as f32];
        }
        Lut(table)
    }

    fn colour(&self, t: f32) -> [f32; 3] {
        if t.is_nan() {
            NO_VALUE_COLOUR.map(|c| c as f32)
        } else {
            self.0[raster::lut_index(t) as usize]
        }
    }

    fn rgb(&self, t: f32) -> Rgb {
        self.colour(t).map(|c| c.round() as u8)
    }
}

/// The qualifying region, the parting line, the centre of mass, the gate, the scale bar,
/// the axes and the caption of one view.
fn draw_overlays(
    canvas: &mut Canvas,
    scene: &Scene,
    view: &View,
    depths: &Depths,
    found: Found,
    tolerance: f64,
    k: f32,
) -> (Vec<bool>, Vec<bool>) {
    let cam = &view.camera;
    if let Some(squares) = &found.qualifying {
        blend_qualifying(canvas, view, squares);
    }
    let (hidden, shown) = found.parting;
    canvas.stroke_polylines(&hidden, false, GREY, 1.2 * k, Some([5.0 * k, 4.0 * k]));
    canvas.stroke_polylines(&shown, false, BLACK, 4.5 * k, None);
    canvas.stroke_polylines(&shown, false, WHITE, 2.0 * k, None);
    let panel_box = [
        view.panel.x as f32,
        view.panel.y as f32,
        (view.panel.x + view.panel.w) as f32,
        (view.panel.y + view.panel.h) as f32,
    ];
    let marks: Vec<[f32; 2]> = std::iter::once(scene.centre)
        .chain(scene.gates.iter().map(|g| g.point))
        .map(|p| {
            let q = cam.to_pixel(p);
            [q.x as f32, q.y as f32]
        })
        .collect();
    let keep_out_labels = keepout::draw_keep_outs(
        canvas,
        cam,
        &scene.keep_out,
        (panel_box, 48.0 * k),
        &marks,
        k,
    );

    // Centre of mass under the gate: its cross reaches beyond the disc, so both show when
    // the gate lies right above it.
    let c = cam.to_pixel(scene.centre);
    let mut reach = 13.0 * k;
    for g in &scene.gates {
        let r = gate_outline(cam, g).1;
        if (cam.to_pixel(g.point) - c).length() < (r + reach) as f64 {
            reach = reach.max(r + 10.0 * k);
        }
    }
    draw_centre_symbol(canvas, c.x as f32, c.y as f32, reach, k);
    let (cx, cy) = (c.x as f32, c.y as f32);
    // What a gate's label must not cover: the centre's cross (its two arms), its label and
    // every gate disc; each label placed is added.
    let arm = 3.0 * k;
    let mut taken: Vec<LabelBox> = vec![
        [cx - reach, cy - arm, cx + reach, cy + arm],
        [cx - arm, cy - reach, cx + arm, cy + reach],
    ];
    taken.extend(keep_out_labels);
    let centre_label = if depths.visible(c.x, c.y, cam.depth(scene.centre), tolerance) {
        "centre of mass"
    } else {
        // It lies inside the part or behind it: say so, the cross is drawn over it.
        "centre of mass (hidden)"
    };
    // Each gate's disc, and whether the part hides its point in this view (a gate inside
    // a box seen from outside): drawn faint and dashed, and labelled so.
    let discs: Vec<Disc> = scene
        .gates
        .iter()
        .map(|g| Disc::of(cam, g, depths, tolerance))
        .collect();
    // The designer's gates alike. A gate the designer placed may lie anywhere on the
    // part, on a face turned away from the view (whose point the depths can still show
    // through a hole or past an edge beside it): such a face is hidden too.
    let placed_discs: Vec<Disc> = scene
        .placed
        .iter()
        .map(|g| {
            let mut d = Disc::of(cam, &g.marker, depths, tolerance);
            d.hidden |= g.marker.normal.dot(cam.toward) < 0.0;
            d
        })
        .collect();
    taken.extend(discs.iter().chain(&placed_discs).map(|d| {
        let ([x, y], r) = (d.at, d.r);
        [x - r, y - r, x + r, y + r]
    }));
    let inside = panel_box;
    // The centre's label: lower left of the cross as usual, elsewhere around it when a
    // gate's disc lies there (a gate of a layout often sits beside the centre).
    let centre_style = TextStyle::new(13.0 * k, INK).halo(WHITE);
    let (lx, ly, align) = centre_label_place(
        [cx, cy],
        reach,
        centre_label,
        &centre_style,
        &taken,
        inside,
        k,
    );
    canvas.text(lx, ly, centre_label, &centre_style, align);
    taken.push(text_box(lx, ly, centre_label, &centre_style, align));
    let gate_style = TextStyle::new(15.0 * k, GATE_COLOUR).bold().halo(WHITE);
    for (i, d) in discs.iter().enumerate() {
        let ([x, y], r) = (d.at, d.r);
        draw_gate(canvas, &d.outline, [x, y, r], d.hidden, k);
        let answer_gates = scene.gates.iter().filter(|g| g.body.is_none()).count();
        let mut label = match scene.gates[i].body {
            Some(b) => format!("gate of {}", crate::flow::body_name(b)),
            None if answer_gates > 1 => format!("gate {}", i + 1),
            None => "gate".to_string(),
        };
        if d.hidden {
            label += " (hidden)";
        }
        // A label reads as the mark it is nearest: the designer's gates count too, and so
        // does the centre of mass's cross when it is off the disc (a large gate's label
        // beside the cross read as the cross's; a cross on the disc is the same place).
        let cross_apart = (cx - x).hypot(cy - y) > r + 12.0 * k;
        let others: Vec<[f32; 2]> = (0..discs.len())
            .filter(|&j| j != i)
            .map(|j| discs[j].at)
            .chain(placed_discs.iter().map(|d| d.at))
            .chain(cross_apart.then_some([cx, cy]))
            .collect();
        let (tx, ty, align, own) =
            gate_label_place([x, y], r, &label, &gate_style, &taken, inside, k, &others);
        let b = text_box(tx, ty, &label, &gate_style, align);
        if !own {
            draw_leader(canvas, &b, [x, y], k);
        }
        canvas.text(tx, ty, &label, &gate_style, align);
        taken.push(b);
    }

    let answer: Vec<[f32; 2]> = discs.iter().map(|d| d.at).collect();
    placed::draw_placed(
        canvas,
        scene,
        &placed_discs,
        (&mut taken, inside, &answer),
        k,
    );

    draw_scale_bar(canvas, view, k);
    draw_axes(canvas, scene, view, k);
    let (title, note) = match view.kind {
        ViewKind::AlongDemold => (
            "Along the demolding direction D",
            "looking at the +D side (gate side), D towards you",
        ),
        ViewKind::Isometric => ("Isometric view", "D points up"),
    };
    let x = view.panel.x as f32 + 12.0 * k;
    let y = view.panel.y as f32;
    canvas.text(
        x,
        y + 24.0 * k,
        title,
        &TextStyle::new(17.0 * k, INK).bold(),
        Align::Left,
    );
    canvas.text(
        x,
        y + 45.0 * k,
        note,
        &TextStyle::new(14.0 * k, GREY),
        Align::Left,
    );
    let hidden = |discs: &[Disc]| discs.iter().map(|d| d.hidden).collect();
    (hidden(&discs), hidden(&placed_discs))
}

/// What the overlays of a view find in its depths before they are drawn: the qualifying
/// region's squares and the parting line's runs, (hidden, shown), chained and simplified.
struct Found {
    qualifying: Option<Squares>,
    parting: (Polylines, Polylines),
}

impl Found {
    fn of(
        scene: &Scene,
        view: &View,
        depths: &Depths,
        (tolerance, range): (f64, &FieldRange),
    ) -> Found {
        // Parting line: seen along D it is the outline of the part, so all of it is shown;
        // in the other view the parts behind the part are dashed.
        let (hidden, shown) = parting_runs(scene, view, &mut |m, depth| {
            depths.visible(m.x, m.y, depth, tolerance)
        });
        let simplify = |lines: Polylines| -> Polylines {
            chained(lines)
                .iter()
                .map(|l| simplified(l, PARTING_TOLERANCE_PX))
                .collect()
        };
        Found {
            qualifying: qualifying_squares(scene, view, depths, tolerance, range),
            parting: (simplify(hidden), simplify(shown)),
        }
    }
}

/// A gate's disc in a view: its outline and radius, pixels, its centre, and whether the
/// part hides it there.
struct Disc {
    outline: Vec<[f32; 2]>,
    r: f32,
    at: [f32; 2],
    hidden: bool,
}

impl Disc {
    /// The disc of gate `g` in the view of `cam`, hidden when the depths drawn at its point
    /// and one pixel around it all lie in front of it (beyond `tolerance`, mm).
    fn of(cam: &Camera, g: &crate::scene::Marker, depths: &Depths, tolerance: f64) -> Disc {
        let (outline, r) = gate_outline(cam, g);
        let p = cam.to_pixel(g.point);
        Disc {
            outline,
            r,
            at: [p.x as f32, p.y as f32],
            hidden: !depths.visible_around(p.x, p.y, cam.depth(g.point), tolerance),
        }
    }
}

/// The places whose depth the overlays of `view` look up (qualifying points, the parting
/// line's pieces in the view that tells hidden from visible, the centre of mass, the
/// answer's gates and the designer's), asked for before the panel is drawn.
fn ask_depths(scene: &Scene, view: &View) -> Depths {
    let cam = &view.camera;
    let mut depths = Depths::new(view.panel, SAMPLES);
    for &p in &scene.qualifying {
        let q = cam.to_pixel(p);
        depths.ask(q.x, q.y);
    }
    if view.kind != ViewKind::AlongDemold {
        parting_runs(scene, view, &mut |m, _| {
            depths.ask(m.x, m.y);
            true
        });
    }
    let c = cam.to_pixel(scene.centre);
    depths.ask(c.x, c.y);
    for p in scene
        .gates
        .iter()
        .chain(scene.placed.iter().map(|g| &g.marker))
    {
        let q = cam.to_pixel(p.point);
        depths.ask_around(q.x, q.y);
    }
    depths
}

/// Lines of canvas points, pixels.
type Polylines = Vec<Vec<[f32; 2]>>;

/// The parting line in `view` as runs of canvas points, (hidden, shown): `visible` tells
/// whether a point at a canvas position with a depth is seen. Seen along D the line is the
/// outline of the part, and all of it is shown without asking.
fn parting_runs(
    scene: &Scene,
    view: &View,
    visible: &mut dyn FnMut(DVec2, f64) -> bool,
) -> (Polylines, Polylines) {
    let cam = &view.camera;
    let depth_test = view.kind != ViewKind::AlongDemold;
    let mut hidden: Vec<Vec<[f32; 2]>> = Vec::new();
    let mut shown: Vec<Vec<[f32; 2]>> = Vec::new();
    for line in &scene.parting {
        let mut run: Vec<[f32; 2]> = Vec::new();
        let mut run_visible = true;
        for pair in line.windows(2) {
            let (p, q) = (pair[0], pair[1]);
            let length_px = (cam.to_pixel(q) - cam.to_pixel(p)).length();
            // Pieces of about 3 pixels each take their visibility from their middle; a run
            // keeps only the points where it changes (the others lie on the same segment).
            let pieces = if depth_test {
                (length_px / 3.0).ceil().clamp(1.0, 10_000.0) as usize
            } else {
                1
            };
            for i in 0..pieces {
                let a = p.lerp(q, i as f64 / pieces as f64);
                let b = p.lerp(q, (i + 1) as f64 / pieces as f64);
                let mid = (a + b) * 0.5;
                let visible = !depth_test || visible(cam.to_pixel(mid), cam.depth(mid));
                let pa = cam.to_pixel(a);
                let pa = [pa.x as f32, pa.y as f32];
                if visible != run_visible && !run.is_empty() {
                    run.push(pa);
                    let done = std::mem::take(&mut run);
                    if run_visible { &mut shown } else { &mut hidden }.push(done);
                }
                if run.is_empty() {
                    run.push(pa);
                }
                run_visible = visible;
            }
            let end = cam.to_pixel(q);
            run.push([end.x as f32, end.y as f32]);
        }
        if !run.is_empty() {
            if run_visible { &mut shown } else { &mut hidden }.push(run);
        }
    }
    (hidden, shown)
}

/// `line` less the points within `tolerance` pixels of the line through their neighbours
/// that are kept (Ramer-Douglas-Peucker): a parting line of a fine mesh has several points
/// per pixel, and each costs the stroke a round join.
fn simplified(line: &[[f32; 2]], tolerance: f32) -> Vec<[f32; 2]> {
    if line.len() < 3 {
        return line.to_vec();
    }
    let mut keep = vec![false; line.len()];
    keep[0] = true;
    keep[line.len() - 1] = true;
    let mut stack = vec![(0, line.len() - 1)];
    while let Some((first, last)) = stack.pop() {
        let (a, b) = (line[first], line[last]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let length = (dx * dx + dy * dy).sqrt();
        let mut far = (0.0f32, first);
        for (i, p) in line.iter().enumerate().take(last).skip(first + 1) {
            let (px, py) = (p[0] - a[0], p[1] - a[1]);
            let d = if length > 0.0 {
                (px * dy - py * dx).abs() / length
            } else {
                (px * px + py * py).sqrt()
            };
            if d > far.0 {
                far = (d, i);
            }
        }
        if far.0 > tolerance {
            keep[far.1] = true;
            stack.push((first, far.1));
            stack.push((far.1, last));
        }
    }
    line.iter()
        .zip(keep)
        .filter_map(|(p, k)| k.then_some(*p))
        .collect()
}

/// Polylines joined where one ends at a point where another starts or ends, so that they
/// are stroked as long lines rather than as thousands of short ones, each with its two
/// round caps (the parting line of a fine mesh comes in pieces of a few edges).
fn chained(lines: Vec<Vec<[f32; 2]>>) -> Vec<Vec<[f32; 2]>> {
    let key = |p: [f32; 2]| (p[0].to_bits(), p[1].to_bits());
    let mut at: rustc_hash::FxHashMap<(u32, u32), Vec<usize>> = Default::default();
    for (i, line) in lines.iter().enumerate() {
        at.entry(key(line[0])).or_default().push(i);
        at.entry(key(line[line.len() - 1])).or_default().push(i);
    }
    let mut used = vec![false; lines.len()];
    let mut out = Vec::new();
    for start in 0..lines.len() {
        if used[start] {
            continue;
        }
        used[start] = true;
        let mut line = lines[start].clone();
        // Grow at the end, then turn round and grow at the other end.
        for _ in 0..2 {
            while let Some(&next) = at[&key(line[line.len() - 1])].iter().find(|&&j| !used[j]) {
                used[next] = true;
                let piece = &lines[next];
                if key(piece[0]) == key(line[line.len() - 1]) {
                    line.extend_from_slice(&piece[1..]);
                } else {
                    line.extend(piece.iter().rev().skip(1));
                }
            }
            line.reverse();
        }
        out.push(line);
    }
    out
}

/// The qualifying nodes as a hatched region with a dark edge: each node covers a square of
/// the grid spacing around it, so the nodes join into the region they stand for. With a
/// node field (the suitability map) each square is filled with its node's colour instead
/// of the hatch.
fn qualifying_squares(
    scene: &Scene,
    view: &View,
    depths: &Depths,
    tolerance: f64,
    range: &FieldRange,
) -> Option<Squares> {
    if scene.qualifying.is_empty() {
        return None;
    }
    let cam = &view.camera;
    let rect = view.panel;
    let (w, h) = (rect.w as usize, rect.h as usize);
    let mut mask = vec![false; w * h];
    let lut = Lut::viridis();
    let mut colour: Vec<Option<Rgb>> = Vec::new();
    if scene.node_field.is_some() {
        colour = vec![None; w * h];
    }
    let half = (scene.grid_spacing_mm * cam.scale * 0.5).max(0.6);
    // The panel's columns and rows the squares cover.
    let (mut columns, mut rows) = (w..0, h..0);
    for (i, &p) in scene.qualifying.iter().enumerate() {
        let q = cam.to_pixel(p);
        if !depths.visible(q.x, q.y, cam.depth(p), tolerance) {
            continue;
        }
        let (x, y) = (q.x - rect.x as f64, q.y - rect.y as f64);
        let (x0, x1) = square_span(x, half, w);
        let (y0, y1) = square_span(y, half, h);
        for row in y0..y1 {
            mask[row * w + x0..row * w + x1].fill(true);
        }
        if x0 < x1 && y0 < y1 {
            (columns.start, columns.end) = (columns.start.min(x0), columns.end.max(x1));
            (rows.start, rows.end) = (rows.start.min(y0), rows.end.max(y1));
        }
        if let Some(f) = &scene.node_field {
            let v = f.per_node.get(i).copied().unwrap_or(f32::NAN);
            let c = lut.rgb(range.unit(v));
            for row in y0..y1 {
                colour[row * w + x0..row * w + x1].fill(Some(c));
            }
        }
    }
    Some(Squares {
        mask,
        colour,
        columns,
        rows,
    })
}

/// The visible qualifying nodes' squares in a panel: which of its pixels they cover, the
/// node field's colour there (empty without a node field), and the columns and rows
/// covered.
struct Squares {
    mask: Vec<bool>,
    colour: Vec<Option<Rgb>>,
    columns: std::ops::Range<usize>,
    rows: std::ops::Range<usize>,
}

/// Draws the qualifying region of [`qualifying_squares`].
fn blend_qualifying(canvas: &mut Canvas, view: &View, squares: &Squares) {
    let Squares {
        mask,
        colour,
        columns,
        rows,
    } = squares;
    let rect = view.panel;
    let (w, h) = (rect.w as usize, rect.h as usize);
    // The covered rows of the canvas on all threads (each pixel's colour depends on the
    // mask alone), within the canvas as [`Canvas::blend`] keeps them.
    let (stride, height) = (canvas.width() as usize, canvas.height() as usize);
    let (left, top) = (rect.x as usize, rect.y as usize);
    let end = (top + rows.end).min(height);
    if columns.is_empty() || top + rows.start >= end || left >= stride {
        return;
    }
    use rayon::prelude::*;
    let columns = columns.start..columns.end.min(stride - left);
    canvas.pixmap.data_mut()[4 * stride * (top + rows.start)..4 * stride * end]
        .par_chunks_mut(4 * stride)
        .enumerate()
        .for_each(|(i, line)| {
            let y = rows.start + i;
            let here = &mask[y * w..(y + 1) * w];
            for x in columns.clone() {
                if !here[x] {
                    continue;
                }
                let edge = x == 0
                    || y == 0
                    || x + 1 == w
                    || y + 1 == h
                    || !here[x - 1]
                    || !here[x + 1]
                    || !mask[(y - 1) * w + x]
                    || !mask[(y + 1) * w + x];
                let pixel = &mut line[4 * (left + x)..4 * (left + x + 1)];
                if edge {
                    canvas::blend_pixel(pixel, BLACK, 0.85);
                } else if let Some(c) = colour.get(y * w + x).copied().flatten() {
                    canvas::blend_pixel(pixel, c, 1.0);
                } else if let Some((c, a)) = hatch(x, y) {
                    canvas::blend_pixel(pixel, c, a);
                }
            }
        });
}

/// The pixels, first and past the last, of a node's square `centre - half` to `centre +
/// half` along one axis of a panel `len` pixels long: every pixel the square touches, so
/// that neighbouring squares meet or overlap by a pixel. (Rounding each side instead, an
/// edge at a pixel's half could round one way for one node and the other way for its
/// neighbour, one ulp apart: a column of pixels between them, outlined as if the region
/// were split there.)
fn square_span(centre: f64, half: f64, len: usize) -> (usize, usize) {
    let first = (centre - half).floor().max(0.0) as usize;
    let end = ((centre + half).ceil().max(0.0) as usize).min(len);
    (first.min(end), end)
}

/// A label's box in pixels: left, top, right, bottom.
type LabelBox = [f32; 4];

/// Whether two boxes overlap (touching is not overlapping).
fn overlaps(a: &LabelBox, b: &LabelBox) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

/// The box of `text` drawn by [`Canvas::text`] at (x, y), y its baseline, with its halo.
fn text_box(x: f32, y: f32, text: &str, style: &TextStyle, align: Align) -> LabelBox {
    let w = canvas::text_width(text, style);
    let x0 = match align {
        Align::Left => x,
        Align::Centre => x - w / 2.0,
        Align::Right => x - w,
    };
    [x0 - 1.5, y - style.size, x0 + w + 1.5, y + 0.3 * style.size]
}

/// Where a gate's label goes: beside its disc (centre `p`, radius `r` pixels), the first of
/// upper right (the usual place), lower right, upper left, lower left, then the same a
/// label's height farther out, whose box overlaps nothing `taken`, lies inside the panel
/// (`inside`) and is clearly nearer the disc's centre than the centre of any other gate
/// (`others`, by a quarter: the label of a gate of a layout must not read as its
/// neighbour's); failing the last,
/// the first of the others; the usual place when none does. Returns the text's anchor and
/// alignment, and whether the label is nearer its own gate than any other (else the caller
/// draws a leader to it).
#[allow(clippy::too_many_arguments)]
fn gate_label_place(
    p: [f32; 2],
    r: f32,
    label: &str,
    style: &TextStyle,
    taken: &[LabelBox],
    inside: LabelBox,
    k: f32,
    others: &[[f32; 2]],
) -> (f32, f32, Align, bool) {
    let around = Around {
        side: r + 12.0 * k,
        above: r + 8.0 * k,
        below: r + 20.0 * k,
        step: style.size * 1.2,
    };
    let order = [
        Corner::UpperRight,
        Corner::LowerRight,
        Corner::UpperLeft,
        Corner::LowerLeft,
    ];
    let places = around.places(p, order);
    let own = |&(tx, ty, align): &(f32, f32, Align)| {
        let b = text_box(tx, ty, label, style, align);
        // Clearly nearer: by a quarter, so a label midway between two discs does not pass.
        let mine = box_distance(&b, p);
        others.iter().all(|&o| 1.25 * mine < box_distance(&b, o))
    };
    let nearest: Vec<(f32, f32, Align)> = places.iter().copied().filter(own).collect();
    if let Some((x, y, align)) = free_place(&nearest, label, style, taken, inside) {
        return (x, y, align, true);
    }
    let (x, y, align) = first_free(&places, label, style, taken, inside);
    (x, y, align, own(&(x, y, align)))
}

/// The distance in pixels from point `p` to the box `b` (0 inside it).
fn box_distance(b: &LabelBox, p: [f32; 2]) -> f32 {
    let dx = (b[0] - p[0]).max(p[0] - b[2]).max(0.0);
    let dy = (b[1] - p[1]).max(p[1] - b[3]).max(0.0);
    dx.hypot(dy)
}

/// A thin dark line from a label's box to the centre of its gate's disc (centre `p`), with
/// a dot there, for a label that could not go clearly nearer its own gate than another:
/// drawn across the disc, it shows which of two touching discs it names.
fn draw_leader(canvas: &mut Canvas, b: &LabelBox, p: [f32; 2], k: f32) {
    let q = [p[0].clamp(b[0], b[2]), p[1].clamp(b[1], b[3])];
    canvas.stroke_polyline(&[p, q], false, INK, 1.5 * k, None);
    canvas.fill_circle(p[0], p[1], 2.5 * k, INK);
}

/// Where the centre of mass's label goes: lower left of its cross (centre `c`, arms of
/// `reach` pixels), then lower right, upper left, upper right, then the same farther out,
/// the first whose box overlaps nothing `taken` (the cross's arms, the gates' discs) and
/// lies inside the panel; the usual place when none does.
fn centre_label_place(
    c: [f32; 2],
    reach: f32,
    label: &str,
    style: &TextStyle,
    taken: &[LabelBox],
    inside: LabelBox,
    k: f32,
) -> (f32, f32, Align) {
    let around = Around {
        side: reach + 6.0 * k,
        above: 8.0 * k,
        below: 18.0 * k,
        step: style.size * 1.4,
    };
    let order = [
        Corner::LowerLeft,
        Corner::LowerRight,
        Corner::UpperLeft,
        Corner::UpperRight,
    ];
    first_free(&around.places(c, order), label, style, taken, inside)
}

/// A corner beside a mark where a label may go.
#[derive(Clone, Copy)]
enum Corner {
    UpperRight,
    LowerRight,
    UpperLeft,
    LowerLeft,
}

/// Label anchors around a mark: `side` pixels to its left or right (the text aligned
/// away from the mark), `above` over it or `below` under it (the baseline), and again
/// `step` and twice `step` farther up or down.
struct Around {
    side: f32,
    above: f32,
    below: f32,
    step: f32,
}

impl Around {
    /// The anchors around the mark at `p`, nearest first, each ring's corners in `order`.
    fn places(&self, p: [f32; 2], order: [Corner; 4]) -> Vec<(f32, f32, Align)> {
        let [x, y] = p;
        let mut places = Vec::new();
        for out in [0.0, self.step, 2.0 * self.step] {
            places.extend(order.map(|corner| match corner {
                Corner::UpperRight => (x + self.side, y - self.above - out, Align::Left),
                Corner::LowerRight => (x + self.side, y + self.below + out, Align::Left),
                Corner::UpperLeft => (x - self.side, y - self.above - out, Align::Right),
                Corner::LowerLeft => (x - self.side, y + self.below + out, Align::Right),
            }));
        }
        places
    }
}

/// The first of `places` (text anchor and alignment) whose box overlaps nothing `taken`
/// and lies inside `inside`; the first place when none does.
fn first_free(
    places: &[(f32, f32, Align)],
    label: &str,
    style: &TextStyle,
    taken: &[LabelBox],
    inside: LabelBox,
) -> (f32, f32, Align) {
    free_place(places, label, style, taken, inside).unwrap_or(places[0])
}

/// The first of `places` whose box overlaps nothing `taken` and lies `inside`, if any.
fn free_place(
    places: &[(f32, f32, Align)],
    label: &str,
    style: &TextStyle,
    taken: &[LabelBox],
    inside: LabelBox,
) -> Option<(f32, f32, Align)> {
    places.iter().copied().find(|&(tx, ty, align)| {
        let b = text_box(tx, ty, label, style, align);
        b[0] >= inside[0]
            && b[1] >= inside[1]
            && b[2] <= inside[2]
            && b[3] <= inside[3]
            && taken.iter().all(|t| !overlaps(&b, t))
    })
}

/// The hatch of the qualifying region at pixel (x, y): a white stripe with a dark edge, so
/// it shows on every colour of the map.
fn hatch(x: usize, y: usize) -> Option<(Rgb, f32)> {
    match (x + y) % 9 {
        0 => Some((WHITE, 0.8)),
        1 => Some((BLACK, 0.35)),
        _ => None,
    }
}

/// The gate disc as seen by the camera: points of the circle of radius R around the gate
/// in the plane of its normal (D when the normal is unknown), and its largest radius in
/// pixels. A disc smaller than 3 pixels is drawn at 3 pixels so it stays visible.
fn gate_outline(cam: &Camera, g: &crate::scene::Marker) -> (Vec<[f32; 2]>, f32) {
    let n = if g.normal.length_squared() > 0.5 {
        g.normal.normalize()
    } else {
        cam.toward
    };
    let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let e1 = n.cross(helper).normalize();
    let e2 = n.cross(e1);
    let c = cam.to_pixel(g.point);
    let mut pts: Vec<DVec2> = (0..64)
        .map(|i| {
            let a = i as f64 / 64.0 * std::f64::consts::TAU;
            cam.to_pixel(g.point + (e1 * a.cos() + e2 * a.sin()) * g.radius_mm)
        })
        .collect();
    let r = pts.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
    let min_r = 3.0;
    // A disc seen edge on (a gate on a wall parallel to the view) is a thin ellipse: its
    // minor axis is widened to `min_r` so that it reads as a disc, not a sliver.
    let minor = pts
        .iter()
        .map(|p| (*p - c).length())
        .fold(f64::INFINITY, f64::min);
    if r >= min_r && minor < min_r {
        let far = pts.iter().copied().max_by(|a, b| {
            (*a - c)
                .length_squared()
                .total_cmp(&(*b - c).length_squared())
        });
        let major = (far.unwrap_or(c) - c).normalize_or_zero();
        let across = DVec2::new(-major.y, major.x);
        // The projected circle is an ellipse of semi-axes r and `minor`: drawn again with
        // `min_r` across.
        for (i, p) in pts.iter_mut().enumerate() {
            let a = i as f64 / 64.0 * std::f64::consts::TAU;
            *p = c + major * (r * a.cos()) + across * (min_r * a.sin());
        }
    }
    if r < min_r {
        let stretch = if r > 1e-9 { min_r / r } else { 0.0 };
        for (i, p) in pts.iter_mut().enumerate() {
            *p = if stretch > 0.0 {
                c + (*p - c) * stretch
            } else {
                let a = i as f64 / 64.0 * std::f64::consts::TAU;
                c + DVec2::new(a.cos(), a.sin()) * min_r
            };
        }
    }
    (
        pts.iter().map(|p| [p.x as f32, p.y as f32]).collect(),
        r.max(min_r) as f32,
    )
}

/// A gate's disc at (x, y) of radius r, pixels; a gate the part hides in the view is faint,
/// its outline dashed.
fn draw_gate(canvas: &mut Canvas, outline: &[[f32; 2]], [x, y, r]: [f32; 3], hidden: bool, k: f32) {
    let dash = hidden.then_some([4.0 * k, 3.0 * k]);
    canvas.stroke_polyline(outline, true, BLACK, 4.5 * k.max(0.7), dash);
    canvas.stroke_polyline(outline, true, WHITE, 2.5 * k.max(0.7), dash);
    canvas.fill_polygon(outline, GATE_COLOUR, if hidden { 110 } else { 255 });
    // Small on screen, or seen edge on (narrow): a ring around it so the eye finds it.
    let narrow = outline
        .iter()
        .map(|p| (p[0] - x).hypot(p[1] - y))
        .fold(f32::INFINITY, f32::min);
    if r < 10.0 * k || narrow < 4.0 * k {
        let ring = r + 9.0 * k;
        match hidden {
            // Behind the part: a thin dashed ring.
            true => {
                let circle: Vec<[f32; 2]> = (0..48)
                    .map(|i| {
                        let a = i as f32 / 48.0 * std::f32::consts::TAU;
                        [x + ring * a.cos(), y + ring * a.sin()]
                    })
                    .collect();
                canvas.stroke_polyline(&circle, true, WHITE, 3.0 * k, None);
                canvas.stroke_polyline(&circle, true, GATE_COLOUR, 1.4 * k, dash);
            }
            false => {
                canvas.stroke_circle(x, y, ring, WHITE, 4.0 * k);
                canvas.stroke_circle(x, y, ring, GATE_COLOUR, 2.2 * k);
            }
        }
    }
}

/// A cross with an open middle and a small ring: the centre of mass.
fn draw_centre_symbol(canvas: &mut Canvas, x: f32, y: f32, reach: f32, k: f32) {
    let inner = 4.0 * k;
    let arms = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)];
    for (colour, width) in [(WHITE, 4.5 * k), (BLACK, 2.0 * k)] {
        for (dx, dy) in arms {
            canvas.stroke_polyline(
                &[
                    [x + dx * inner, y + dy * inner],
                    [x + dx * reach, y + dy * reach],
                ],
                false,
                colour,
                width,
                None,
            );
        }
        canvas.stroke_circle(x, y, 7.0 * k, colour, width * 0.8);
    }
}

/// A "nice" number near `x`: 1, 2 or 5 times a power of ten, not above `x`.
fn nice_below(x: f64) -> f64 {
    let p = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&v| v <= x)
        .unwrap_or(p)
}

/// A number with as many decimals as `step` needs (at most 6).
fn format_step(v: f64, step: f64) -> String {
    let decimals = (0..6)
        .find(|&d| {
            let scaled = step.abs() * 10f64.powi(d as i32);
            (scaled - scaled.round()).abs() < 1e-6 * scaled.max(1.0)
        })
        .unwrap_or(6);
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

fn draw_scale_bar(canvas: &mut Canvas, view: &View, k: f32) {
    let cam = &view.camera;
    let p = view.panel;
    let target_px = p.w as f64 * 0.22;
    let length_mm = nice_below(target_px / cam.scale);
    let length_px = (length_mm * cam.scale) as f32;
    let x0 = p.x as f32 + 20.0 * k;
    let y = (p.y + p.h) as f32 - 22.0 * k;
    let tick = 6.0 * k;
    let pts = [
        [x0, y - tick],
        [x0, y],
        [x0 + length_px, y],
        [x0 + length_px, y - tick],
    ];
    canvas.stroke_polyline(&pts, false, INK, 2.2 * k, None);
    canvas.text(
        x0 + length_px / 2.0,
        y - 9.0 * k,
        &format!("{} mm", format_step(length_mm, length_mm)),
        &TextStyle::new(14.0 * k, INK),
        Align::Centre,
    );
}

/// One mark of the orientation axes in a panel's lower right corner.
enum AxisMark {
    /// An axis nearly along the line of sight: a circle with a dot (towards the viewer) or
    /// a cross (away), its name to the right.
    Symbol {
        name: &'static str,
        colour: Rgb,
        width: f32,
        at: [f32; 2],
        toward: bool,
    },
    /// An arrow from the axes' origin, its name beyond the head.
    Arrow {
        name: &'static str,
        colour: Rgb,
        width: f32,
        from: [f32; 2],
        to: [f32; 2],
        /// Unit direction on the canvas.
        unit: [f32; 2],
    },
}

/// The radius of an axis symbol, the length of an arrow and the size of its head, times k.
const AXIS_SYMBOL_R: f32 = 6.0;
const AXIS_LENGTH: f32 = 34.0;
const AXIS_HEAD: f32 = 7.0;

/// World axes X, Y, Z and the demolding direction D as seen along `toward` with `right`
/// and `up` on the canvas, in the lower right corner of `panel`.
fn axis_marks(
    scene: &Scene,
    (right, up, toward): (DVec3, DVec3, DVec3),
    panel: PixelRect,
    k: f32,
) -> Vec<AxisMark> {
    let length = AXIS_LENGTH * k;
    let ox = (panel.x + panel.w) as f32 - 62.0 * k;
    let oy = (panel.y + panel.h) as f32 - 62.0 * k;
    // Axes along the line of sight are drawn as symbols in a row left of the arrows.
    let mut symbol_x = ox - 58.0 * k;
    let axes = [
        ("X", DVec3::X, GREY),
        ("Y", DVec3::Y, GREY),
        ("Z", DVec3::Z, GREY),
        ("D", scene.frame.d, INK),
    ];
    let mut marks = Vec::with_capacity(axes.len());
    for (name, a, colour) in axes {
        let sx = a.dot(right) as f32;
        let sy = -a.dot(up) as f32;
        let along = (sx * sx + sy * sy).sqrt();
        let width = if name == "D" { 2.4 * k } else { 1.6 * k };
        if along < 0.2 {
            marks.push(AxisMark::Symbol {
                name,
                colour,
                width,
                at: [symbol_x, oy],
                toward: a.dot(toward) > 0.0,
            });
            symbol_x -= 40.0 * k;
        } else {
            marks.push(AxisMark::Arrow {
                name,
                colour,
                width,
                from: [ox, oy],
                to: [ox + sx * length, oy + sy * length],
                unit: [sx / along, sy / along],
            });
        }
    }
    marks
}

/// The box [x0, y0, x1, y1] the axes of [`axis_marks`] and their names cover, with a margin
/// of a few pixels: the part is kept out of it ([`fit_camera`]).
fn axes_box(marks: &[AxisMark], k: f32) -> [f64; 4] {
    let mut b = [
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    let mut grow = |[x0, y0, x1, y1]: [f32; 4]| {
        b = [b[0].min(x0), b[1].min(y0), b[2].max(x1), b[3].max(y1)];
    };
    let label = axis_label_style(k);
    for m in marks {
        match *m {
            AxisMark::Symbol {
                name, at: [x, y], ..
            } => {
                let r = AXIS_SYMBOL_R * k;
                grow([x - r, y - r, x + r, y + r]);
                let [tx, ty] = symbol_label_at([x, y], k);
                grow(text_box(tx, ty, name, &label, Align::Left));
            }
            AxisMark::Arrow {
                name,
                from,
                to,
                unit,
                ..
            } => {
                grow([from[0], from[1], from[0], from[1]]);
                grow([to[0], to[1], to[0], to[1]]);
                let [tx, ty] = arrow_label_at(to, unit, k);
                grow(text_box(tx, ty, name, &label, Align::Centre));
            }
        }
    }
    let pad = 8.0 * k;
    [b[0] - pad, b[1] - pad, b[2] + pad, b[3] + pad].map(f64::from)
}

/// The style of the axes' names.
fn axis_label_style(k: f32) -> TextStyle {
    TextStyle::new(13.0 * k, INK).bold().halo(VIEW_BACKGROUND)
}

/// Where an axis symbol's name is written (left-aligned, its baseline), beside it.
fn symbol_label_at([x, y]: [f32; 2], k: f32) -> [f32; 2] {
    [x + AXIS_SYMBOL_R * k + 3.0 * k, y + 5.0 * k]
}

/// Where an arrow's name is written (centred, its baseline), beyond its head.
fn arrow_label_at(to: [f32; 2], [ux, uy]: [f32; 2], k: f32) -> [f32; 2] {
    [to[0] + ux * 12.0 * k, to[1] + uy * 12.0 * k + 5.0 * k]
}

/// World axes X, Y, Z and the demolding direction D, as seen by the view.
fn draw_axes(canvas: &mut Canvas, scene: &Scene, view: &View, k: f32) {
    let cam = &view.camera;
    let label = axis_label_style(k);
    for mark in axis_marks(scene, (cam.right, cam.up, cam.toward), view.panel, k) {
        match mark {
            AxisMark::Symbol {
                name,
                colour,
                width,
                at: [cx, cy],
                toward,
            } => {
                let r = AXIS_SYMBOL_R * k;
                canvas.stroke_circle(cx, cy, r, colour, width * 0.8);
                if toward {
                    canvas.fill_circle(cx, cy, 1.8 * k, colour);
                } else {
                    let d = r * 0.7;
                    canvas.stroke_polyline(
                        &[[cx - d, cy - d], [cx + d, cy + d]],
                        false,
                        colour,
                        width * 0.7,
                        None,
                    );
                    canvas.stroke_polyline(
                        &[[cx - d, cy + d], [cx + d, cy - d]],
                        false,
                        colour,
                        width * 0.7,
                        None,
                    );
                }
                let [tx, ty] = symbol_label_at([cx, cy], k);
                canvas.text(tx, ty, name, &label, Align::Left);
            }
            AxisMark::Arrow {
                name,
                colour,
                width,
                from: [ox, oy],
                to: [ex, ey],
                unit: [ux, uy],
            } => {
                canvas.stroke_polyline(&[[ox, oy], [ex, ey]], false, colour, width, None);
                let head = AXIS_HEAD * k;
                canvas.fill_polygon(
                    &[
                        [ex + ux * head * 0.6, ey + uy * head * 0.6],
                        [
                            ex - ux * head * 0.5 - uy * head * 0.45,
                            ey - uy * head * 0.5 + ux * head * 0.45,
                        ],
                        [
                            ex - ux * head * 0.5 + uy * head * 0.45,
                            ey - uy * head * 0.5 - ux * head * 0.45,
                        ],
                    ],
                    colour,
                    255,
                );
                let [tx, ty] = arrow_label_at([ex, ey], [ux, uy], k);
                canvas.text(tx, ty, name, &label, Align::Centre);
            }
        }
    }
}

fn draw_title(canvas: &mut Canvas, scene: &Scene, layout: &Layout, k: f32) {
    let x = 16.0 * k;
    let width = canvas.width() as f32 - 2.0 * x;
    let title = TextStyle::new(24.0 * k, INK).bold();
    let sub = TextStyle::new(16.0 * k, INK);
    let first = wrap(&scene.title, &title, width);
    canvas.text(
        x,
        32.0 * k,
        first.first().map(String::as_str).unwrap_or(""),
        &title,
        Align::Left,
    );
    let second = wrap(&scene.subtitle, &sub, width);
    canvas.text(
        x,
        layout.title_h - 16.0 * k,
        second.first().map(String::as_str).unwrap_or(""),
        &sub,
        Align::Left,
    );
}

/// The colour bar with its ticks, name and unit, and the legend of the overlays.
fn draw_side_bar(
    canvas: &mut Canvas,
    scene: &Scene,
    layout: &Layout,
    range: &FieldRange,
    lut: &Lut,
    k: f32,
) {
    let x = layout.side_x;
    let mut y = layout.title_h + 24.0 * k;
    let head = TextStyle::new(16.0 * k, INK).bold();
    // "Height along D (mm)", but "Fill time (estimate), in s": not two brackets running on.
    let name = if scene.field.unit.is_empty() {
        scene.field.name.clone()
    } else if scene.field.name.contains('(') {
        format!("{}, in {}", scene.field.name, scene.field.unit)
    } else {
        format!("{} ({})", scene.field.name, scene.field.unit)
    };
    let name = capitalised(&name);
    for line in wrap(&name, &head, layout.side_w) {
        canvas.text(x, y, &line, &head, Align::Left);
        y += 21.0 * k;
    }
    y += 6.0 * k;
    let bar_w = 28.0 * k;
    let bar_h = 300.0 * k;
    let label = TextStyle::new(14.0 * k, INK);
    match range.min_max {
        None => {
            canvas.text(x, y + 14.0 * k, "no values", &label, Align::Left);
            y += 30.0 * k;
        }
        Some((lo, hi)) => {
            let rows = bar_h.round() as u32;
            for i in 0..rows {
                // Top of the bar is the largest value.
                let t = 1.0 - (i as f32 + 0.5) / rows as f32;
                let c = if hi > lo { lut.rgb(t) } else { lut.rgb(0.5) };
                canvas.fill_rect(x, y + i as f32, bar_w, 1.0, c, 255);
            }
            canvas.stroke_rect(x, y, bar_w, bar_h, INK, 1.0);
            let (lo, hi) = (lo as f64, hi as f64);
            let ticks: Vec<(f64, f64)> = if hi > lo {
                let step = nice_below((hi - lo) / 4.0);
                let first = (lo / step).ceil() * step;
                let mut v = first;
                let mut out = Vec::new();
                while v <= hi + step * 1e-9 && out.len() < 20 {
                    out.push((v, step));
                    v += step;
                }
                out
            } else {
                vec![(lo, lo.abs().max(1e-3) / 100.0)]
            };
            for (v, step) in ticks {
                let f = if hi > lo { (v - lo) / (hi - lo) } else { 0.5 };
                let ty = y + bar_h * (1.0 - f as f32);
                canvas.stroke_polyline(
                    &[[x + bar_w, ty], [x + bar_w + 6.0 * k, ty]],
                    false,
                    INK,
                    1.4 * k,
                    None,
                );
                canvas.text(
                    x + bar_w + 10.0 * k,
                    ty + 5.0 * k,
                    &format_step(v, step),
                    &label,
                    Align::Left,
                );
            }
            y += bar_h + 14.0 * k;
            // Cells beyond the span: said under the bar, with their largest value.
            if let Some(top) = range.beyond {
                let unit = if scene.field.unit.is_empty() {
                    String::new()
                } else {
                    format!(" {}", scene.field.unit)
                };
                let words = format!(
                    "colours stop at the 99th percentile of the cells: the last 1 % reach up to {}{unit} (the top colour)",
                    crate::report::three_figures(f64::from(top))
                );
                for line in wrap(&words, &label, layout.side_w) {
                    canvas.text(x, y + 12.0 * k, &line, &label, Align::Left);
                    y += 18.0 * k;
                }
                y += 6.0 * k;
            }
        }
    }
    if scene.node_field.is_some() {
        canvas.text(
            x,
            y + 12.0 * k,
            "lower is better (dark blue)",
            &label,
            Align::Left,
        );
        y += 22.0 * k;
    }
    if range.has_missing {
        canvas.fill_rect(x, y, bar_w, 14.0 * k, NO_VALUE_COLOUR, 255);
        canvas.text(
            x + bar_w + 10.0 * k,
            y + 12.0 * k,
            if scene.node_field.is_some() {
                "not a qualifying node"
            } else {
                "no value"
            },
            &label,
            Align::Left,
        );
        y += 24.0 * k;
    }

    // Legend.
    y += 20.0 * k;
    canvas.text(x, y, "Legend", &head, Align::Left);
    y += 14.0 * k;
    let row = 30.0 * k;
    let sx = x + 14.0 * k; // swatch centre
    let tx = x + 36.0 * k;
    let cy = |y: f32| y + row / 2.0;

    let item = |canvas: &mut Canvas, y: &mut f32, text: &str, draw: &dyn Fn(&mut Canvas, f32)| {
        draw(canvas, cy(*y));
        let lines = wrap(text, &label, layout.side_w - 36.0 * k);
        for (i, line) in lines.iter().enumerate() {
            canvas.text(
                tx,
                cy(*y) + 5.0 * k + i as f32 * 17.0 * k,
                line,
                &label,
                Align::Left,
            );
        }
        *y += row + (lines.len().max(1) - 1) as f32 * 17.0 * k;
    };
    match scene.gates.first() {
        Some(g) => {
            let mut gate_text = format!("gate, disc of R = {:.3} mm", g.radius_mm);
            if scene.gates.iter().any(|g| g.body.is_some()) {
                gate_text +=
                    "; a gate of body N: that body's own gate, from which the picture fills it";
            }
            item(canvas, &mut y, &gate_text, &|c, cy| {
                let r = 8.0 * k;
                c.stroke_circle(sx, cy, r, BLACK, 4.5 * k);
                c.stroke_circle(sx, cy, r, WHITE, 2.5 * k);
                c.fill_circle(sx, cy, r, GATE_COLOUR);
            });
        }
        // No disc is drawn: the swatch is an empty, struck-out circle, not a gate's.
        None => item(
            canvas,
            &mut y,
            "no gate: no node passes the rules (the report says why)",
            &|c, cy| {
                let r = 8.0 * k;
                c.stroke_circle(sx, cy, r, INK, 1.5 * k);
                let d = r * std::f32::consts::FRAC_1_SQRT_2;
                c.stroke_polyline(
                    &[[sx - d, cy + d], [sx + d, cy - d]],
                    false,
                    INK,
                    1.5 * k,
                    None,
                );
            },
        ),
    }
    if !scene.placed.is_empty() {
        item(
            canvas,
            &mut y,
            "your gate (placed): disc outline; diamond filled if it qualifies",
            &|c, cy| {
                let r = 9.0 * k;
                c.stroke_circle(sx, cy, r, BLACK, 5.0 * k);
                c.stroke_circle(sx, cy, r, PLACED_COLOUR, 3.0 * k);
                placed::draw_diamond(c, sx, cy, 5.0 * k, true, k);
            },
        );
    }
    item(canvas, &mut y, "centre of mass", &|c, cy| {
        draw_centre_symbol(c, sx, cy, 12.0 * k, k);
    });
    item(canvas, &mut y, "parting line", &|c, cy| {
        let pts = [[sx - 13.0 * k, cy], [sx + 13.0 * k, cy]];
        c.stroke_polyline(&pts, false, BLACK, 4.5 * k, None);
        c.stroke_polyline(&pts, false, WHITE, 2.0 * k, None);
    });
    item(canvas, &mut y, "parting line, hidden", &|c, cy| {
        let pts = [[sx - 13.0 * k, cy], [sx + 13.0 * k, cy]];
        c.stroke_polyline(&pts, false, GREY, 1.2 * k, Some([5.0 * k, 4.0 * k]));
    });
    if !scene.keep_out.is_empty() {
        item(
            canvas,
            &mut y,
            "keep-out region (no gate disc reaches into it)",
            &|c, cy| {
                let pts = [
                    [sx - 12.0 * k, cy - 8.0 * k],
                    [sx + 12.0 * k, cy - 8.0 * k],
                    [sx + 12.0 * k, cy + 8.0 * k],
                    [sx - 12.0 * k, cy + 8.0 * k],
                ];
                c.stroke_polyline(&pts, true, WHITE, 4.0 * k, None);
                c.stroke_polyline(&pts, true, BLACK, 2.0 * k, Some([7.0 * k, 5.0 * k]));
            },
        );
    }
    let qualifying = if scene.node_field.is_some() {
        format!(
            "qualifying region ({} grid nodes), each coloured by its score",
            scene.qualifying.len()
        )
    } else {
        format!("qualifying region ({} grid nodes)", scene.qualifying.len())
    };
    item(canvas, &mut y, &qualifying, &|c, cy| {
        let (w, h) = ((26.0 * k) as i32, (18.0 * k) as i32);
        let (x0, y0) = ((sx - 13.0 * k) as i32, (cy - 9.0 * k) as i32);
        // The hatch is white stripes with a dark edge over whatever colour the part has
        // there: shown over a dark and a light colour of the map, as on the part.
        let half = (w / 2) as f32;
        c.fill_rect(x0 as f32, y0 as f32, half, h as f32, lut.rgb(0.1), 255);
        c.fill_rect(
            x0 as f32 + half,
            y0 as f32,
            w as f32 - half,
            h as f32,
            lut.rgb(0.9),
            255,
        );
        for yy in 0..h {
            for xx in 0..w {
                let edge = xx == 0 || yy == 0 || xx + 1 == w || yy + 1 == h;
                let (px, py) = (x0 + xx, y0 + yy);
                if edge {
                    c.blend(px, py, BLACK, 0.85);
                } else if let Some((col, a)) = hatch(xx as usize, yy as usize) {
                    c.blend(px, py, col, a);
                }
            }
        }
    });
    item(
        canvas,
        &mut y,
        "scale bars: mm in the picture plane",
        &|c, cy| {
            let t = 5.0 * k;
            let pts = [
                [sx - 13.0 * k, cy - t],
                [sx - 13.0 * k, cy],
                [sx + 13.0 * k, cy],
                [sx + 13.0 * k, cy - t],
            ];
            c.stroke_polyline(&pts, false, INK, 2.0 * k, None);
        },
    );
}

fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbouring_node_squares_leave_no_pixel_between_them() {
        // Nodes a spacing apart whose squares' edges fall on pixels' halves (the grid
        // centred on a symmetric part), and at other phases; the centres computed as a
        // projection does, so an edge may be an ulp either side of the half.
        for (spacing, phase) in [(3.0, 0.5), (2.5, 0.25), (4.14, 0.0), (1.0, 0.5), (7.0, 0.5)] {
            let half = 0.5 * spacing;
            for start in [10.0, 10.1, 333.3] {
                let centres: Vec<f64> = (0..60)
                    .map(|k| (start + phase + k as f64 * spacing) * 0.1 * 10.0)
                    .collect();
                for pair in centres.windows(2) {
                    let (a, b) = (
                        square_span(pair[0], half, 2000),
                        square_span(pair[1], half, 2000),
                    );
                    assert!(b.0 <= a.1, "{pair:?}: {a:?} then {b:?}");
                    assert!(
                        a.1 - b.0 <= 1,
                        "{pair:?}: {a:?} and {b:?} overlap by more than a pixel"
                    );
                }
            }
        }
        // The split the rounding of each side made: one edge an ulp short of a pixel's
        // half (11.5), the neighbour's on it; rounded, pixel 11 belonged to neither.
        let (a, b) = (
            square_span(10.0 - 1e-12, 1.5, 100),
            square_span(13.0, 1.5, 100),
        );
        assert!(b.0 <= a.1, "{a:?} then {b:?}");
        // Clamped to the panel, never reversed.
        assert_eq!(square_span(-5.0, 1.5, 100), (0, 0));
        assert_eq!(square_span(99.5, 1.5, 100), (98, 100));
        assert_eq!(square_span(200.0, 1.5, 100), (100, 100));
    }

    #[test]
    fn the_part_is_kept_out_of_the_axes_box() {
        let area = [24.0, 64.0, 600.0, 700.0];
        let avoid = [500.0, 700.0, 700.0, 900.0];
        // The part's box in pixels for (scale, centre).
        let drawn = |span: DVec2, (scale, c): (f64, DVec2)| {
            let half = span * scale * 0.5;
            [c.x - half.x, c.y - half.y, c.x + half.x, c.y + half.y]
        };
        let inside = |b: [f64; 4]| {
            b[0] >= area[0] - 1e-9
                && b[1] >= area[1] - 1e-9
                && b[2] <= area[0] + area[2] + 1e-9
                && b[3] <= area[1] + area[3] + 1e-9
        };
        let clear = |b: [f64; 4]| b[2] <= avoid[0] + 1e-9 || b[3] <= avoid[1] + 1e-9;
        // Fits the width with 50 px to spare above and below, and reaches 14 px into the
        // box: it moves up by those 14 px, at full size.
        let wide = DVec2::new(100.0, 100.0);
        let (scale, c) = clear_of(wide, area, avoid);
        assert_eq!(scale, 6.0);
        let b = drawn(wide, (scale, c));
        assert!(inside(b) && clear(b), "{b:?}");
        assert!(
            (b[3] - avoid[1]).abs() < 1e-9,
            "moved up by the least: {b:?}"
        );
        // Square, filling the area's width and most of its height: no room to move, so it
        // is drawn smaller, beside the box.
        let square = DVec2::new(100.0, 110.0);
        let (scale, c) = clear_of(square, area, avoid);
        assert!(scale < 6.0, "{scale}");
        let b = drawn(square, (scale, c));
        assert!(inside(b) && clear(b), "{b:?}");
        // A small part in the middle stays where it is.
        let small = DVec2::new(10.0, 10.0);
        assert_eq!(
            clear_of(small, area, [650.0, 760.0, 700.0, 900.0]),
            (60.0, DVec2::new(324.0, 414.0))
        );
    }

    #[test]
    fn a_gate_label_moves_off_the_centre_of_mass_and_other_labels() {
        // watchy_yatari_bottom's isometric view: the gate's usual place (upper right of the
        // disc) lies on the arm of the centre-of-mass cross.
        let k = 1.0;
        let style = TextStyle::new(15.0, GATE_COLOUR).bold();
        let (gate, r) = ([500.0f32, 500.0f32], 8.0f32);
        let usual = text_box(
            gate[0] + r + 12.0,
            gate[1] - r - 8.0,
            "gate",
            &style,
            Align::Left,
        );
        let mid = (usual[1] + usual[3]) / 2.0;
        let cross = [usual[0] - 10.0, mid - 3.0, usual[2] + 10.0, mid + 3.0];
        let other = [usual[0], usual[3] + 10.0, usual[2], usual[3] + 60.0];
        let taken = [cross, other];
        let inside = [0.0, 0.0, 1000.0, 1000.0];
        let (x, y, align, _) = gate_label_place(gate, r, "gate", &style, &taken, inside, k, &[]);
        let placed = text_box(x, y, "gate", &style, align);
        for t in &taken {
            assert!(!overlaps(&placed, t), "{placed:?} overlaps {t:?}");
        }
        let disc = [gate[0] - r, gate[1] - r, gate[0] + r, gate[1] + r];
        assert!(!overlaps(&placed, &disc));
        // With nothing in the way the label keeps its usual place.
        let (x, y, _, _) = gate_label_place(gate, r, "gate", &style, &[], inside, k, &[]);
        assert_eq!((x, y), (gate[0] + r + 12.0, gate[1] - r - 8.0));
    }

    #[test]
    fn a_gate_label_goes_nearer_its_own_gate_than_a_neighbour() {
        // The heatbed clip's layout seen along D: gate 4's disc sits up and right of gate
        // 1's, where gate 1's label usually goes.
        let k = 1.0;
        let style = TextStyle::new(15.0, GATE_COLOUR).bold();
        let (gate, r) = ([300.0f32, 300.0f32], 24.0f32);
        let neighbour = [gate[0] + 2.0 * r + 20.0, gate[1] - 2.0 * r - 10.0];
        let inside = [0.0, 0.0, 1000.0, 1000.0];
        let disc = |c: [f32; 2]| [c[0] - r, c[1] - r, c[0] + r, c[1] + r];
        let taken = [disc(gate), disc(neighbour)];
        // Alone, the usual place (upper right) is nearer the neighbour.
        let usual = text_box(
            gate[0] + r + 12.0,
            gate[1] - r - 8.0,
            "gate 1",
            &style,
            Align::Left,
        );
        assert!(box_distance(&usual, neighbour) < box_distance(&usual, gate));
        let (x, y, align, own) =
            gate_label_place(gate, r, "gate 1", &style, &taken, inside, k, &[neighbour]);
        let placed = text_box(x, y, "gate 1", &style, align);
        assert!(own);
        assert!(
            box_distance(&placed, gate) < box_distance(&placed, neighbour),
            "{placed:?}"
        );
        assert!(taken.iter().all(|t| !overlaps(&placed, t)));
    }

    #[test]
    fn the_centre_label_moves_off_a_gate_disc_beside_the_cross() {
        // The plate's two gates seen along D: gate 1's disc lies where the centre's label
        // usually goes, lower left of the cross.
        let k = 1.0;
        let style = TextStyle::new(13.0, INK);
        let (c, reach) = ([600.0f32, 500.0f32], 13.0f32);
        let label = "centre of mass (hidden)";
        let usual = text_box(c[0] - reach - 6.0, c[1] + 18.0, label, &style, Align::Right);
        let disc = [
            usual[0] + 20.0,
            usual[1] - 5.0,
            usual[0] + 40.0,
            usual[1] + 15.0,
        ];
        let arms = [
            [c[0] - reach, c[1] - 3.0, c[0] + reach, c[1] + 3.0],
            [c[0] - 3.0, c[1] - reach, c[0] + 3.0, c[1] + reach],
        ];
        let taken = [arms[0], arms[1], disc];
        let inside = [0.0, 0.0, 1200.0, 1000.0];
        let (x, y, align) = centre_label_place(c, reach, label, &style, &taken, inside, k);
        let placed = text_box(x, y, label, &style, align);
        for t in &taken {
            assert!(!overlaps(&placed, t), "{placed:?} overlaps {t:?}");
        }
        // With only the cross, the label keeps its usual place.
        let (x, y, align) = centre_label_place(c, reach, label, &style, &arms, inside, k);
        assert_eq!(
            (x, y, align),
            (c[0] - reach - 6.0, c[1] + 18.0, Align::Right)
        );
    }

    /// A gate seen face on is its circle; seen edge on (on a wall along the view) it is
    /// widened to an ellipse 3 px across each way, not left a sliver.
    #[test]
    fn a_gate_seen_edge_on_is_drawn_as_a_narrow_disc_not_a_sliver() {
        let cam = Camera {
            right: DVec3::X,
            up: DVec3::Y,
            toward: DVec3::Z,
            centre: DVec2::ZERO,
            scale: 5.0,
            origin: DVec2::new(400.0, 300.0),
        };
        let extent = |normal: DVec3| {
            let g = crate::scene::Marker {
                point: DVec3::ZERO,
                normal,
                radius_mm: 1.5,
                body: None,
            };
            let (outline, r) = gate_outline(&cam, &g);
            let d: Vec<f32> = outline
                .iter()
                .map(|p| (p[0] - 400.0).hypot(p[1] - 300.0))
                .collect();
            (
                r,
                d.iter().copied().fold(f32::INFINITY, f32::min),
                d.iter().copied().fold(0.0, f32::max),
            )
        };
        let (r, least, most) = extent(DVec3::Z);
        assert!((r - 7.5).abs() < 1e-3 && (least - 7.5).abs() < 0.01 && (most - 7.5).abs() < 0.01);
        for normal in [DVec3::X, DVec3::Y, DVec3::new(1.0, 0.0, 0.02).normalize()] {
            let (r, least, most) = extent(normal);
            assert!((r - 7.5).abs() < 1e-3, "{normal}: {r}");
            assert!(
                (least - 3.0).abs() < 0.01 && (most - 7.5).abs() < 0.01,
                "{normal}: {least} {most}"
            );
        }
    }

    #[test]
    fn nice_numbers() {
        assert_eq!(nice_below(7.3), 5.0);
        assert_eq!(nice_below(3.0), 2.0);
        assert_eq!(nice_below(1.0), 1.0);
        assert!((nice_below(0.072) - 0.05).abs() < 1e-12);
        assert_eq!(nice_below(260.0), 200.0);
        assert_eq!(format_step(20.0, 20.0), "20");
        assert_eq!(format_step(0.05, 0.05), "0.05");
        assert_eq!(format_step(-0.0, 0.5), "0.0");
        assert_eq!(format_step(12.5, 2.5), "12.5");
    }

    #[test]
    fn pieces_of_a_line_are_chained_and_straight_runs_lose_their_inner_points() {
        // Three pieces of one path, one of them reversed, and a separate piece.
        let pieces = vec![
            vec![[0.0, 0.0], [1.0, 0.0]],
            vec![[3.0, 0.0], [2.0, 0.0], [1.0, 0.0]],
            vec![[3.0, 0.0], [3.0, 4.0]],
            vec![[10.0, 10.0], [11.0, 11.0]],
        ];
        let lines = chained(pieces);
        assert_eq!(lines.len(), 2);
        let long = lines
            .iter()
            .find(|l| l.len() == 5)
            .expect("the joined path");
        let ends = [long[0], long[4]];
        assert!(
            ends.contains(&[0.0, 0.0]) && ends.contains(&[3.0, 4.0]),
            "{long:?}"
        );
        // The collinear points go; the corner stays.
        let s = simplified(long, 0.1);
        assert_eq!(s.len(), 3, "{s:?}");
        assert!(s.contains(&[3.0, 0.0]));
        // A bump of 0.05 px is within the tolerance, one of 0.5 px is not.
        let bumpy = [[0.0, 0.0], [5.0, 0.05], [10.0, 0.0]];
        assert_eq!(simplified(&bumpy, 0.1).len(), 2);
        let bent = [[0.0, 0.0], [5.0, 0.5], [10.0, 0.0]];
        assert_eq!(simplified(&bent, 0.1).len(), 3);
    }

    #[test]
    fn field_range_maps_to_unit_interval_and_keeps_missing_values() {
        let r = FieldRange::of(&[2.0, f32::NAN, 4.0, 3.0]);
        assert_eq!(r.min_max, Some((2.0, 4.0)));
        assert!(r.has_missing);
        assert_eq!(r.unit(3.0), 0.5);
        assert!(r.unit(f32::NAN).is_nan());
        let constant = FieldRange::of(&[1.0, 1.0]);
        assert_eq!(constant.unit(1.0), 0.5);
        assert!(FieldRange::of(&[f32::NAN]).min_max.is_none());
    }

    #[test]
    fn the_gate_colour_is_not_in_the_colour_map() {
        let lut = Lut::viridis();
        for e in lut.0 {
            let d: f32 = e
                .iter()
                .zip(GATE_COLOUR)
                .map(|(a, b)| (a - b as f32).abs())
                .sum();
            assert!(d > 150.0, "{e:?}");
        }
    }

    #[test]
    fn the_placed_gate_colour_is_not_in_the_colour_map_nor_the_gate_colour() {
        let lut = Lut::viridis();
        let far = |a: [f32; 3], b: [u8; 3]| -> f32 {
            a.iter().zip(b).map(|(a, b)| (a - b as f32).abs()).sum()
        };
        for e in lut.0 {
            assert!(far(e, PLACED_COLOUR) > 150.0, "{e:?}");
        }
        assert!(far(GATE_COLOUR.map(f32::from), PLACED_COLOUR) > 150.0);
    }

    #[test]
    fn isometric_axes_are_right_handed_with_d_up() {
        let part = crate::mesh::from_generated(crate::samples::sample("plate").unwrap());
        let analysis = crate::locate(&part, &crate::LocateOptions::default()).unwrap();
        let scene = Scene::new(&part.mesh, &analysis, "plate");
        for kind in [ViewKind::AlongDemold, ViewKind::Isometric] {
            let (r, u, t) = axes(&scene, kind);
            assert!((r.cross(u) - t).length() < 1e-12, "{kind:?}");
            assert!(u.dot(scene.frame.d) > 0.5 || kind == ViewKind::AlongDemold);
            assert!(t.dot(scene.frame.d) > 0.0, "{kind:?} sees the +D side");
        }
    }
}
