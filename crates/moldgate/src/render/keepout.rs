//! The designer's keep-out regions on the picture: each region's outline in the view (a
//! sphere's circle, a box's projected hull) dashed in black over white, clipped to the
//! panel, with its number, so the nodes it took out of the qualifying region are seen as
//! taken by it and not by a rule of the paper.

use super::canvas::{Canvas, TextStyle};
use super::raster::Camera;
use super::{text_box, LabelBox, BLACK, INK, WHITE};
use crate::keepout::Region;
use crate::math::DVec3;

/// Points of a sphere's outline.
const CIRCLE_POINTS: usize = 96;

/// The region's outline in the view, in pixels: closed (the last point is the first).
fn outline(cam: &Camera, region: &Region) -> Vec<[f32; 2]> {
    let mut points: Vec<[f32; 2]> = match *region {
        Region::Sphere { centre, radius } => {
            let c = cam.to_pixel(DVec3::from_array(centre));
            let r = radius * cam.scale;
            (0..CIRCLE_POINTS)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / CIRCLE_POINTS as f64;
                    [(c.x + r * a.cos()) as f32, (c.y + r * a.sin()) as f32]
                })
                .collect()
        }
        Region::Box { min, max } => {
            let corners: Vec<[f32; 2]> = Region::box_corners(min, max)
                .iter()
                .map(|&p| {
                    let q = cam.to_pixel(p);
                    [q.x as f32, q.y as f32]
                })
                .collect();
            hull(corners)
        }
    };
    if let Some(&first) = points.first() {
        points.push(first);
    }
    points
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain).
fn hull(mut points: Vec<[f32; 2]>) -> Vec<[f32; 2]> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let cross = |o: [f32; 2], a: [f32; 2], b: [f32; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut lower: Vec<[f32; 2]> = Vec::new();
    for &p in &points {
        while lower.len() >= 2 && cross(lower[lower.len() - 2], lower[lower.len() - 1], p) <= 0.0 {
            lower.pop();
        }
        lower.push(p);
    }
    let mut upper: Vec<[f32; 2]> = Vec::new();
    for &p in points.iter().rev() {
        while upper.len() >= 2 && cross(upper[upper.len() - 2], upper[upper.len() - 1], p) <= 0.0 {
            upper.pop();
        }
        upper.push(p);
    }
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// The part of the segment a-b inside `rect` (x0, y0, x1, y1), by Liang and Barsky's
/// clipping; `None` when none is.
fn clip(a: [f32; 2], b: [f32; 2], rect: LabelBox) -> Option<([f32; 2], [f32; 2])> {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for (p, q) in [
        (-dx, a[0] - rect[0]),
        (dx, rect[2] - a[0]),
        (-dy, a[1] - rect[1]),
        (dy, rect[3] - a[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
            continue;
        }
        let t = q / p;
        if p < 0.0 {
            t0 = t0.max(t);
        } else {
            t1 = t1.min(t);
        }
        if t0 > t1 {
            return None;
        }
    }
    let at = |t: f32| [a[0] + t * dx, a[1] + t * dy];
    Some((at(t0), at(t1)))
}

/// The runs of the closed outline `points` inside `rect`, as polylines.
fn runs_inside(points: &[[f32; 2]], rect: LabelBox) -> Vec<Vec<[f32; 2]>> {
    let mut runs: Vec<Vec<[f32; 2]>> = Vec::new();
    let mut open = false;
    for w in points.windows(2) {
        match clip(w[0], w[1], rect) {
            Some((p, q)) => {
                // A run goes on while each clipped segment starts where the last ended.
                match runs.last_mut() {
                    Some(run) if open && run.last() == Some(&p) => run.push(q),
                    _ => runs.push(vec![p, q]),
                }
                open = q == w[1];
            }
            None => open = false,
        }
    }
    runs
}

/// Draws every keep-out region of the view's camera `cam`, clipped to `panel`, below the
/// panel's titles (`titles` pixels from its top); returns the labels' boxes (taken from the
/// gates' labels after them). A label goes above the outline's highest point, or below its
/// lowest when that one would cover a mark of `avoid` (the centre of mass, the gates).
pub(super) fn draw_keep_outs(
    canvas: &mut Canvas,
    cam: &Camera,
    regions: &[Region],
    (panel, titles): (LabelBox, f32),
    avoid: &[[f32; 2]],
    k: f32,
) -> Vec<LabelBox> {
    use super::canvas::Align;
    let style = TextStyle::new(13.0 * k, INK).bold().halo(WHITE);
    let dash = Some([7.0 * k, 5.0 * k]);
    let below_titles = [panel[0], panel[1] + titles, panel[2], panel[3]];
    let clear = |b: &LabelBox| {
        let m = 14.0 * k;
        !avoid
            .iter()
            .any(|p| p[0] > b[0] - m && p[0] < b[2] + m && p[1] > b[1] - m && p[1] < b[3] + m)
    };
    let mut labels = Vec::new();
    for (i, region) in regions.iter().enumerate() {
        let points = outline(cam, region);
        let runs = runs_inside(&points, panel);
        canvas.stroke_polylines(&runs, false, WHITE, 4.0 * k, None);
        canvas.stroke_polylines(&runs, false, BLACK, 2.0 * k, dash);
        let label = format!("keep-out {}", i + 1);
        let inside: Vec<[f32; 2]> = runs_inside(&points, below_titles)
            .into_iter()
            .flatten()
            .collect();
        let top = inside.iter().copied().min_by(|a, b| a[1].total_cmp(&b[1]));
        let bottom = inside.iter().copied().max_by(|a, b| a[1].total_cmp(&b[1]));
        let places = [
            top.map(|[x, y]| (x, y - 5.0 * k)),
            bottom.map(|[x, y]| (x, y + 17.0 * k)),
        ];
        let boxes: Vec<(f32, f32, LabelBox)> = places
            .into_iter()
            .flatten()
            .map(|(x, y)| {
                let y = y.clamp(below_titles[1] + 13.0 * k, panel[3] - 4.0 * k);
                (x, y, text_box(x, y, &label, &style, Align::Centre))
            })
            .collect();
        if let Some(&(x, y, b)) = boxes.iter().find(|(_, _, b)| clear(b)).or(boxes.first()) {
            canvas.text(x, y, &label, &style, Align::Centre);
            labels.push(b);
        }
    }
    labels
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hull of a box's projected corners holds them all, and the clipped runs of an
    /// outline stay inside the panel and join where the outline is inside.
    #[test]
    fn outlines_are_hulls_clipped_to_the_panel() {
        let square = hull(vec![
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0, 10.0],
            [0.0, 10.0],
            [5.0, 5.0],
            [5.0, 0.0],
        ]);
        assert_eq!(square.len(), 4, "{square:?}");
        let mut closed = square.clone();
        closed.push(square[0]);
        // Wholly inside: one run, the whole outline.
        let runs = runs_inside(&closed, [-1.0, -1.0, 11.0, 11.0]);
        assert_eq!(runs.len(), 1, "{runs:?}");
        assert_eq!(runs[0].len(), 5);
        // Half outside: every point inside the panel.
        let runs = runs_inside(&closed, [-1.0, -1.0, 5.0, 11.0]);
        assert!(!runs.is_empty());
        for p in runs.iter().flatten() {
            assert!(p[0] <= 5.0 + 1e-4 && p[0] >= -1.0, "{p:?}");
        }
        // Wholly outside: nothing.
        assert!(runs_inside(&closed, [20.0, 20.0, 30.0, 30.0]).is_empty());
    }
}
