//! The gates the designer placed (`gate_at`) on the picture: the outline of each disc of
//! radius R_gate in [`PLACED_COLOUR`], unfilled so that the field shows through, with a
//! diamond at its centre (filled when the gate qualifies, hollow when it fails a rule) and
//! a label, so they are never mistaken for the answer's red discs.

use super::canvas::{Canvas, Rgb, TextStyle};
use super::{draw_leader, gate_label_place, text_box, Disc, LabelBox, BLACK, WHITE};
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

/// Draws every placed gate of `scene`, their discs in the view `discs` (in the order of
/// `scene.placed`). A gate the view cannot see (the part hides its point, or its face is
/// turned away) is drawn dashed and labelled "(hidden)", as the answer's gates are. Each
/// label goes where [`gate_label_place`] puts the answer's: clear of what is `taken` (the
/// discs, the labels so far, which it joins) and nearer its own gate than the answer's
/// gates (`answer`) and the other placed ones, with a leader when it cannot be.
pub(super) fn draw_placed(
    canvas: &mut Canvas,
    scene: &Scene,
    discs: &[Disc],
    (taken, inside, answer): (&mut Vec<LabelBox>, LabelBox, &[[f32; 2]]),
    k: f32,
) {
    let colour: Rgb = PLACED_COLOUR;
    let style = TextStyle::new(15.0 * k, colour).bold().halo(WHITE);
    for (i, (g, d)) in scene.placed.iter().zip(discs).enumerate() {
        let ([x, y], r) = (d.at, d.r);
        let dash = d.hidden.then_some([4.0 * k, 3.0 * k]);
        canvas.stroke_polyline(&d.outline, true, BLACK, 5.0 * k, dash);
        canvas.stroke_polyline(&d.outline, true, colour, 3.0 * k, dash);
        draw_diamond(canvas, x, y, 7.0 * k, g.qualifies, k);
        let notes: Vec<&str> = [(!g.qualifies, "fails"), (d.hidden, "hidden")]
            .into_iter()
            .filter_map(|(on, note)| on.then_some(note))
            .collect();
        let label = match notes.is_empty() {
            true => format!("your gate {}", i + 1),
            false => format!("your gate {} ({})", i + 1, notes.join(", ")),
        };
        let others: Vec<[f32; 2]> = answer
            .iter()
            .copied()
            .chain(
                discs
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, o)| o.at),
            )
            .collect();
        let (tx, ty, align, own) =
            gate_label_place([x, y], r, &label, &style, taken, inside, k, &others);
        let b = text_box(tx, ty, &label, &style, align);
        if !own {
            draw_leader(canvas, &b, [x, y], k);
        }
        canvas.text(tx, ty, &label, &style, align);
        taken.push(b);
    }
}
