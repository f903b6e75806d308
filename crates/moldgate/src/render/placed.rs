//! The gates the designer placed (`gate_at`) on the picture: the outline of each disc of
//! radius R_gate in [`PLACED_COLOUR`], unfilled so that the field shows through, with a
//! diamond at its centre (filled when the gate qualifies, hollow when it fails a rule) and
//! a label, so they are never mistaken for the answer's red discs.

use super::canvas::{text_width, Align, Canvas, Rgb, TextStyle};
use super::{gate_outline, View, BLACK, WHITE};
use crate::scene::Scene;

/// Colour of the designer's gates: no colour of the colour map, and far from the answer's
/// red.
pub const PLACED_COLOUR: [u8; 3] = [240, 0, 200];

/// The diamond at a placed gate's centre: filled when it qualifies.
pub(super) fn draw_diamond(canvas: &mut Canvas, x: f32, y: f32, size: f32, filled: bool, k: f32) {
    let pts = [[x, y - size], [x + size, y], [x, y + size], [x - size, y]];
    canvas.stroke_polyline(&pts, true, BLACK, 4.0 * k, None);
    canvas.stroke_polyline(&pts, true, WHITE, 2.4 * k, None);
    if filled {
        canvas.fill_polygon(&pts, PLACED_COLOUR, 255);
    } else {
        canvas.stroke_polyline(&pts, true, PLACED_COLOUR, 1.6 * k, None);
    }
}

/// Draws every placed gate of `scene` in `view`.
pub(super) fn draw_placed(canvas: &mut Canvas, scene: &Scene, view: &View, k: f32) {
    let cam = &view.camera;
    let colour: Rgb = PLACED_COLOUR;
    for (i, g) in scene.placed.iter().enumerate() {
        let (outline, r) = gate_outline(cam, &g.marker);
        let p = cam.to_pixel(g.marker.point);
        let (x, y) = (p.x as f32, p.y as f32);
        canvas.stroke_polyline(&outline, true, BLACK, 5.0 * k, None);
        canvas.stroke_polyline(&outline, true, colour, 3.0 * k, None);
        draw_diamond(canvas, x, y, 7.0 * k, g.qualifies, k);
        let label = format!(
            "your gate {}{}",
            i + 1,
            if g.qualifies { "" } else { " (fails)" }
        );
        let style = TextStyle::new(15.0 * k, colour).bold().halo(WHITE);
        // Beside the disc, on the side that keeps the label inside the panel.
        let right_edge = (view.panel.x + view.panel.w) as f32 - 8.0 * k;
        let fits_right = x + r + 12.0 * k + text_width(&label, &style) < right_edge;
        let (tx, align) = if fits_right {
            (x + r + 12.0 * k, Align::Left)
        } else {
            (x - r - 12.0 * k, Align::Right)
        };
        canvas.text(tx, y + r + 20.0 * k, &label, &style, align);
    }
}
