//! The gate-suitability map: for every qualifying node, how good a gate it would be, as the
//! objective of the balanced gate (L_max, or the largest fill-order value) of a gate there.
//!
//! **Exact and bounded scores.** The objective of a node c is its eccentricity
//! e(c) = max_x d(c, x) over the cells of its body, where d is the arrival value of the
//! march ([`super::march`]). One march from c gives e(c) exactly; a march per node (the
//! brute force) would cost thousands of marches. Since d is a distance (symmetric, and it
//! keeps the triangle inequality), one march from any cell s, whose own eccentricity e(s)
//! it gives too, bounds every node at once:
//!
//! - lower: e(c) >= d(s, c) (s is a point the melt must reach) and e(c) >= e(s) - d(s, c)
//!   (the point farthest from s is at most d(s, c) + e(c) from s);
//! - upper: e(c) <= e(s) + d(s, c) (any point is at most d(c, s) + e(s) from c).
//!
//! Over the marches run, each node keeps the largest lower bound and the smallest upper
//! bound. A node marched from is exact. The marches alternate between the node of least
//! lower bound that is not yet exact (so the best region is exact, as the balanced search
//! proves its gate; each body's in turn on a part of several bodies, whose scores compare
//! within a body only) and the node of widest gap (its field gives upper bounds near it), each
//! followed by a march from the farthest cell of that node's field (a far point: the
//! farthest cells of neighbouring nodes are mostly the same few extremes of the part, so
//! far points raise the lower bounds of whole regions). The map stops when every node is
//! exact to the tolerance or the budget of marches is spent.
//!
//! **Score.** The score of a node is its exact value, or its lower bound (with its upper
//! bound stated beside it): a lower bound from far points is usually within a few percent
//! of the truth (the gap against brute force is measured in `docs/suitability.md`), while
//! the upper bound of the triangle inequality is loose far from the nodes marched from.
//!
//! **Discretisation.** The march is first-order fast marching, not exactly symmetric:
//! d(s, c) from a march at s and d(c, s) from a march at c differ by up to about a cell.
//! Every march here starts at a cell centre (like the balanced search's), and the bounds
//! hold to that tolerance (one cell, in the objective's units).
//!
//! **Cost.** In the fill analysis, at most twice the marches of the balanced search (and
//! at most [`MAX_RUNS`]), that many for each body holding nodes (marches times solid cells within
//! [`super::FlowOptions::max_march_cells`], checked before the work), two at a time on two
//! threads, plus one pass over the nodes per march. Marches already made by the fill
//! analysis (the paper gate's field, and the balanced gate's, exact for its node) are used
//! as free sources, so the best node is exact from the start when the balanced search
//! proved its gate.

use rayon::prelude::*;
use serde::Serialize;

use super::{argmax, march, Domain, Field, FillError, Objective, Source};
use crate::math::DVec3;

/// Most marches the map runs for each body holding nodes (beyond the fields given to it),
/// whatever the budget asked.
pub const MAX_RUNS: usize = 40;

/// Whether a node's score is its exact value or a lower bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ScoreKind {
    /// The objective of a gate at the node, from a march at it.
    Exact,
    /// A lower bound from the marches of other cells; the node's `upper` bounds it above.
    LowerBound,
}

/// The score of one qualifying node.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NodeScore {
    /// Index of the node among the analysis's qualifying points.
    pub node: usize,
    /// Its point on the part's surface, mm.
    pub point: [f64; 3],
    /// The body its cell belongs to (numbered as the fill's bodies, from 0): a gate fills
    /// only its own body, so scores compare within one body.
    pub body: u32,
    /// The objective of a gate there (lower is better): L_max in mm, or the fill time in s.
    pub score: f64,
    /// An upper bound of the objective (equal to `score` for exact nodes; `None` when no
    /// march reached the node's body).
    pub upper: Option<f64>,
    /// Whether `score` is exact or a lower bound.
    pub kind: ScoreKind,
}

/// The gate-suitability map of the qualifying nodes.
#[derive(Debug, Clone, Serialize)]
pub struct Suitability {
    /// What the scores are: the objective of the balanced gate.
    pub objective: Objective,
    /// Unit of the scores: `mm` (L_max) or `s` (fill time).
    pub unit: &'static str,
    /// Tolerance of the scores (one flow cell, in the objective's unit): bounds hold to it,
    /// and a node is exact when its bounds are within it.
    pub tolerance: f64,
    /// Every qualifying node on the voxelised part, in the order of the qualifying points.
    pub nodes: Vec<NodeScore>,
    /// Index in `nodes` of the best node (least score; exact unless the budget ran out).
    pub best: Option<usize>,
    /// Index in `nodes` of the best node of each body, by body number (`None` for a body
    /// without a scored node): on a part of several bodies each node is scored by the fill
    /// of its own body, so scores compare only within a body (see [`Suitability::spans_bodies`]).
    pub best_per_body: Vec<Option<usize>>,
    /// Nodes whose score is exact.
    pub exact: usize,
    /// Largest gap between a node's upper bound and its score, over its score, percent
    /// (`None` when a node has no upper bound).
    pub max_gap_pct: Option<f64>,
    /// Median of that gap, percent.
    pub median_gap_pct: Option<f64>,
    /// Qualifying nodes with no solid cell near them, left out.
    pub off_part: usize,
    /// Marches the map ran (beyond the fields given to it).
    pub runs: usize,
}

impl Suitability {
    /// Each body's best node, with the body's name in words ("body 1"), for the bodies
    /// that have a scored node, in body order.
    pub fn body_bests(&self) -> impl Iterator<Item = (String, &NodeScore)> {
        self.best_per_body
            .iter()
            .enumerate()
            .filter_map(|(body, best)| Some((super::body_name(body as u32), &self.nodes[(*best)?])))
    }

    /// Whether the scored nodes lie on more than one body. Each node is scored by the fill of
    /// its own body, so a small body's nodes score better than a large one's whatever their
    /// place: the scores then compare only within a body.
    pub fn spans_bodies(&self) -> bool {
        self.nodes.windows(2).any(|w| w[0].body != w[1].body)
    }

    /// The best node's score in words with its unit (`58.9 mm`). When the map's runs ran out
    /// before that score was proven (a lower bound), it says so with the node's upper
    /// bound: a lower bound is not a value a gate there is known to reach.
    pub fn best_value_text(&self) -> Option<String> {
        Some(self.score_text(&self.nodes[self.best?]))
    }

    /// A node's score in words with its unit, said as a lower bound with its upper bound
    /// when it is one (as [`Suitability::best_value_text`]): each body's best on a part of
    /// several bodies is said so.
    pub fn score_text(&self, n: &NodeScore) -> String {
        let value = |x: f64| format!("{} {}", self.objective.value_text(x), self.unit);
        match n.kind {
            ScoreKind::Exact => value(n.score),
            ScoreKind::LowerBound => format!(
                "at least {} (a lower bound: the map's runs ended before a march at this node; {})",
                value(n.score),
                n.upper.map_or("no upper bound".to_string(), |u| format!(
                    "at most {}",
                    value(u)
                ))
            ),
        }
    }
}

/// Bounds of the nodes of one unique cell.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    lo: f64,
    hi: f64,
    exact: bool,
}

/// A field already marched with the objective's cost, and the cell of the node it is the
/// field of (within the tolerance), if any.
#[derive(Debug, Clone, Copy)]
pub struct Given<'a> {
    /// The field.
    pub field: &'a Field,
    /// The cell of the node it was marched from, when it was marched from a node.
    pub node_cell: Option<u32>,
}

/// The map of the nodes at `points` (the qualifying points) for `objective`. `given` are
/// fields already marched (free sources). At most `max_runs` marches more are run (and at
/// most [`MAX_RUNS`]) for each body holding nodes; the fill analysis gives twice the
/// balanced search's runs. `scale`
/// turns the arrival values into the reported unit (1 for mm, seconds per mm for the fill
/// time); `tolerance` is in arrival units (the cell side). Refused before the work when the
/// marches would visit more than `max_march_cells` cells.
#[allow(clippy::too_many_arguments)]
pub fn suitability(
    domain: &Domain,
    points: &[DVec3],
    objective: Objective,
    given: &[Given],
    max_runs: usize,
    scale: f64,
    tolerance: f64,
    max_march_cells: f64,
) -> Result<Suitability, FillError> {
    let v = &domain.voxels;
    let cost = domain.cost(objective);
    // Nodes by their cell; nodes sharing a cell share its bounds.
    let sources: Vec<Option<Source>> = points.iter().map(|&p| domain.source(p)).collect();
    // Each body holding nodes has its own best to refine (scores compare within a body),
    // so the budget is a body's: a second body's best does not take the first's marches.
    let mut bodies_with_nodes: Vec<u32> = sources
        .iter()
        .flatten()
        .map(|s| domain.body[s.cell as usize])
        .collect();
    bodies_with_nodes.sort_unstable();
    bodies_with_nodes.dedup();
    let max_runs = max_runs.min(MAX_RUNS) * bodies_with_nodes.len().max(1);
    let work = v.len() as f64 * max_runs as f64;
    if work > max_march_cells {
        return Err(FillError::too_large(
            "cell visits of the suitability map",
            work,
            max_march_cells,
            v.h,
            3.0,
        ));
    }
    let mut cells: Vec<u32> = sources.iter().flatten().map(|s| s.cell).collect();
    cells.sort_unstable();
    cells.dedup();
    let slot = |cell: u32| cells.binary_search(&cell).expect("a node's cell");
    let mut bounds = vec![
        Bounds {
            lo: 0.0,
            hi: f64::INFINITY,
            exact: false,
        };
        cells.len()
    ];
    let update = |bounds: &mut [Bounds], field: &Field, at: Option<u32>| {
        let (_, e) = argmax(&field.t);
        for (b, &c) in bounds.iter_mut().zip(&cells) {
            let d = field.t[c as usize];
            if d.is_finite() {
                b.lo = b.lo.max(d).max(e - d);
                b.hi = b.hi.min(e + d);
            }
        }
        if let Some(i) = at.and_then(|c| cells.binary_search(&c).ok()) {
            let b = &mut bounds[i];
            *b = Bounds {
                lo: e,
                hi: e,
                exact: true,
            };
        }
    };
    for g in given {
        update(&mut bounds, g.field, g.node_cell);
    }
    let centred = |c: u32| Source {
        point: v.centre(c),
        cell: c,
    };
    let mut used = vec![false; v.len()];
    let mut far: Vec<u32> = given.iter().map(|g| argmax(&g.field.t).0).collect();
    // Scores compare within a body only (a march reaches its own body), so each body's best
    // is refined in turn: the best of a small body must not keep a large body's best at a
    // lower bound.
    let cell_body: Vec<u32> = cells.iter().map(|&c| domain.body[c as usize]).collect();
    let bodies = cell_body.iter().max().map_or(0, |&b| b as usize + 1);
    let mut runs = 0;
    let mut refine_best = true;
    let mut turn = 0;
    while runs < max_runs {
        let open = |b: &Bounds| !b.exact && b.hi - b.lo > tolerance;
        let by_lo = |a: &usize, b: &usize| bounds[*a].lo.total_cmp(&bounds[*b].lo).then(a.cmp(b));
        let least_in = |body: usize, open_only: bool| {
            (0..cells.len())
                .filter(|&i| cell_body[i] as usize == body && (!open_only || open(&bounds[i])))
                .min_by(by_lo)
        };
        let order = || (0..bodies).map(|k| (turn + k) % bodies);
        // The node to march from: least lower bound (a body whose best is not yet exact
        // first, the bodies in turn), or widest gap, in turn.
        let pick = |best: bool| {
            if best {
                order()
                    .find(|&b| least_in(b, false).is_some_and(|i| open(&bounds[i])))
                    .and_then(|b| least_in(b, true))
                    .or_else(|| order().filter_map(|b| least_in(b, true)).min_by(by_lo))
            } else {
                (0..cells.len())
                    .filter(|&i| open(&bounds[i]))
                    .min_by(|&a, &b| {
                        let gap = |i: usize| -(bounds[i].hi - bounds[i].lo);
                        gap(a).total_cmp(&gap(b)).then(a.cmp(&b))
                    })
            }
        };
        // Each body's best node first until it is exact and no open node of its body could
        // beat it.
        let best_exact = order().all(|b| least_in(b, false).is_none_or(|i| !open(&bounds[i])));
        let node = pick(refine_best || !best_exact).or_else(|| pick(true));
        refine_best = !refine_best;
        if let Some(i) = node {
            turn = (cell_body[i] as usize + 1) % bodies.max(1);
        }
        let mut batch: Vec<u32> = Vec::new();
        if let Some(i) = node {
            batch.push(cells[i]);
        }
        while let Some(f) = far.pop() {
            if !used[f as usize] && !batch.contains(&f) {
                batch.push(f);
                break;
            }
        }
        if batch.is_empty() {
            break;
        }
        batch.truncate(max_runs - runs);
        for &c in &batch {
            used[c as usize] = true;
        }
        let fields: Vec<Field> = batch
            .par_iter()
            .map(|&c| march(v, &[centred(c)], cost))
            .collect();
        runs += fields.len();
        for (field, &c) in fields.iter().zip(&batch) {
            let is_node = cells.binary_search(&c).is_ok();
            update(&mut bounds, field, is_node.then_some(c));
            if is_node {
                far.push(argmax(&field.t).0);
            }
        }
    }
    let mut off_part = 0;
    let nodes: Vec<NodeScore> = sources
        .iter()
        .zip(points)
        .enumerate()
        .filter_map(|(node, (s, p))| {
            let Some(s) = s else {
                off_part += 1;
                return None;
            };
            let b = bounds[slot(s.cell)];
            let exact = b.exact || b.hi - b.lo <= tolerance;
            Some(NodeScore {
                node,
                point: p.to_array(),
                body: domain.body[s.cell as usize],
                score: b.lo * scale,
                upper: if exact {
                    Some(b.lo * scale)
                } else {
                    Some(b.hi * scale).filter(|u| u.is_finite())
                },
                kind: if exact {
                    ScoreKind::Exact
                } else {
                    ScoreKind::LowerBound
                },
            })
        })
        .collect();
    let best =
        (0..nodes.len()).min_by(|&a, &b| nodes[a].score.total_cmp(&nodes[b].score).then(a.cmp(&b)));
    let mut gaps: Vec<f64> = nodes
        .iter()
        .map(|n| match n.upper {
            Some(u) if n.score > 0.0 => 100.0 * (u - n.score) / n.score,
            Some(_) => 0.0,
            None => f64::INFINITY,
        })
        .collect();
    gaps.sort_by(f64::total_cmp);
    let finite = |x: &f64| x.is_finite().then_some(*x);
    Ok(Suitability {
        objective,
        unit: match objective {
            Objective::Length => "mm",
            Objective::Resistance => "s",
        },
        tolerance: tolerance * scale,
        exact: nodes.iter().filter(|n| n.kind == ScoreKind::Exact).count(),
        max_gap_pct: gaps.last().map_or(Some(0.0), finite),
        median_gap_pct: gaps.get(gaps.len() / 2).map_or(Some(0.0), finite),
        best_per_body: best_per_body(&nodes),
        nodes,
        best,
        off_part,
        runs,
    })
}

/// The node of least score of each body (an index in `nodes`; the first of equal scores),
/// indexed by body; `None` for a body without a scored node.
fn best_per_body(nodes: &[NodeScore]) -> Vec<Option<usize>> {
    let bodies = nodes.iter().map(|n| n.body as usize + 1).max();
    let mut best: Vec<Option<usize>> = vec![None; bodies.unwrap_or(0)];
    for (i, n) in nodes.iter().enumerate() {
        let b = &mut best[n.body as usize];
        if b.is_none_or(|j| n.score < nodes[j].score) {
            *b = Some(i);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_best_score_left_at_a_lower_bound_is_said_to_be_one() {
        let node = |score: f64, upper: Option<f64>, kind| NodeScore {
            node: 0,
            point: [0.0; 3],
            body: 0,
            score,
            upper,
            kind,
        };
        let mut map = Suitability {
            objective: Objective::Length,
            unit: "mm",
            tolerance: 0.5,
            nodes: vec![node(58.94, Some(60.89), ScoreKind::LowerBound)],
            best: Some(0),
            best_per_body: vec![Some(0)],
            exact: 0,
            max_gap_pct: Some(3.3),
            median_gap_pct: Some(3.3),
            off_part: 0,
            runs: 40,
        };
        assert_eq!(
            map.best_value_text().unwrap(),
            "at least 58.9 mm (a lower bound: the map's runs ended before a march at this node; at most 60.9 mm)"
        );
        map.nodes[0] = node(59.76, Some(59.76), ScoreKind::Exact);
        assert_eq!(map.best_value_text().unwrap(), "59.8 mm");
        map.best = None;
        assert_eq!(map.best_value_text(), None);
    }
}
