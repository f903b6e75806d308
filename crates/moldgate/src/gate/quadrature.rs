//! The nodal quadrature: a regular grid of nodes over the part's projected bounding box.

use serde::Serialize;

use crate::error::OptionsError;
use crate::math::DVec2;

/// How the grid spacing is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Spacing {
    /// `min(R_gate, longest side of the projected box / 100)`; see [`auto_spacing`].
    #[default]
    Auto,
    /// A fixed spacing in millimetres.
    Mm(f64),
}

/// The default spacing rule.
///
/// The paper sets the grid's accuracy to the part's smallest relevant detail. For a gate, the
/// smallest relevant detail is the gate itself: a face narrower than the gate's diameter cannot
/// seat it, so a spacing of at most `R_gate` puts a node within reach of every place the disc
/// fits. The bound of 1/100 of the longest projected side keeps at least 100 nodes across
/// the part when the gate is large for it, so small parts get a fine grid too.
pub fn auto_spacing(box_size: DVec2, gate_radius_mm: f64) -> f64 {
    gate_radius_mm.min(box_size.max_element() / 100.0)
}

/// A regular grid of nodes in the projection plane, centred in the projected box.
///
/// Node (iu, iw) has index `iw * n_u + iu` and sits at `first + spacing * (iu, iw)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Grid {
    /// Projected box, low corner (u, w).
    pub box_lo: [f64; 2],
    /// Projected box, high corner (u, w).
    pub box_hi: [f64; 2],
    /// Distance between neighbouring nodes in mm.
    pub spacing: f64,
    /// Shift of the grid as a fraction of the spacing, along both u and w.
    pub offset: f64,
    /// Position (u, w) of node 0.
    pub first: [f64; 2],
    /// Nodes along u.
    pub n_u: usize,
    /// Nodes along w.
    pub n_w: usize,
}

impl Grid {
    /// Lays the grid over the box `lo`..`hi`: `n = floor(span / spacing) + 1` nodes along each
    /// axis, centred in the box, then shifted by `offset * spacing`. Refuses grids of more
    /// than `max_nodes` nodes.
    pub fn new(
        lo: DVec2,
        hi: DVec2,
        spacing: f64,
        offset: f64,
        max_nodes: usize,
    ) -> Result<Grid, OptionsError> {
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(OptionsError::NonPositive {
                option: "spacing",
                value: spacing,
            });
        }
        if !(offset.is_finite() && offset.abs() < 1.0) {
            return Err(OptionsError::GridOffset(offset));
        }
        let span = hi - lo;
        let count = |s: f64| (s / spacing + 1e-9).floor() + 1.0;
        let (nu, nw) = (count(span.x), count(span.y));
        if nu * nw > max_nodes as f64 {
            return Err(OptionsError::GridTooLarge {
                spacing_mm: spacing,
                n_u: nu as u64,
                n_w: nw as u64,
                nodes: (nu * nw) as u64,
                limit: max_nodes as u64,
                min_spacing_mm: least_spacing(span, max_nodes),
            });
        }
        let (n_u, n_w) = (nu as usize, nw as usize);
        let used = DVec2::new((n_u - 1) as f64, (n_w - 1) as f64) * spacing;
        let first = lo + (span - used) * 0.5 + DVec2::splat(offset * spacing);
        Ok(Grid {
            box_lo: lo.to_array(),
            box_hi: hi.to_array(),
            spacing,
            offset,
            first: first.to_array(),
            n_u,
            n_w,
        })
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.n_u * self.n_w
    }

    /// True when the grid has no node (never, for a grid made by [`Grid::new`]).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Column and row of node `i`.
    pub fn coords(&self, i: usize) -> (usize, usize) {
        (i % self.n_u, i / self.n_u)
    }

    /// Position (u, w) of node `i`.
    pub fn node(&self, i: usize) -> DVec2 {
        let (iu, iw) = self.coords(i);
        DVec2::from_array(self.first) + DVec2::new(iu as f64, iw as f64) * self.spacing
    }
}

/// The smallest spacing whose grid over a box of `span` has at most `max_nodes` nodes:
/// nodes ~ (su/h + 1)(sw/h + 1) <= max, with a margin of 1e-4 for the rounding.
pub(crate) fn least_spacing(span: DVec2, max_nodes: usize) -> f64 {
    let (su, sw, m) = (span.x, span.y, max_nodes as f64);
    let a = m - 1.0;
    let b = -(su + sw);
    let c = -su * sw;
    let h = (-b + (b * b - 4.0 * a * c).sqrt()) / (2.0 * a);
    h * 1.0001
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_centred_and_counts_nodes() {
        let g = Grid::new(DVec2::ZERO, DVec2::new(100.0, 60.0), 1.0, 0.0, 1 << 20).unwrap();
        assert_eq!((g.n_u, g.n_w), (101, 61));
        assert_eq!(g.node(0), DVec2::ZERO);
        assert_eq!(g.node(g.len() - 1), DVec2::new(100.0, 60.0));
        // A span that is not a multiple of the spacing leaves equal margins.
        let g = Grid::new(DVec2::ZERO, DVec2::new(10.5, 3.0), 1.0, 0.0, 1 << 20).unwrap();
        assert_eq!(g.n_u, 11);
        assert!((g.first[0] - 0.25).abs() < 1e-12);
        let g = Grid::new(DVec2::ZERO, DVec2::new(10.0, 3.0), 1.0, 0.37, 1 << 20).unwrap();
        assert!((g.first[0] - 0.37).abs() < 1e-12);
    }

    #[test]
    fn refuses_grids_over_the_limit_with_a_spacing_that_fits() {
        let err = Grid::new(DVec2::ZERO, DVec2::new(100.0, 100.0), 0.01, 0.0, 1_000_000);
        let Err(OptionsError::GridTooLarge { min_spacing_mm, .. }) = err else {
            panic!("expected GridTooLarge, got {err:?}");
        };
        let g = Grid::new(
            DVec2::ZERO,
            DVec2::new(100.0, 100.0),
            min_spacing_mm,
            0.0,
            1_000_000,
        );
        assert!(g.is_ok(), "{g:?}");
        assert!(Grid::new(DVec2::ZERO, DVec2::ONE, 0.0, 0.0, 10).is_err());
        assert!(Grid::new(DVec2::ZERO, DVec2::ONE, f64::NAN, 0.0, 10).is_err());
    }

    #[test]
    fn auto_spacing_is_the_gate_radius_or_a_hundredth_of_the_part() {
        assert_eq!(auto_spacing(DVec2::new(200.0, 50.0), 1.4), 1.4);
        assert_eq!(auto_spacing(DVec2::new(66.0, 61.0), 1.4), 0.66);
    }
}
