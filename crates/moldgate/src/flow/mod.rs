//! Fill analysis: how far the melt travels from a gate, where it arrives last, where fronts
//! meet, what pressure it needs (the paper's Eq. 1), and the gate that shortens the worst
//! path (the balanced gate) or several gates that share the part.
//!
//! **Model.** The part is voxelised ([`voxel`]): the solid cells of its inside plus the cells
//! its surface passes through. The melt flows from cell to cell, never through air; parts of
//! the mesh that touch no common cell are separate bodies, and a gate fills only its own.
//! Arrival fields are marched over the cells ([`march`]): the flow length is the length of
//! the shortest path through the solid; the fill order weights each millimetre by the flow
//! resistance of the wall it crosses.
//!
//! **Resistance (derivation).** In a slit of thickness H, a power-law melt (index n,
//! consistency K) has a mean velocity
//! v = n / (2n + 1) (H / 2)^((n+1)/n) (|dp/ds| / K)^(1/n).
//! Under the same pressure gradient a front therefore moves at a speed proportional to
//! H^((n+1)/n), and the time to cross ds is proportional to H^(-(n+1)/n) ds. The fill-order
//! cost of a millimetre is (H_ref / H)^((n+1)/n), with H_ref the nominal wall: for a
//! Newtonian melt (n = 1) that is the 1/H^2 of Eq. 1; for the paper's materials (n about
//! 0.2-0.3) the exponent is 4-6, so thin walls hold the front back much more strongly.
//!
//! **Pressure.** Eq. 1, ΔP = 12 μ L v / H^2, taken along the path with the local H:
//! ΔP(x) = 12 μ v ∫ ds / H(s)^2 = 12 μ v T_2(x) / H_ref^2, where T_2 is the field with cost
//! (H_ref / H)^2. The estimate is its largest value over the part, with μ = mu_opt and v from
//! Eq. 7.

pub mod march;
pub mod voxel;

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::material::Material;
use crate::math::DVec3;
use crate::mesh::Mesh;
use crate::raycast::Bvh;
pub use march::{march, Field, Source};
pub use voxel::Voxels;

/// What the balanced gate minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Objective {
    /// The largest flow length L_max.
    #[default]
    Length,
    /// The largest fill-order value (flow length weighted by the wall's resistance).
    Resistance,
}

/// Options of the fill analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct FlowOptions {
    /// Cell side in mm; `None` chooses it from the part (see [`cell_size`]).
    pub cell_mm: Option<f64>,
    /// Largest dense grid, in cells. Default 24 million (about 100 MB of index).
    pub max_cells: f64,
}

impl Default for FlowOptions {
    fn default() -> Self {
        FlowOptions {
            cell_mm: None,
            max_cells: 24.0e6,
        }
    }
}

/// The cell side: half the nominal wall (a wall is two cells across, and the surface cells
/// add about one more), at most 1/120 of the part's diagonal, and no finer than `max_cells`
/// allows.
pub fn cell_size(mesh: &Mesh, nominal_wall_mm: f64, options: &FlowOptions) -> f64 {
    let bounds = mesh.bounds();
    let h = options
        .cell_mm
        .unwrap_or_else(|| (nominal_wall_mm / 2.0).min(bounds.diagonal() / 120.0));
    // The grid's cell count falls as h^-3.
    let n = Voxels::cells_for(&bounds, h);
    if n > options.max_cells {
        h * (n / options.max_cells).cbrt() * 1.01
    } else {
        h
    }
}

/// The voxelised part with its wall thickness and the costs of the three fields.
#[derive(Debug, Clone)]
pub struct Domain {
    /// The solid cells.
    pub voxels: Voxels,
    /// Connected component (body) of each cell.
    pub body: Vec<u32>,
    /// Number of bodies.
    pub bodies: usize,
    /// Nominal wall thickness H_ref, mm.
    pub nominal_wall_mm: f64,
    /// Wall thickness per cell, mm.
    pub wall_mm: Vec<f32>,
    /// Fill-order cost per cell: (H_ref / H)^((n+1)/n).
    pub fill_cost: Vec<f32>,
    /// Eq. 1 cost per cell: (H_ref / H)^2.
    pub pressure_cost: Vec<f32>,
    /// Power-law index n used for the fill cost.
    pub n: f64,
}

impl Domain {
    /// Voxelises `mesh` at `h` mm. `triangle_wall_mm` gives the wall thickness of each
    /// triangle (NaN where unknown); cells take the thickness of their triangle, and unknown
    /// values take the nominal wall. The thickness is clamped to [h, 100 H_ref] so costs
    /// stay finite.
    pub fn new(
        mesh: &Mesh,
        h: f64,
        triangle_wall_mm: Option<&[f32]>,
        nominal_wall_mm: f64,
        material: &Material,
    ) -> Domain {
        Domain::from_voxels(
            Voxels::new(mesh, h),
            triangle_wall_mm,
            nominal_wall_mm,
            material,
        )
    }

    /// [`Domain::new`] on cells already made.
    pub fn from_voxels(
        voxels: Voxels,
        triangle_wall_mm: Option<&[f32]>,
        nominal_wall_mm: f64,
        material: &Material,
    ) -> Domain {
        let h = voxels.h;
        let (body, bodies) = voxels.components();
        let lo = h.min(nominal_wall_mm);
        let wall_mm: Vec<f32> = voxels
            .triangle
            .iter()
            .map(|&t| {
                let w = triangle_wall_mm
                    .and_then(|w| w.get(t as usize).copied())
                    .map(f64::from)
                    .filter(|w| w.is_finite() && *w > 0.0)
                    .unwrap_or(nominal_wall_mm);
                w.clamp(lo, 100.0 * nominal_wall_mm) as f32
            })
            .collect();
        let n = material.n;
        let exponent = (n + 1.0) / n;
        let cost = |p: f64| -> Vec<f32> {
            wall_mm
                .iter()
                .map(|&w| (nominal_wall_mm / w as f64).powf(p) as f32)
                .collect()
        };
        Domain {
            fill_cost: cost(exponent),
            pressure_cost: cost(2.0),
            voxels,
            body,
            bodies,
            nominal_wall_mm,
            wall_mm,
            n,
        }
    }

    /// The source at a surface point, or `None` when no solid cell is near it.
    pub fn source(&self, point: DVec3) -> Option<Source> {
        self.voxels
            .cell_near(point)
            .map(|cell| Source { point, cell })
    }

    /// The cost array of an objective.
    pub fn cost(&self, objective: Objective) -> Option<&[f32]> {
        match objective {
            Objective::Length => None,
            Objective::Resistance => Some(&self.fill_cost),
        }
    }
}

/// A point and the value of a field there.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PointValue {
    /// Position, mm.
    pub point: [f64; 3],
    /// Flow length from the gate, mm.
    pub flow_length_mm: f64,
}

/// A place where two melt fronts meet head on, an estimate of a weld line.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WeldLine {
    /// A representative point (the cell of the group nearest its mean), mm.
    pub point: [f64; 3],
    /// Cells in the group.
    pub cells: usize,
    /// Extent of the group (largest distance from the representative point), mm.
    pub extent_mm: f64,
    /// Flow length there, mm.
    pub flow_length_mm: f64,
    /// Mean angle between the meeting fronts, degrees (180: head on).
    pub meeting_angle_deg: f64,
}

/// The fill from one gate.
#[derive(Debug, Clone, Serialize)]
pub struct GateFill {
    /// The gate, mm.
    pub gate: [f64; 3],
    /// The body it feeds (cell component number).
    pub body: u32,
    /// Share of all solid cells it reaches (below 1 when the part has several bodies).
    pub reached_share: f64,
    /// Wall thickness at the gate (of its cell), mm.
    pub wall_mm: f64,
    /// Largest flow length, mm.
    pub l_max_mm: f64,
    /// Mean flow length over the volume it reaches, mm.
    pub l_mean_mm: f64,
    /// The point reached last by flow length.
    pub farthest: [f64; 3],
    /// Largest fill-order value (mm of nominal wall).
    pub fill_max: f64,
    /// L_max over the nominal wall.
    pub flow_ratio: f64,
    /// The material's limit of that ratio, if known.
    pub flow_ratio_limit: Option<f64>,
    /// True when the ratio exceeds the limit.
    pub exceeds_flow_ratio: bool,
    /// Pressure drop to the last point by Eq. 1 along the path with local walls, MPa.
    pub pressure_mpa: f64,
    /// The last places to fill (local maxima of the fill order, highest first): air-trap
    /// candidates.
    pub last_to_fill: Vec<PointValue>,
    /// Where fronts meet head on after flowing around an obstacle.
    pub weld_lines: Vec<WeldLine>,
}

/// The fields of one gate, kept for pictures.
#[derive(Debug, Clone)]
pub struct GateFields {
    /// Flow length.
    pub length: Field,
    /// Fill order (resistance-weighted).
    pub fill: Field,
}

/// Eq. 1 pressure factor: ΔP = factor · T_2 with T_2 in mm, result in MPa.
pub fn pressure_factor_mpa_per_mm(material: &Material, nominal_wall_mm: f64) -> f64 {
    let v = material.melt_velocity_m_s();
    let h = nominal_wall_mm * 1e-3;
    // 12 mu v / H^2 in Pa per metre of path; 1e-3 m per mm; 1e-6 MPa per Pa.
    12.0 * material.mu_opt * v / (h * h) * 1e-3 * 1e-6
}

/// Analyses the fill from a gate at `point`. `None` when no solid cell is near the point.
pub fn fill_from(
    domain: &Domain,
    point: DVec3,
    material: &Material,
) -> Option<(GateFill, GateFields)> {
    let src = domain.source(point)?;
    let (length, (fill, pressure)) = rayon::join(
        || march(&domain.voxels, &[src], None),
        || {
            rayon::join(
                || march(&domain.voxels, &[src], Some(&domain.fill_cost)),
                || march(&domain.voxels, &[src], Some(&domain.pressure_cost)),
            )
        },
    );
    let v = &domain.voxels;
    let reached: Vec<u32> = (0..v.len() as u32)
        .filter(|&c| length.t[c as usize].is_finite())
        .collect();
    let (far, l_max) = argmax(&length.t);
    let l_mean = reached.iter().map(|&c| length.t[c as usize]).sum::<f64>() / reached.len() as f64;
    let fill_max = argmax(&fill.t).1;
    let p_max = argmax(&pressure.t).1;
    let flow_ratio = l_max / domain.nominal_wall_mm;
    let limit = material.max_flow_ratio;
    let gate_fill = GateFill {
        gate: point.to_array(),
        body: domain.body[src.cell as usize],
        reached_share: reached.len() as f64 / v.len() as f64,
        wall_mm: domain.wall_mm[src.cell as usize] as f64,
        l_max_mm: l_max,
        l_mean_mm: l_mean,
        farthest: v.centre(far).to_array(),
        fill_max,
        flow_ratio,
        flow_ratio_limit: limit,
        exceeds_flow_ratio: limit.is_some_and(|m| flow_ratio > m),
        pressure_mpa: p_max * pressure_factor_mpa_per_mm(material, domain.nominal_wall_mm),
        last_to_fill: last_to_fill(v, &fill.t, &length.t, 5),
        weld_lines: weld_lines(v, &length.t),
    };
    Some((gate_fill, GateFields { length, fill }))
}

/// The cell with the largest finite value and that value (lowest cell on ties).
pub fn argmax(t: &[f64]) -> (u32, f64) {
    let mut best = (0u32, f64::NEG_INFINITY);
    for (i, &x) in t.iter().enumerate() {
        if x.is_finite() && x > best.1 {
            best = (i as u32, x);
        }
    }
    best
}

/// Local maxima of `order` over the 26 neighbours, highest first, at least a tenth of the
/// largest flow length apart, at most `count` of them.
fn last_to_fill(v: &Voxels, order: &[f64], length: &[f64], count: usize) -> Vec<PointValue> {
    let offsets = voxel::neighbour_offsets();
    let mut maxima: Vec<u32> = (0..v.len() as u32)
        .filter(|&c| {
            let t = order[c as usize];
            t.is_finite()
                && offsets.iter().all(|&(o, _)| {
                    v.neighbour(c, o)
                        .is_none_or(|n| order[n as usize] <= t || !order[n as usize].is_finite())
                })
        })
        .collect();
    maxima.sort_by(|&a, &b| {
        order[b as usize]
            .total_cmp(&order[a as usize])
            .then(a.cmp(&b))
    });
    let spread = 0.1 * argmax(length).1;
    let mut out: Vec<PointValue> = Vec::new();
    for c in maxima {
        let p = v.centre(c);
        if out
            .iter()
            .all(|q| DVec3::from_array(q.point).distance(p) >= spread)
        {
            out.push(PointValue {
                point: p.to_array(),
                flow_length_mm: length[c as usize],
            });
            if out.len() == count {
                break;
            }
        }
    }
    out
}

/// The direction the front travels at each cell: the upwind gradient of T from the face
/// neighbours (unit, or zero where undefined).
fn front_direction(v: &Voxels, t: &[f64]) -> Vec<DVec3> {
    const AXES: [[i32; 3]; 3] = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    (0..v.len() as u32)
        .map(|c| {
            let tc = t[c as usize];
            if !tc.is_finite() {
                return DVec3::ZERO;
            }
            let mut g = [0.0; 3];
            for (k, axis) in AXES.iter().enumerate() {
                // The neighbour the front came from along this axis (the smaller T).
                let minus = v.neighbour(c, axis.map(|x| -x)).map(|n| t[n as usize]);
                let plus = v.neighbour(c, *axis).map(|n| t[n as usize]);
                let m = minus.unwrap_or(f64::INFINITY);
                let p = plus.unwrap_or(f64::INFINITY);
                if m < tc && m <= p {
                    g[k] = tc - m;
                } else if p < tc {
                    g[k] = -(tc - p);
                }
            }
            DVec3::from_array(g).normalize_or_zero()
        })
        .collect()
}

/// Cells where two fronts meet head on (each front travels towards the other, at more than
/// 120 degrees to each other), grouped into connected lines, largest first. Groups smaller
/// than three cells are noise of the discrete field and dropped.
fn weld_lines(v: &Voxels, t: &[f64]) -> Vec<WeldLine> {
    let dir = front_direction(v, t);
    let offsets = voxel::neighbour_offsets();
    let cos_limit = (120f64).to_radians().cos();
    let mut angle = vec![f64::NAN; v.len()];
    for c in 0..v.len() as u32 {
        let dc = dir[c as usize];
        if dc == DVec3::ZERO {
            continue;
        }
        let pc = v.centre(c);
        for &(o, _) in &offsets {
            if let Some(n) = v.neighbour(c, o) {
                let dn = dir[n as usize];
                let towards = v.centre(n) - pc;
                let cos = dc.dot(dn);
                if cos < cos_limit && dc.dot(towards) > 0.0 && dn.dot(-towards) > 0.0 {
                    let a = cos.clamp(-1.0, 1.0).acos().to_degrees();
                    if angle[c as usize].is_nan() || angle[c as usize] < a {
                        angle[c as usize] = a;
                    }
                }
            }
        }
    }
    // Group the flagged cells (26-neighbour components).
    let mut seen = vec![false; v.len()];
    let mut groups = Vec::new();
    for start in 0..v.len() as u32 {
        if seen[start as usize] || angle[start as usize].is_nan() {
            continue;
        }
        seen[start as usize] = true;
        let mut stack = vec![start];
        let mut members = Vec::new();
        while let Some(c) = stack.pop() {
            members.push(c);
            for &(o, _) in &offsets {
                if let Some(n) = v.neighbour(c, o) {
                    if !seen[n as usize] && !angle[n as usize].is_nan() {
                        seen[n as usize] = true;
                        stack.push(n);
                    }
                }
            }
        }
        if members.len() < 3 {
            continue;
        }
        let mean = members.iter().map(|&c| v.centre(c)).sum::<DVec3>() / members.len() as f64;
        let &rep = members
            .iter()
            .min_by(|&&a, &&b| {
                v.centre(a)
                    .distance_squared(mean)
                    .total_cmp(&v.centre(b).distance_squared(mean))
                    .then(a.cmp(&b))
            })
            .expect("non-empty");
        let p = v.centre(rep);
        let extent = members
            .iter()
            .map(|&c| v.centre(c).distance(p))
            .fold(0.0, f64::max);
        groups.push(WeldLine {
            point: p.to_array(),
            cells: members.len(),
            extent_mm: extent,
            flow_length_mm: t[rep as usize],
            meeting_angle_deg: members.iter().map(|&c| angle[c as usize]).sum::<f64>()
                / members.len() as f64,
        });
    }
    groups.sort_by(|a, b| {
        b.cells
            .cmp(&a.cells)
            .then(a.point[0].total_cmp(&b.point[0]))
    });
    groups.truncate(8);
    groups
}

/// The result of the balanced-gate search.
#[derive(Debug, Clone, Serialize)]
pub struct Balanced {
    /// Index of the chosen candidate in the list given.
    pub candidate: usize,
    /// Its objective value (L_max, or the largest fill-order value), mm.
    pub value: f64,
    /// The lower bound of the objective over all candidates when the search stopped.
    pub lower_bound: f64,
    /// Field runs it took.
    pub runs: usize,
    /// True when the bound proves the choice optimal (to the tolerance).
    pub proven: bool,
}

/// The candidate that minimises the largest arrival value over its body, without a run per
/// candidate.
///
/// The arrival value is a distance, so it is symmetric: the run from a far point x gives
/// d(c, x) for every candidate c at once, and max over the far points found so far is a
/// lower bound of each candidate's true worst value. The candidate with the least bound is
/// run; if its worst value equals its bound (within `tolerance`), no other candidate can do
/// better and the search stops; else its farthest points join the far points. Candidates
/// outside the body of `first` are not considered. After 40 runs the search stops unproven
/// with the best candidate it evaluated and the bound it reached (round parts, whose far
/// points are spread around a rim, need many far points).
pub fn balanced_gate(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: Source,
    tolerance: f64,
) -> Option<Balanced> {
    let start = march(&domain.voxels, &[first], domain.cost(objective));
    balanced_gate_from(domain, candidates, objective, first, &start, tolerance)
}

/// [`balanced_gate`] with the field of `first` for the objective already marched (the fill
/// analysis has it from the first gate's fill); it counts as the search's first run.
pub fn balanced_gate_from(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: Source,
    start: &Field,
    tolerance: f64,
) -> Option<Balanced> {
    let cost = domain.cost(objective);
    let v = &domain.voxels;
    let body = domain.body[first.cell as usize];
    let pool: Vec<usize> = (0..candidates.len())
        .filter(|&i| domain.body[candidates[i].cell as usize] == body)
        .collect();
    if pool.is_empty() {
        return None;
    }
    let mut runs = 1;
    let mut far = far_points(v, &start.t, FAR_POINTS);
    let mut bound = vec![0.0f64; candidates.len()];
    let max_runs = 40;
    let mut seen: Option<(f64, usize)> = None;
    loop {
        // Runs from the new far points, in parallel; each raises the bounds.
        let fields: Vec<Field> = far
            .par_iter()
            .map(|&f| {
                march(
                    v,
                    &[Source {
                        point: v.centre(f),
                        cell: f,
                    }],
                    cost,
                )
            })
            .collect();
        runs += fields.len();
        for field in &fields {
            for &i in &pool {
                bound[i] = bound[i].max(field.t[candidates[i].cell as usize]);
            }
        }
        let &best = pool
            .iter()
            .min_by(|&&a, &&b| bound[a].total_cmp(&bound[b]).then(a.cmp(&b)))
            .expect("non-empty pool");
        // Seeded at the cell centre, like the far points, so that the runs are symmetric.
        let centred = Source {
            point: v.centre(candidates[best].cell),
            cell: candidates[best].cell,
        };
        let field = march(v, &[centred], cost);
        runs += 1;
        let value = argmax(&field.t).1;
        if seen.is_none_or(|(v, _)| value < v) {
            seen = Some((value, best));
        }
        let proven = value <= bound[best] + tolerance;
        if proven || runs >= max_runs {
            // Unproven: the best candidate evaluated so far, with the bound that every
            // candidate is known to reach.
            let (value, candidate) = if proven {
                (value, best)
            } else {
                seen.expect("one run")
            };
            return Some(Balanced {
                candidate,
                value,
                lower_bound: bound[best],
                runs,
                proven,
            });
        }
        far = far_points(v, &field.t, FAR_POINTS);
    }
}

/// Far points taken from each run of the balanced search.
const FAR_POINTS: usize = 6;

/// The cell of the largest value, then other local maxima of `t` within 5 % of it and at
/// least a quarter of it away from those already taken, up to `count`.
fn far_points(v: &Voxels, t: &[f64], count: usize) -> Vec<u32> {
    let (top, max) = argmax(t);
    let mut out = vec![top];
    if count > 1 {
        let mut near_max: Vec<u32> = (0..v.len() as u32)
            .filter(|&c| t[c as usize].is_finite() && t[c as usize] >= 0.95 * max)
            .collect();
        near_max.sort_by(|&a, &b| t[b as usize].total_cmp(&t[a as usize]).then(a.cmp(&b)));
        for c in near_max {
            if out.len() == count {
                break;
            }
            let p = v.centre(c);
            if out.iter().all(|&o| v.centre(o).distance(p) >= 0.15 * max) {
                out.push(c);
            }
        }
    }
    out
}

/// One gate of a several-gate layout.
#[derive(Debug, Clone, Serialize)]
pub struct GateShare {
    /// Candidate index.
    pub candidate: usize,
    /// The gate point, mm.
    pub point: [f64; 3],
    /// Share of the reached volume this gate fills first.
    pub volume_share: f64,
    /// Largest flow value inside its share, mm.
    pub l_max_mm: f64,
}

/// Several gates that together minimise the largest arrival value (a k-centre problem).
#[derive(Debug, Clone, Serialize)]
pub struct MultiGate {
    /// The gates.
    pub gates: Vec<GateShare>,
    /// Largest arrival value with all gates open, mm.
    pub l_max_mm: f64,
    /// Smallest volume share over the largest (1: perfectly even).
    pub balance: f64,
    /// Field runs it took.
    pub runs: usize,
}

/// Places `k` gates among `candidates` (same body as `first`, which starts the layout):
/// farthest-point seeding (each new gate is the candidate nearest, along the flow, to the
/// point the current gates reach last; a 2-approximation of the k-centre optimum), then
/// rounds of local improvement in which each gate moves to the centre of its own share (the
/// candidate nearest to both ends of the share's longest path), kept only while the
/// overall worst value falls.
pub fn several_gates(
    domain: &Domain,
    candidates: &[Source],
    objective: Objective,
    first: usize,
    k: usize,
) -> Option<MultiGate> {
    let cost = domain.cost(objective);
    let v = &domain.voxels;
    let body = domain.body[candidates[first].cell as usize];
    let pool: Vec<usize> = (0..candidates.len())
        .filter(|&i| domain.body[candidates[i].cell as usize] == body)
        .collect();
    if k == 0 || pool.len() < k {
        return None;
    }
    let mut runs = 0;
    let mut chosen = vec![first];
    let mut field = march(v, &[candidates[first]], cost);
    runs += 1;
    while chosen.len() < k {
        let (far, _) = argmax(&field.t);
        let from_far = march(
            v,
            &[Source {
                point: v.centre(far),
                cell: far,
            }],
            cost,
        );
        runs += 1;
        let &next = pool
            .iter()
            .filter(|i| !chosen.contains(i))
            .min_by(|&&a, &&b| {
                from_far.t[candidates[a].cell as usize]
                    .total_cmp(&from_far.t[candidates[b].cell as usize])
                    .then(a.cmp(&b))
            })?;
        chosen.push(next);
        let sources: Vec<Source> = chosen.iter().map(|&i| candidates[i]).collect();
        field = march(v, &sources, cost);
        runs += 1;
    }
    // Local improvement: each gate to the centre of its share, kept while the overall worst
    // value falls.
    let mut worst = argmax(&field.t).1;
    for _round in 0..8 {
        let mut improved = false;
        for g in 0..k {
            let share: Vec<u32> = (0..v.len() as u32)
                .filter(|&c| field.source[c as usize] == g as u32)
                .collect();
            if share.is_empty() {
                continue;
            }
            // The share's two ends: its cell farthest from the gate, x1, and its cell
            // farthest from x1, x2. The candidate nearest to both (least of the larger
            // distance) is the centre of the share's longest path.
            let x1 = share
                .iter()
                .copied()
                .max_by(|&a, &b| {
                    field.t[a as usize]
                        .total_cmp(&field.t[b as usize])
                        .then(b.cmp(&a))
                })
                .expect("non-empty");
            let at = |c: u32| Source {
                point: v.centre(c),
                cell: c,
            };
            let from_x1 = march(v, &[at(x1)], cost);
            let x2 = share
                .iter()
                .copied()
                .filter(|&c| from_x1.t[c as usize].is_finite())
                .max_by(|&a, &b| {
                    from_x1.t[a as usize]
                        .total_cmp(&from_x1.t[b as usize])
                        .then(b.cmp(&a))
                })
                .unwrap_or(x1);
            let from_x2 = march(v, &[at(x2)], cost);
            runs += 2;
            let &try_c = pool
                .iter()
                .filter(|&&i| i == chosen[g] || !chosen.contains(&i))
                .min_by(|&&a, &&b| {
                    let f = |i: usize| {
                        let c = candidates[i].cell as usize;
                        from_x1.t[c].max(from_x2.t[c])
                    };
                    f(a).total_cmp(&f(b)).then(a.cmp(&b))
                })
                .expect("non-empty");
            if try_c == chosen[g] {
                continue;
            }
            let mut trial = chosen.clone();
            trial[g] = try_c;
            let sources: Vec<Source> = trial.iter().map(|&i| candidates[i]).collect();
            let trial_field = march(v, &sources, cost);
            runs += 1;
            let trial_worst = argmax(&trial_field.t).1;
            // Keep the move when the overall worst value does not grow and the sum of the
            // shares' worst values falls (a gate may improve its share while another
            // share still sets the overall worst).
            if trial_worst <= worst + 1e-9
                && share_sum(&trial_field, k) < share_sum(&field, k) - 1e-9
            {
                worst = trial_worst;
                chosen = trial;
                field = trial_field;
                improved = true;
            }
        }
        if !improved {
            break;
        }
    }
    let reached = field.t.iter().filter(|t| t.is_finite()).count().max(1);
    let gates: Vec<GateShare> = chosen
        .iter()
        .enumerate()
        .map(|(g, &i)| {
            let mut count = 0usize;
            let mut l_max = 0.0f64;
            for c in 0..v.len() {
                if field.source[c] == g as u32 {
                    count += 1;
                    l_max = l_max.max(field.t[c]);
                }
            }
            GateShare {
                candidate: i,
                point: candidates[i].point.to_array(),
                volume_share: count as f64 / reached as f64,
                l_max_mm: l_max,
            }
        })
        .collect();
    let shares: Vec<f64> = gates.iter().map(|g| g.volume_share).collect();
    let balance = shares.iter().copied().fold(f64::INFINITY, f64::min)
        / shares
            .iter()
            .copied()
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
    Some(MultiGate {
        gates,
        l_max_mm: worst,
        balance,
        runs,
    })
}

/// The sum over the `k` shares of a multi-source field of their largest values.
fn share_sum(field: &Field, k: usize) -> f64 {
    let mut worst = vec![0.0f64; k];
    for (t, &s) in field.t.iter().zip(&field.source) {
        if t.is_finite() && (s as usize) < k {
            worst[s as usize] = worst[s as usize].max(*t);
        }
    }
    worst.iter().sum()
}

/// Seconds per stage of the fill analysis.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct FlowTimes {
    /// Voxelising and the cost fields (without the wall measurement).
    pub voxels_s: f64,
    /// Measuring the wall thickness (one ray per surface cell).
    pub wall_s: f64,
    /// Building the ray-casting tree the wall is measured with (set by the caller, which
    /// may share the tree with other analyses; 0 when not measured).
    pub tree_s: f64,
    /// Fields from the paper gate.
    pub paper_s: f64,
    /// Balanced-gate search and its fields.
    pub balanced_s: f64,
    /// Several gates.
    pub several_s: f64,
}

/// Timer helper.
pub(crate) fn seconds(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

/// Which gate is the answer when the fill is analysed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Strategy {
    /// The paper's gate (nearest the centre of mass).
    #[default]
    Paper,
    /// The qualifying candidate that minimises the objective.
    Balanced,
}

/// Options of [`analyse`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FillOptions {
    /// Voxel resolution.
    pub flow: FlowOptions,
    /// Which gate is the answer.
    pub strategy: Strategy,
    /// What the balanced gate and several gates minimise.
    pub objective: Objective,
    /// Number of gates; 1 is the single-gate analysis.
    pub gates: usize,
}

/// The balanced gate and its fill.
#[derive(Debug, Clone, Serialize)]
pub struct BalancedFill {
    /// Its fill.
    pub fill: GateFill,
    /// The search.
    pub search: Balanced,
    /// Reduction of the objective from the paper gate, percent (>= 0).
    pub improvement_pct: f64,
    /// True when no candidate beats the paper gate by more than the discretisation, so the
    /// balanced gate is the paper gate.
    pub is_paper_gate: bool,
}

/// Where the wall thickness of the cells came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WallSource {
    /// Per-triangle wall thickness measured on the mesh.
    Measured,
    /// A uniform wall, estimated as 2 V / A (exact for a thin closed plate).
    VolumeOverArea,
}

/// Everything the fill analysis found.
#[derive(Debug, Clone, Serialize)]
pub struct FillAnalysis {
    /// Cell side, mm.
    pub cell_mm: f64,
    /// Solid cells.
    pub cells: usize,
    /// Bodies (connected groups of cells).
    pub bodies: usize,
    /// Nominal wall H_ref, mm.
    pub nominal_wall_mm: f64,
    /// Where the cell walls came from.
    pub wall_source: WallSource,
    /// The wall thickness measured for the analysis (with [`Walls::Measure`]).
    pub wall: Option<WallSummary>,
    /// What the balanced gate minimises.
    pub objective: Objective,
    /// Which gate is the answer.
    pub strategy: Strategy,
    /// Eq. 1 pressure per mm of path at the nominal wall, MPa/mm.
    pub pressure_mpa_per_mm: f64,
    /// Fill from the paper gate (the answer of `locate`: grid or aesthetic gate).
    pub paper: Option<GateFill>,
    /// Fill from the balanced gate.
    pub balanced: Option<BalancedFill>,
    /// Several gates, when more than one was asked for.
    pub several: Option<MultiGate>,
    /// Warnings of the fill analysis.
    pub warnings: Vec<String>,
    /// Seconds per stage.
    pub times: FlowTimes,
    /// Fill order of the answer's gate per mesh vertex (0 at the gate, 1 last), for pictures;
    /// with several gates, of all of them together.
    #[serde(skip)]
    pub fill_order_per_vertex: Vec<f32>,
    /// The answer's gate point.
    #[serde(skip)]
    pub answer: Option<DVec3>,
}

/// Why the fill analysis could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FillError {
    /// The analysis found no gate to start from.
    #[error("no gate to fill from: {0}")]
    NoGate(String),
    /// No solid cell near the gate.
    #[error("the gate at ({0:.3}, {1:.3}, {2:.3}) is not on the voxelised part")]
    GateOffPart(f64, f64, f64),
    /// More gates than candidates.
    #[error(
        "{asked} gates asked for, but only {available} qualifying candidates feed the gate's body"
    )]
    TooFewCandidates {
        /// Gates asked for.
        asked: usize,
        /// Candidates available.
        available: usize,
    },
    /// Bad option.
    #[error("{0}")]
    Option(String),
}

/// Where the fill analysis takes the wall thickness from.
#[derive(Debug, Clone, Copy)]
pub enum Walls<'a> {
    /// Measure it with this tree: one ray per surface cell, from the centroid of a triangle
    /// through the cell along its inverted normal ([`crate::thickness`]'s rule).
    Measure(&'a Bvh),
    /// Given per triangle (NaN where unknown), with the nominal wall.
    Given(&'a [f32], f64),
    /// A uniform wall of 2 V / A.
    Estimate,
}

/// The wall thickness seen by the fill analysis, over its samples (one per surface cell).
#[derive(Debug, Clone, Serialize)]
pub struct WallSummary {
    /// Samples measured (surface cells).
    pub samples: usize,
    /// Smallest known value, mm.
    pub min_mm: Option<f64>,
    /// 5th percentile, mm (robust to slivers at small features).
    pub p05_mm: Option<f64>,
    /// The nominal wall: median of the samples (each stands for one cell of surface), mm.
    pub nominal_mm: Option<f64>,
    /// 95th percentile, mm.
    pub p95_mm: Option<f64>,
    /// Largest known value, mm (corners, where a chord runs up a wall, read high).
    pub max_mm: Option<f64>,
    /// Share of samples with no known value (rays leaving an open mesh).
    pub unknown_share: f64,
    /// Seconds spent measuring.
    pub time_s: f64,
}

/// Runs the fill analysis of a located part: fields from the paper gate, the balanced gate
/// (always computed, so the report can compare), and several gates when asked for.
/// `triangle_wall_mm` is the measured wall per triangle when available.
pub fn analyse(
    mesh: &Mesh,
    analysis: &crate::gate::Analysis,
    material: &Material,
    walls: Walls,
    options: &FillOptions,
) -> Result<FillAnalysis, FillError> {
    let gate = analysis
        .gate()
        .map_err(|e| FillError::NoGate(e.to_string()))?
        .point();
    if let Some(h) = options.flow.cell_mm {
        if !(h.is_finite() && h > 0.0) {
            return Err(FillError::Option(format!(
                "the cell size must be a positive number, got {h}"
            )));
        }
    }
    let mut warnings = Vec::new();
    let mut times = FlowTimes::default();
    let t = Instant::now();
    let c = &analysis.centres;
    let estimate = if c.volume_mm3 > 0.0 && c.area_mm2 > 0.0 {
        2.0 * c.volume_mm3 / c.area_mm2
    } else {
        mesh.bounds().diagonal() / 100.0
    };
    let h = cell_size(
        mesh,
        match walls {
            Walls::Given(_, n) if n.is_finite() && n > 0.0 => n,
            _ => estimate,
        },
        &options.flow,
    );
    let voxels = Voxels::new(mesh, h);
    let mut measured = None;
    let (per_triangle, nominal, wall_source, wall) = match walls {
        Walls::Given(w, n) if n.is_finite() && n > 0.0 => {
            (Some(w.to_vec()), n, WallSource::Measured, None)
        }
        Walls::Measure(bvh) => {
            let t = Instant::now();
            let mut owners: Vec<u32> = voxels
                .triangle
                .iter()
                .zip(&voxels.surface)
                .filter(|(_, &s)| s)
                .map(|(&t, _)| t)
                .collect();
            owners.sort_unstable();
            owners.dedup();
            let w = crate::thickness::wall_thickness_of(
                mesh,
                bvh,
                &crate::thickness::ThicknessOptions::default(),
                &owners,
            );
            let summary = summarise_walls(&voxels, &w, seconds(t));
            let nominal = summary.nominal_mm.unwrap_or(estimate);
            measured = Some(w);
            let source = if summary.nominal_mm.is_some() {
                WallSource::Measured
            } else {
                WallSource::VolumeOverArea
            };
            (None, nominal, source, Some(summary))
        }
        _ => (None, estimate, WallSource::VolumeOverArea, None),
    };
    let triangle_walls = per_triangle.as_deref().or(measured.as_deref());
    // The cell size is set from an estimate of the wall before it is measured; warn only
    // when the measured wall is less than 1.5 cells across.
    if h > nominal / 1.5 {
        warnings.push(format!(
            "flow cells of {h:.3} mm are coarse for the nominal wall of {nominal:.3} mm (under 1.5 cells across): flow lengths are rough; try --cell {:.3}",
            nominal / 2.0
        ));
    }
    let domain = Domain::from_voxels(voxels, triangle_walls, nominal, material);
    times.wall_s = wall.as_ref().map_or(0.0, |w| w.time_s);
    times.voxels_s = seconds(t) - times.wall_s;
    if domain.bodies > 1 {
        warnings.push(format!(
            "the part has {} separate bodies; a gate fills only its own body",
            domain.bodies
        ));
    }

    let t = Instant::now();
    let (paper, paper_fields) =
        fill_from(&domain, gate, material).ok_or(FillError::GateOffPart(gate.x, gate.y, gate.z))?;
    if paper.reached_share < 0.999 {
        warnings.push(format!(
            "the gate feeds body {} only: {:.1} % of the part's volume is not reached",
            paper.body,
            100.0 * (1.0 - paper.reached_share)
        ));
    }
    times.paper_s = seconds(t);

    // Candidates: the qualifying nodes' surface points on the voxelised part.
    let t = Instant::now();
    let candidates: Vec<Source> = analysis
        .qualifying_points
        .iter()
        .filter_map(|&p| domain.source(p))
        .collect();
    let first = domain.source(gate).expect("checked by fill_from");
    let objective_value = |f: &GateFill| match options.objective {
        Objective::Length => f.l_max_mm,
        Objective::Resistance => f.fill_max,
    };
    let start = match options.objective {
        Objective::Length => &paper_fields.length,
        Objective::Resistance => &paper_fields.fill,
    };
    let balanced = balanced_gate_from(&domain, &candidates, options.objective, first, start, h)
        .map(|search| {
            let point = candidates[search.candidate].point;
            let (fill, fields) = fill_from(&domain, point, material).expect("on the part");
            if objective_value(&fill) >= objective_value(&paper) {
                // Within the discretisation the paper gate is as good (it is a candidate
                // itself unless it is the aesthetic gate): keep it, so the balanced gate
                // never does worse than the paper gate.
                let search = Balanced {
                    value: objective_value(&paper),
                    ..search
                };
                let fill = BalancedFill {
                    fill: paper.clone(),
                    search,
                    improvement_pct: 0.0,
                    is_paper_gate: true,
                };
                (fill, None)
            } else {
                let improvement_pct =
                    100.0 * (1.0 - objective_value(&fill) / objective_value(&paper));
                let fill = BalancedFill {
                    fill,
                    search,
                    improvement_pct,
                    is_paper_gate: false,
                };
                (fill, Some(fields))
            }
        });
    if balanced.is_none() {
        warnings.push("no qualifying candidate feeds the gate's body".into());
    }
    times.balanced_s = seconds(t);

    let t = Instant::now();
    let several = if options.gates > 1 {
        // Start from the balanced gate (or the paper gate's nearest candidate).
        let start = match &balanced {
            Some((b, _)) => b.search.candidate,
            None => nearest_candidate(&candidates, gate).ok_or(FillError::TooFewCandidates {
                asked: options.gates,
                available: 0,
            })?,
        };
        let available = candidates
            .iter()
            .filter(|s| {
                domain.body[s.cell as usize] == domain.body[candidates[start].cell as usize]
            })
            .count();
        Some(
            several_gates(
                &domain,
                &candidates,
                options.objective,
                start,
                options.gates,
            )
            .ok_or(FillError::TooFewCandidates {
                asked: options.gates,
                available,
            })?,
        )
    } else {
        None
    };
    times.several_s = seconds(t);

    let (answer, fields) = match (&options.strategy, &balanced) {
        (Strategy::Balanced, Some((b, Some(f)))) => (DVec3::from_array(b.fill.gate), f),
        _ => (gate, &paper_fields),
    };
    // With several gates the picture's fill order is that of all of them together.
    let fill_order_per_vertex = match &several {
        Some(m) => {
            let sources: Vec<Source> = m.gates.iter().map(|g| candidates[g.candidate]).collect();
            let field = march(&domain.voxels, &sources, Some(&domain.fill_cost));
            per_vertex(&domain, mesh, &field.t)
        }
        None => per_vertex(&domain, mesh, &fields.fill.t),
    };
    Ok(FillAnalysis {
        cell_mm: h,
        cells: domain.voxels.len(),
        bodies: domain.bodies,
        nominal_wall_mm: nominal,
        wall_source,
        wall,
        objective: options.objective,
        strategy: options.strategy,
        pressure_mpa_per_mm: pressure_factor_mpa_per_mm(material, nominal),
        paper: Some(paper),
        balanced: balanced.map(|(b, _)| b),
        several,
        warnings,
        times,
        fill_order_per_vertex,
        answer: Some(answer),
    })
}

/// Statistics of the surface cells' walls: each surface cell is one sample, the value of its
/// triangle.
fn summarise_walls(voxels: &Voxels, per_triangle: &[f32], time_s: f64) -> WallSummary {
    let mut values: Vec<f32> = Vec::new();
    let mut samples = 0;
    for (&t, &s) in voxels.triangle.iter().zip(&voxels.surface) {
        if s {
            samples += 1;
            let v = per_triangle[t as usize];
            if v.is_finite() {
                values.push(v);
            }
        }
    }
    values.sort_by(f32::total_cmp);
    let q = |f: f64| -> Option<f64> {
        (!values.is_empty())
            .then(|| values[((values.len() - 1) as f64 * f).round() as usize] as f64)
    };
    WallSummary {
        samples,
        min_mm: q(0.0),
        p05_mm: q(0.05),
        nominal_mm: q(0.5),
        p95_mm: q(0.95),
        max_mm: q(1.0),
        unknown_share: if samples == 0 {
            1.0
        } else {
            1.0 - values.len() as f64 / samples as f64
        },
        time_s,
    }
}

fn nearest_candidate(candidates: &[Source], p: DVec3) -> Option<usize> {
    (0..candidates.len()).min_by(|&a, &b| {
        candidates[a]
            .point
            .distance(p)
            .total_cmp(&candidates[b].point.distance(p))
            .then(a.cmp(&b))
    })
}

/// A field per mesh vertex, normalised to 0..1 over its finite values (NaN where the vertex's
/// cell is unreached).
fn per_vertex(domain: &Domain, mesh: &Mesh, t: &[f64]) -> Vec<f32> {
    let max = argmax(t).1.max(f64::MIN_POSITIVE);
    mesh.vertices
        .par_iter()
        .map(|&p| {
            domain
                .voxels
                .cell_near(p)
                .map(|c| t[c as usize])
                .filter(|x| x.is_finite())
                .map_or(f32::NAN, |x| (x / max) as f32)
        })
        .collect()
}
