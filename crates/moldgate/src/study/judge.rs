//! Gates the designer places (`gate_at`), judged as the method judges its own proposals.
//!
//! **Snap.** Each point is moved to the nearest point of the part's surface, over every
//! triangle (exact: the foot on the triangle's plane when it falls inside, else the
//! nearest point of its edges; ties go to the lowest triangle index). Any face may take
//! it: the snap is *not* restricted to the faces seen along D. Whether the snapped point
//! is seen along D (the ray of the paper's projection through it meets the part first
//! there, so the mould half on the +D side can carry the gate) is reported, and a point
//! that is not seen fails the first rule. The distance moved is reported; a point farther
//! than [`SNAP_LIMIT_OF_DIAGONAL`] of the diagonal of the part's box is refused before
//! any other work, with the distance and the limit.
//!
//! **Rules.** The snapped point is a node of its own: the same rays as a grid node (its
//! own and the Eq. 6 circle of radius R_gate, the Eq. 7-8 radius or the forced one), the
//! same rules in the same order ([`crate::locate`]'s): the circle on the part, the wall
//! along D under the disc thicker than R_gate (when the thickness rule is in force), flat
//! (when required), the keep-out regions, the cosmetic side. The first that fails is
//! named ([`FailedRule`]). The wall under it is the paper gate's: `thickness_mm` along D
//! at the point and `disc_thickness_mm` the smallest under the disc.
//!
//! **Fill.** With the fill analysis, the gates are one layout: their fronts are marched
//! together ([`crate::flow::fill_from_all`], the march of the balanced and several gates),
//! giving L_max, the Eq. 1 pressure, L/t against the material's limit, the last places to
//! fill and the weld lines of the layout, and each gate's share.

use rayon::prelude::*;
use serde::Serialize;

use crate::flow::{GateFill, PlacedFill};
use crate::gate::{Analysis, FlatRule, ThicknessRule};
use crate::math::DVec3;
use crate::mesh::Mesh;
use crate::study::StudyError;

/// A placed point farther from the surface than this share of the diagonal of the part's
/// box is refused: it is most likely in other units or another frame.
pub const SNAP_LIMIT_OF_DIAGONAL: f64 = 0.1;

/// A point moved onto the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Snapped {
    /// As given, mm.
    pub(crate) asked: DVec3,
    /// The nearest point of the surface, mm.
    pub(crate) point: DVec3,
    /// Its triangle.
    pub(crate) triangle: u32,
}

/// The first of the paper's rules that a placed gate fails, in the order [`crate::locate`]
/// applies them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FailedRule {
    /// The point is not where the ray along D first meets the part: it lies on a face
    /// turned away from D, or another face lies above it, so the +D mould half cannot
    /// carry a gate there.
    NotSeenAlongD,
    /// Some point of the Eq. 6 circle of radius R_gate is off the part.
    CircleOffPart,
    /// The wall along D under the disc is not thicker than R_gate.
    ThinWall,
    /// The circle is not flat within the tolerance (only with `require_flat`).
    NotFlat,
    /// The disc reaches into a keep-out region.
    KeptOut,
    /// The point lies on a face turned towards the cosmetic side.
    Cosmetic,
}

/// One gate the designer placed, and the paper's verdict on it.
#[derive(Debug, Clone, Serialize)]
pub struct PlacedGate {
    /// The point as given, mm.
    pub asked: [f64; 3],
    /// The nearest point of the surface, where the gate is judged, mm.
    pub point: [f64; 3],
    /// How far the point moved to reach the surface, mm.
    pub moved_mm: f64,
    /// Outward unit normal of the surface there.
    pub normal: [f64; 3],
    /// The triangle it lies on.
    pub triangle: u32,
    /// Whether the ray along D meets the part first at this point (see [`FailedRule`]).
    pub seen_along_d: bool,
    /// Whether it passes every rule in force, as a qualifying grid node does.
    pub qualifies: bool,
    /// The first rule it fails, or `null`.
    pub failed_rule: Option<FailedRule>,
    /// The failure in words, with the numbers, or `null`.
    pub why: Option<String>,
    /// Wall thickness along D at the point, mm (`null` where the ray never leaves the
    /// solid, or when the point is not seen along D), as the paper gate's `thickness_mm`.
    pub thickness_mm: Option<f64>,
    /// Smallest wall thickness along D under the disc, mm, as the paper gate's
    /// `disc_thickness_mm`.
    pub disc_thickness_mm: Option<f64>,
    /// The circle lies within the flatness tolerance.
    pub flat: bool,
    /// How far the circle reaches off the point's height along D, mm (`null` when the point
    /// is not seen along D or its circle is not wholly on the part).
    pub step_mm: Option<f64>,
    /// 3D distance to the centre of mass, mm.
    pub distance_3d_mm: f64,
    /// With the fill: the share of the reached volume this gate fills first.
    pub volume_share: Option<f64>,
    /// With the fill: the largest flow length inside its share, mm.
    pub l_max_mm: Option<f64>,
    /// With the fill: the wall across the surface at the gate, mm (the fill's
    /// `wall_across_mm`).
    pub wall_across_mm: Option<f64>,
}

/// The designer's gates, judged, and their fill as one layout.
#[derive(Debug, Clone, Serialize)]
pub struct PlacedGates {
    /// The gates in the order given.
    pub gates: Vec<PlacedGate>,
    /// Whether every gate qualifies.
    pub all_qualify: bool,
    /// How far a point may be from the surface, mm ([`SNAP_LIMIT_OF_DIAGONAL`] of the
    /// diagonal of the part's box).
    pub snap_limit_mm: f64,
    /// The fill of the layout, all gates open together (`gate` is the first gate's point),
    /// when the fill analysis ran.
    pub fill: Option<GateFill>,
    /// Why there is no fill, when there is none.
    pub no_fill_reason: Option<String>,
    /// The study's answer judged as these gates are, when it is the balanced gate (a grid
    /// node other than the paper gate, chosen by the fill), so that the table of these
    /// gates gives the answer's verdict beside theirs; `null` otherwise (the paper gate's
    /// verdict is the report's `paper_gate`).
    pub balanced: Option<PlacedGate>,
}

/// The verdict of a gate that passes every rule in force, in words: `qualifies`, or, off a
/// flat seat (`off_flat_mm`: how far its disc reaches off its height along D), with that
/// reach. The designer's gates, the paper gate and the balanced gate beside them are said
/// alike, so that one point gets one verdict.
pub fn qualifies_words(off_flat_mm: Option<f64>) -> String {
    match off_flat_mm {
        Some(step) => {
            format!(
                "qualifies, off a flat seat (its disc reaches {step:.2} mm off its height along D)"
            )
        }
        None => "qualifies".to_string(),
    }
}

/// A gate of the study shown beside the designer's gates in their table, with its verdict
/// in the words theirs are given.
#[derive(Debug, Clone, PartialEq)]
pub struct BesidePlaced {
    /// `paper gate`, `balanced gate` or `aesthetic gate`.
    pub name: String,
    /// Its point, mm.
    pub point: [f64; 3],
    /// Wall thickness along D at the point, mm (`None` for the aesthetic gate).
    pub thickness_mm: Option<f64>,
    /// Smallest wall thickness along D under its disc, mm.
    pub disc_thickness_mm: Option<f64>,
    /// The verdict, and which of them is the answer.
    pub verdict: String,
}

/// The study's gates beside the designer's in their table: the paper gate, judged in the
/// same words (on a flat seat or not), and the answer when it is another gate (the
/// balanced gate, judged as a placed gate; the aesthetic gate, an edge gate that the
/// paper's rules along D do not judge). Empty without placed gates.
pub fn beside_placed(r: &crate::report::Report) -> Vec<BesidePlaced> {
    use crate::flow::Strategy;
    use crate::GateMode;
    let Some(placed) = &r.placed_gates else {
        return Vec::new();
    };
    let answer = r.gate.as_ref().map(|g| (g.mode, g.strategy));
    let balanced_is_paper = r
        .fill
        .as_ref()
        .and_then(|f| f.balanced.as_ref())
        .is_some_and(|b| b.is_paper_gate);
    let mut rows = Vec::new();
    if let Some(g) = &r.paper_gate {
        let role = match answer {
            Some((GateMode::Paper, Strategy::Paper)) => "; the method's proposal",
            Some((GateMode::Paper, Strategy::Balanced)) if balanced_is_paper => {
                "; the answer (the balanced gate is the paper gate)"
            }
            _ => "",
        };
        rows.push(BesidePlaced {
            name: "paper gate".into(),
            point: g.point,
            thickness_mm: g.thickness_mm,
            disc_thickness_mm: g.disc_thickness_mm,
            verdict: format!("{}{role}", qualifies_words(g.off_flat_mm())),
        });
    }
    if let Some(g) = &placed.balanced {
        let verdict = match &g.why {
            None => qualifies_words(g.off_flat_mm()),
            Some(why) => format!("fails: {why}"),
        };
        rows.push(BesidePlaced {
            name: "balanced gate".into(),
            point: g.point,
            thickness_mm: g.thickness_mm,
            disc_thickness_mm: g.disc_thickness_mm,
            verdict: format!("{verdict}; the answer, chosen by the fill"),
        });
    }
    if let (Some((GateMode::Aesthetic, _)), Some(g)) = (answer, &r.aesthetic_gate) {
        rows.push(BesidePlaced {
            name: "aesthetic gate".into(),
            point: g.point,
            thickness_mm: None,
            disc_thickness_mm: None,
            verdict: "the answer, an edge gate on the parting line: the paper's rules along D are not its rules (a gate placed there fails them)".into(),
        });
    }
    rows
}

/// The distance beyond which a point is refused for `mesh`.
pub(crate) fn snap_limit_mm(mesh: &Mesh) -> f64 {
    SNAP_LIMIT_OF_DIAGONAL * mesh.bounds().diagonal()
}

/// Moves each point to the nearest point of the surface, refusing one farther than
/// [`snap_limit_mm`].
pub(crate) fn snap(mesh: &Mesh, points: &[DVec3]) -> Result<Vec<Snapped>, StudyError> {
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let limit = snap_limit_mm(mesh);
    let nearest = nearest_points(mesh, points);
    points
        .iter()
        .zip(nearest)
        .enumerate()
        .map(|(i, (&p, nearest))| {
            let (triangle, point) = nearest.ok_or_else(|| StudyError::Invalid {
                field: "gate_at",
                message: "needs a part with triangles".into(),
            })?;
            let moved = point.distance(p);
            if moved > limit {
                return Err(StudyError::Invalid {
                    field: "gate_at",
                    message: format!(
                        "{} ({:.3}, {:.3}, {:.3}) is {moved:.3} mm from the part's surface, over the limit of {limit:.3} mm ({} % of the diagonal of the part's box); give the point in mm in the part's frame",
                        i + 1,
                        p.x,
                        p.y,
                        p.z,
                        100.0 * SNAP_LIMIT_OF_DIAGONAL
                    ),
                });
            }
            Ok(Snapped {
                asked: p,
                point,
                triangle,
            })
        })
        .collect()
}

/// For each point, the triangle nearest it and the nearest point on it (lowest index on
/// ties), `None` without triangles: exact, over every triangle, and for the few points a
/// designer places cheaper than building a tree. The nearest vertex bounds the distance,
/// and a triangle whose box lies beyond the bound (or beyond the best so far) is skipped.
fn nearest_points(mesh: &Mesh, points: &[DVec3]) -> Vec<Option<(u32, DVec3)>> {
    let bound: Vec<f64> = points
        .iter()
        .map(|&p| {
            let d2 = mesh
                .vertices
                .par_iter()
                .map(|v| v.distance_squared(p))
                .reduce(|| f64::INFINITY, f64::min);
            // Room for the round-off of the exact distance computed later.
            d2 * (1.0 + 1e-9) + 1e-18
        })
        .collect();
    type Best = Vec<(f64, u32, DVec3)>;
    let none = || -> Best { vec![(f64::INFINITY, u32::MAX, DVec3::ZERO); points.len()] };
    const CHUNK: usize = 4096;
    let best = mesh
        .triangles
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(chunk, triangles)| {
            let mut best = none();
            for j in 0..triangles.len() {
                let t = chunk * CHUNK + j;
                let c = mesh.corners(t);
                let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
                for ((b, &p), &bound) in best.iter_mut().zip(points).zip(&bound) {
                    let outside = (lo - p).max(p - hi).max(DVec3::ZERO).length_squared();
                    if outside > bound || outside > b.0 {
                        continue;
                    }
                    let q = crate::thickness::nearest_on_triangle(c, p);
                    let d2 = q.distance_squared(p);
                    // Triangles come in increasing index: `<` keeps the lowest on ties.
                    if d2 < b.0 {
                        *b = (d2, t as u32, q);
                    }
                }
            }
            best
        })
        .reduce(none, |a, b| {
            a.into_iter()
                .zip(b)
                .map(|(x, y)| {
                    if y.0 < x.0 || (y.0 == x.0 && y.1 < x.1) {
                        y
                    } else {
                        x
                    }
                })
                .collect()
        });
    best.into_iter()
        .map(|(_, t, q)| (t != u32::MAX).then_some((t, q)))
        .collect()
}

/// Judges each snapped gate by the paper's rules with the options of `analysis`.
pub(crate) fn judge(mesh: &Mesh, analysis: &Analysis, snapped: &[Snapped]) -> PlacedGates {
    let nodes: Vec<_> = snapped
        .iter()
        .map(|s| analysis.frame.project(s.point))
        .collect();
    let rays = crate::gate::rays_at(mesh, analysis, &nodes);
    let gates: Vec<PlacedGate> = snapped
        .iter()
        .zip(rays)
        .map(|(s, (hit, v))| judge_one(mesh, analysis, s, hit, v))
        .collect();
    PlacedGates {
        all_qualify: gates.iter().all(|g| g.qualifies),
        gates,
        snap_limit_mm: snap_limit_mm(mesh),
        fill: None,
        no_fill_reason: Some("the fill analysis was not asked for (--fill)".into()),
        balanced: None,
    }
}

/// `gates` with the balanced gate at `point` (a point of the surface) judged beside them.
pub(crate) fn with_balanced(
    mut gates: PlacedGates,
    mesh: &Mesh,
    analysis: &Analysis,
    point: DVec3,
) -> PlacedGates {
    gates.balanced = snap(mesh, &[point])
        .ok()
        .and_then(|s| judge(mesh, analysis, &s).gates.pop());
    gates
}

fn judge_one(
    mesh: &Mesh,
    analysis: &Analysis,
    s: &Snapped,
    hit: crate::gate::projection::Hit,
    v: crate::gate::NodeVerdict,
) -> PlacedGate {
    let o = &analysis.options;
    let frame = &analysis.frame;
    let r = o.gate_radius_mm;
    let p = s.point;
    // Seen along D: the node's ray meets the part first at the point's height (to the
    // round-off of the part's size).
    let tolerance = 1e-6 * mesh.bounds().diagonal().max(1.0);
    let seen = hit.is_hit() && (hit.first - frame.height(p)).abs() <= tolerance;
    let mut normal = mesh.normal(s.triangle as usize);
    // As for the paper gate: a face seen along D whose normal points away from D is wound
    // inside out.
    if seen && normal.dot(frame.d) < 0.0 {
        normal = -normal;
    }
    let thickness = |t: Option<f64>| t.map_or("unknown".to_string(), |t| format!("{t:.3} mm"));
    let failed: Option<(FailedRule, String)> = if !seen {
        Some((
            FailedRule::NotSeenAlongD,
            if hit.is_hit() && hit.first > frame.height(p) {
                format!(
                    "not seen along D: the part lies {:.3} mm above it along D, so the mould half on the +D side cannot reach it",
                    hit.first - frame.height(p)
                )
            } else {
                "not seen along D: the point is on the outline or a face turned away from D, so the mould half on the +D side cannot reach it".to_string()
            },
        ))
    } else if !v.circle_on_part {
        Some((
            FailedRule::CircleOffPart,
            format!("its circle of radius {r:.3} mm is not wholly on the part"),
        ))
    } else if o.thickness_rule == ThicknessRule::Require && v.disc_thickness.is_some_and(|t| t <= r)
    {
        Some((
            FailedRule::ThinWall,
            format!(
                "the wall along D under its disc is {}, not thicker than R_gate = {r:.3} mm",
                thickness(v.disc_thickness)
            ),
        ))
    } else if o.flat_rule == FlatRule::Require && !v.flat {
        Some((
            FailedRule::NotFlat,
            format!(
                "its circle is not flat within {:.3} mm along D",
                analysis.flat_tolerance_mm
            ),
        ))
    } else if o.keep_out.iter().any(|k| k.touches(p, r)) {
        Some((
            FailedRule::KeptOut,
            format!("its disc of radius {r:.3} mm reaches into a keep-out region"),
        ))
    } else if o
        .cosmetic
        .is_some_and(|c| normal.dot(c.vector()) > crate::keepout::COSMETIC_COS)
    {
        Some((
            FailedRule::Cosmetic,
            "it lies on a face turned towards the cosmetic side".to_string(),
        ))
    } else {
        None
    };
    PlacedGate {
        asked: s.asked.to_array(),
        point: p.to_array(),
        moved_mm: p.distance(s.asked),
        normal: normal.to_array(),
        triangle: s.triangle,
        seen_along_d: seen,
        qualifies: failed.is_none(),
        failed_rule: failed.as_ref().map(|f| f.0),
        why: failed.map(|f| f.1),
        thickness_mm: if seen { hit.thickness() } else { None },
        disc_thickness_mm: if seen { v.disc_thickness } else { None },
        flat: seen && v.flat,
        step_mm: (seen && v.circle_on_part).then_some(v.step),
        distance_3d_mm: p.distance(analysis.centre),
        volume_share: None,
        l_max_mm: None,
        wall_across_mm: None,
    }
}

impl PlacedGate {
    /// How far the disc reaches off the point's height along D when it is not flat, mm:
    /// a gate that qualifies with it sits on a step, rib or slope.
    pub fn off_flat_mm(&self) -> Option<f64> {
        self.step_mm.filter(|_| !self.flat)
    }
}

impl PlacedGates {
    /// Adds the fill of the layout (`None`: the fill did not run, for `reason`).
    pub(crate) fn with_fill(mut self, fill: Option<PlacedFill>, reason: Option<&str>) -> Self {
        match fill {
            Some(f) => {
                for ((g, share), wall) in
                    self.gates.iter_mut().zip(&f.shares).zip(&f.wall_across_mm)
                {
                    g.volume_share = Some(share.volume_share);
                    g.l_max_mm = share.l_max_mm;
                    g.wall_across_mm = Some(*wall);
                }
                self.fill = Some(f.fill);
                self.no_fill_reason = None;
            }
            None => {
                if let Some(r) = reason {
                    self.no_fill_reason = Some(r.to_string());
                }
            }
        }
        self
    }

    /// A warning for the gates that qualify but sit off a flat seat (the paper does not
    /// require a flat seat, so they pass, as the grid gate does with its own warning):
    /// `tol` is the analysis's flatness tolerance, mm.
    pub fn not_flat_warning(&self, tol: f64) -> Option<String> {
        let off: Vec<(usize, f64)> = self
            .gates
            .iter()
            .enumerate()
            .filter(|(_, g)| g.qualifies)
            .filter_map(|(i, g)| g.off_flat_mm().filter(|&s| s > tol).map(|s| (i, s)))
            .collect();
        let what = |i: usize| match self.gates.len() {
            1 => "your gate".to_string(),
            _ => format!("your gate {}", i + 1),
        };
        match off.as_slice() {
            [] => None,
            [(i, step)] => {
                let p = self.gates[*i].point;
                Some(format!(
                    "{} at ({:.3}, {:.3}, {:.3}) qualifies but is not on a flat seat: its disc reaches {step:.2} mm off its height along D (a step, rib or slope; flatness tolerance {tol:.3} mm)",
                    what(*i),
                    p[0],
                    p[1],
                    p[2]
                ))
            }
            _ => Some(format!(
                "{} of your gates qualify but are not on a flat seat: {} (how far each disc reaches off its height along D: a step, rib or slope; flatness tolerance {tol:.3} mm)",
                off.len(),
                off.iter()
                    .map(|(i, s)| format!("gate {} {s:.2} mm", i + 1))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    }

    /// Gate `i`'s share of the layout's fill in words, when the fill ran: the share of the
    /// volume the gates reach that it reaches first (of the part's whole volume when they
    /// reach all of it), and the longest flow path inside that share.
    pub fn share_words(&self, i: usize) -> Option<String> {
        let g = self.gates.get(i)?;
        let (share, l) = (g.volume_share?, g.l_max_mm?);
        let of = match self.fill.as_ref().map(|f| f.reached_share) {
            Some(r) if r < 0.9995 => format!(
                "of the volume your gates reach ({:.1} % of the part's; the share it reaches first by flow length)",
                100.0 * r
            ),
            _ => "of the volume (the share it reaches first by flow length)".to_string(),
        };
        Some(format!(
            "your gate {} fills {:.1} % {of}, longest flow path L_max {l:.1} mm in it",
            i + 1,
            100.0 * share
        ))
    }

    /// A warning for gates whose discs overlap (closer than twice the gate radius `r`, mm,
    /// once on the surface): in the mould they are one gate. A
    /// point given twice has the options' own warning, and is left out here.
    pub fn overlap_warning(&self, r: f64) -> Option<String> {
        let mut pairs = Vec::new();
        for (i, a) in self.gates.iter().enumerate() {
            for (j, b) in self.gates.iter().enumerate().skip(i + 1) {
                let d = DVec3::from_array(a.point).distance(DVec3::from_array(b.point));
                if d < 2.0 * r && a.asked != b.asked {
                    pairs.push(format!("gates {} and {} ({d:.2} mm apart)", i + 1, j + 1));
                }
            }
        }
        (!pairs.is_empty()).then(|| {
            format!(
                "your {} overlap (closer than twice the gate radius, {:.3} mm, on the surface): each pair is one gate in the mould, though the fill shares the volume between them",
                pairs.join(", "),
                2.0 * r
            )
        })
    }

    /// The snapped points, in order.
    pub fn points(&self) -> Vec<DVec3> {
        self.gates
            .iter()
            .map(|g| DVec3::from_array(g.point))
            .collect()
    }
}
