//! The JSON report: a versioned contract, kept apart from the computation types.
//!
//! Field names and meanings are documented in `docs/json-schema.md`; any change to them
//! bumps [`SCHEMA_VERSION`].

use serde::Serialize;

use crate::flow::{FillAnalysis, Strategy};
use crate::gate::{
    Analysis, FlatRule, Gate, GateMode, Grid, Nearest, RuleCounts, Spacing, ThicknessRule,
};
use crate::material::Material;
use crate::mesh::MeshStats;
use crate::parting::{AestheticGate, PartingSummary};
use crate::thickness::WallThickness;
use crate::undercut::AutoDemold;
use crate::CentreKind;

/// Version of the report's schema.
pub const SCHEMA_VERSION: u32 = 3;

/// Where the part came from.
#[derive(Debug, Clone, Serialize)]
pub struct Input {
    /// Path of the mesh file, or `None` for a built-in sample.
    pub path: Option<String>,
    /// Name of the built-in sample, or `None` for a file.
    pub sample: Option<String>,
    /// Size of the file in bytes (0 for a sample).
    pub bytes: u64,
}

/// Where the gate radius came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RadiusSource {
    /// Eq. 8 with the material's parameters.
    Material,
    /// Forced by the user.
    Forced,
    /// The largest radius that fits below the refused one, taken with `--fit-radius`
    /// (the refused radius is `radius_fit.refused_mm`).
    Fitted,
}

/// The options in force.
#[derive(Debug, Clone, Serialize)]
pub struct OptionsReport {
    /// Demolding direction (unit vector).
    pub demold: [f64; 3],
    /// Gate radius in mm.
    pub gate_radius_mm: f64,
    /// Where it came from.
    pub gate_radius_source: RadiusSource,
    /// Grid spacing in mm.
    pub spacing_mm: f64,
    /// `auto` or `fixed`.
    pub spacing_rule: &'static str,
    /// Grid shift as a fraction of the spacing.
    pub grid_offset: f64,
    /// Circle points per node.
    pub circle_points: usize,
    /// Centre of mass used.
    pub centre: CentreKind,
    /// Distance measure.
    pub nearest: Nearest,
    /// Thickness rule.
    pub thickness_rule: ThicknessRule,
    /// Flat rule.
    pub flat_rule: FlatRule,
    /// Flatness tolerance in mm.
    pub flat_tolerance_mm: f64,
    /// Which gate is the answer.
    pub mode: GateMode,
    /// Keep-out regions.
    pub keep_out: Vec<crate::keepout::Region>,
    /// Cosmetic direction (unit vector), or `null`.
    pub cosmetic: Option<[f64; 3]>,
    /// Which edges make the parting line: `outline` or `longest`.
    pub parting_line: crate::parting::PartingRule,
}

/// The material and the quantities of Eq. 7-8.
#[derive(Debug, Clone, Serialize)]
pub struct MaterialReport {
    /// Parameters as in Table 1.
    #[serde(flatten)]
    pub material: Material,
    /// Eq. 7, m/s.
    pub melt_velocity_m_s: f64,
    /// Eq. 8, mm.
    pub gate_radius_mm: f64,
}

/// Centres of mass.
#[derive(Debug, Clone, Serialize)]
pub struct CentreReport {
    /// Eq. 5, the area-weighted mean of facet centroids, mm.
    pub surface: [f64; 3],
    /// Centroid of the enclosed volume, or `null` for a mesh enclosing none.
    pub volume: Option<[f64; 3]>,
    /// The one the gate was placed by.
    pub used: [f64; 3],
    /// Which one that is.
    pub kind: CentreKind,
    /// Surface area, mm^2.
    pub area_mm2: f64,
    /// Signed enclosed volume, mm^3.
    pub volume_mm3: f64,
}

/// The projection frame.
#[derive(Debug, Clone, Serialize)]
pub struct FrameReport {
    /// Demolding direction.
    pub d: [f64; 3],
    /// First plane axis.
    pub u: [f64; 3],
    /// Second plane axis.
    pub w: [f64; 3],
}

/// A gate on the grid.
#[derive(Debug, Clone, Serialize)]
pub struct GateReport {
    /// Surface point, mm.
    pub point: [f64; 3],
    /// Outward surface normal.
    pub normal: [f64; 3],
    /// Node index.
    pub node: usize,
    /// Node column and row.
    pub node_iu_iw: [usize; 2],
    /// Node position (u, w), mm.
    pub node_uw: [f64; 2],
    /// Triangle hit.
    pub triangle: u32,
    /// Wall thickness along D at the node, mm.
    pub thickness_mm: Option<f64>,
    /// Smallest thickness under the disc, mm.
    pub disc_thickness_mm: Option<f64>,
    /// Circle within the flatness tolerance.
    pub flat: bool,
    /// How far the circle reaches off the gate's height along D, mm.
    pub step_mm: f64,
    /// 3D distance to the centre of mass, mm.
    pub distance_3d_mm: f64,
    /// Distance in the projection plane, mm.
    pub distance_2d_mm: f64,
    /// Nodes equally near.
    pub ties: usize,
}

impl GateReport {
    /// How far the disc reaches off the gate's height along D when it is not flat, mm (as
    /// [`crate::study::judge::PlacedGate::off_flat_mm`] says it of a placed gate).
    pub fn off_flat_mm(&self) -> Option<f64> {
        (!self.flat).then_some(self.step_mm)
    }
}

impl From<&Gate> for GateReport {
    fn from(g: &Gate) -> Self {
        GateReport {
            point: g.point.to_array(),
            normal: g.normal.to_array(),
            node: g.node,
            node_iu_iw: [g.node_iu_iw.0, g.node_iu_iw.1],
            node_uw: g.node_uw.to_array(),
            triangle: g.triangle,
            thickness_mm: g.thickness_mm,
            disc_thickness_mm: g.disc_thickness_mm,
            flat: g.flat,
            step_mm: g.step_mm,
            distance_3d_mm: g.distance_3d,
            distance_2d_mm: g.distance_2d,
            ties: g.ties,
        }
    }
}

/// The gate on the parting line.
#[derive(Debug, Clone, Serialize)]
pub struct AestheticReport {
    /// Point, mm.
    pub point: [f64; 3],
    /// 3D distance to the centre of mass, mm.
    pub distance_3d_mm: f64,
    /// Distance in the projection plane, mm.
    pub distance_2d_mm: f64,
}

impl From<&AestheticGate> for AestheticReport {
    fn from(g: &AestheticGate) -> Self {
        AestheticReport {
            point: g.point.to_array(),
            distance_3d_mm: g.distance_3d,
            distance_2d_mm: g.distance_2d,
        }
    }
}

/// The answer.
#[derive(Debug, Clone, Serialize)]
pub struct ChosenReport {
    /// `paper` or `aesthetic`.
    pub mode: GateMode,
    /// `paper` (the method's gate) or `balanced` (the fill analysis's gate).
    pub strategy: Strategy,
    /// The gate point, mm.
    pub point: [f64; 3],
    /// 3D distance to the centre of mass, mm.
    pub distance_3d_mm: f64,
    /// With several gates (`gates` K > 1), the K gates of the answer; `point` is the first.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gates: Option<Vec<AnswerGate>>,
}

/// One gate of a several-gate answer.
#[derive(Debug, Clone, Serialize)]
pub struct AnswerGate {
    /// The gate point, mm.
    pub point: [f64; 3],
    /// Outward unit normal of the surface there.
    pub normal: [f64; 3],
    /// Share of the reached volume this gate fills first.
    pub volume_share: f64,
    /// Longest flow path inside its share, mm (`None` when the layout minimised the fill
    /// time).
    pub l_max_mm: Option<f64>,
    /// Fill time of its share, s (`None` when the layout minimised the flow length).
    pub fill_time_s: Option<f64>,
}

/// Seconds per stage.
#[derive(Debug, Clone, Serialize)]
pub struct Timings {
    /// Reading and welding the mesh, with topology.
    pub load_s: f64,
    /// Centres of mass, computed alongside the rays (this time overlaps `projection_s`).
    pub centre_s: f64,
    /// Frame and grid.
    pub grid_s: f64,
    /// Ray casting.
    pub projection_s: f64,
    /// Rules and selection.
    pub select_s: f64,
    /// Parting line, computed alongside the rays (this time overlaps `projection_s`).
    pub parting_s: f64,
    /// The ray-casting tree (automatic direction, wall thickness, fill), when built.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tree_s: Option<f64>,
    /// The automatic demolding direction, when chosen. The gate along the first line drawn
    /// ray by ray is located inside it; when that line is chosen, `total_s` counts only the
    /// time the choice ran past that locate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub demold_s: Option<f64>,
    /// The wall thickness everywhere, when measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_s: Option<f64>,
    /// The fill analysis less its tree (its stages are in `fill.times`), when it ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fill_s: Option<f64>,
    /// Every stage that ran, from loading to the end (the centre of mass and the parting
    /// line overlap the rays and are counted once, inside the locate stages).
    pub total_s: f64,
}

/// The whole report of one part.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// moldgate's version.
    pub moldgate_version: &'static str,
    /// Where the part came from.
    pub input: Input,
    /// Options in force.
    pub options: OptionsReport,
    /// Mesh statistics.
    pub mesh: MeshStats,
    /// Warnings about the mesh and the analysis.
    pub warnings: Vec<String>,
    /// Material and Eq. 7-8.
    pub material: MaterialReport,
    /// Centres of mass.
    pub centre_of_mass: CentreReport,
    /// Frame.
    pub frame: FrameReport,
    /// Grid.
    pub grid: Grid,
    /// Nodes passing each rule.
    pub counts: RuleCounts,
    /// The answer, or `null` when there is none.
    pub gate: Option<ChosenReport>,
    /// Why there is no answer, or `null`.
    pub no_gate_reason: Option<String>,
    /// The grid gate by the chosen distance.
    pub paper_gate: Option<GateReport>,
    /// The grid gate by the other distance.
    pub other_rule_gate: Option<GateReport>,
    /// The parting-line gate.
    pub aesthetic_gate: Option<AestheticReport>,
    /// The parting line.
    pub parting_line: PartingSummary,
    /// Time per stage.
    pub timings: Timings,
    /// The fill analysis (flow length, fill order, pressure, balanced and several gates), or
    /// `null` when it was not asked for.
    pub fill: Option<FillAnalysis>,
    /// Wall thickness of the part everywhere (present when it was computed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_thickness: Option<WallThicknessReport>,
    /// The directions tried by `--demold auto` (present when it was used).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub demold_auto: Option<AutoDemold>,
    /// The largest gate radius that fits, when the thickness rule removed every node
    /// (present only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radius_fit: Option<RadiusFitReport>,
    /// The gates the designer placed (`gate_at`), judged by the paper's rules and filled
    /// as one layout (present only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub placed_gates: Option<crate::study::judge::PlacedGates>,
}

/// The largest gate radius that fits where the paper's thickness rule left no node
/// ([`crate::gate::RadiusFit`]).
#[derive(Debug, Clone, Serialize)]
pub struct RadiusFitReport {
    /// The gate radius the rule refused, mm.
    pub refused_mm: f64,
    /// Why it was refused: which rule removed the last nodes.
    pub reason: String,
    /// The largest radius found to fit, mm, or `null` when none down to `floor_mm` fits.
    pub radius_mm: Option<f64>,
    /// The gate it gives.
    pub gate: Option<GateReport>,
    /// The smallest radius tried, mm.
    pub floor_mm: f64,
    /// Projections the search ran.
    pub probes: usize,
    /// Whether that gate is the answer (`--fit-radius`).
    pub accepted: bool,
    /// The thickest wall under a disc wholly on the part at `refused_mm`, mm (`null` when
    /// none is known): the radius had to fall below it; thicker walls, if any, are too
    /// narrow for that disc.
    pub thickest_wall_mm: Option<f64>,
}

/// Statistics of [`crate::thickness::WallThickness`] and the value at the gate.
#[derive(Debug, Clone, Serialize)]
pub struct WallThicknessReport {
    /// Smallest known thickness that is not a sliver, mm.
    pub min_mm: Option<f64>,
    /// Facets thinner than 5 % of the nominal wall (slivers), left out of `min_mm`.
    pub slivers: usize,
    /// The smallest sliver, mm (`null` without slivers).
    pub sliver_min_mm: Option<f64>,
    /// Area-weighted median, mm.
    pub nominal_mm: Option<f64>,
    /// Largest known thickness, mm.
    pub max_mm: Option<f64>,
    /// Share of the area where it is unknown (0 to 1).
    pub unknown_area_share: f64,
    /// Thickness of the triangle the paper gate lies on, mm (`null` without a gate or where
    /// unknown). The along-D value is `paper_gate.thickness_mm`.
    pub at_gate_mm: Option<f64>,
    /// Seconds spent.
    pub time_s: f64,
}

impl Report {
    /// Says where the part came from and how long it took to load: `input`, and
    /// `timings.load_s` (added to `timings.total_s`).
    pub fn set_input(&mut self, input: Input, load_s: f64) {
        self.input = input;
        self.timings.load_s = load_s;
        self.timings.total_s += load_s;
    }

    /// Whether the balanced gate is the paper's grid gate while the answer is another (the
    /// aesthetic gate): the grid gate stays the balanced gate when no candidate beats it
    /// by more than a flow cell.
    pub fn balanced_is_paper_gate_beside_another(&self) -> bool {
        let balanced = self.fill.as_ref().and_then(|f| f.balanced.as_ref());
        match (balanced, &self.paper_gate) {
            (Some(b), Some(g)) => !b.is_paper_gate && b.fill.gate == g.point,
            _ => false,
        }
    }

    /// The balanced gate's name in a table beside the answer's gate: "balanced gate (the
    /// paper gate)" when it is the paper's grid gate beside another
    /// ([`Report::balanced_is_paper_gate_beside_another`]), else "balanced gate".
    pub fn balanced_row_name(&self) -> &'static str {
        match self.balanced_is_paper_gate_beside_another() {
            true => "balanced gate (the paper gate)",
            false => "balanced gate",
        }
    }

    /// This report with its sentences (the warnings, the reasons for no gate, no fill or a
    /// refused radius, why a placed gate does not qualify) in the words of a front end
    /// whose options are keywords ([`crate::study::keyword_words`]): `--require-flat`
    /// becomes `require_flat=True` for Python (`truth` "True"), `require_flat=true` for the
    /// service. Every number and every other field stays as it is.
    pub fn in_keyword_words(&self, truth: &str) -> Report {
        let words = |s: &mut String| *s = crate::study::keyword_words(s, truth);
        let mut r = self.clone();
        r.warnings.iter_mut().for_each(words);
        r.no_gate_reason.iter_mut().for_each(words);
        if let Some(f) = &mut r.fill {
            f.warnings.iter_mut().for_each(words);
        }
        if let Some(fit) = &mut r.radius_fit {
            words(&mut fit.reason);
        }
        if let Some(placed) = &mut r.placed_gates {
            placed.no_fill_reason.iter_mut().for_each(words);
            for g in &mut placed.gates {
                g.why.iter_mut().for_each(words);
            }
        }
        r
    }

    /// Adds the wall thickness, with its value at the paper gate's triangle.
    pub fn with_wall_thickness(mut self, w: &WallThickness, time_s: f64) -> Report {
        let at_gate_mm = self
            .paper_gate
            .as_ref()
            .and_then(|g| w.at_triangle(g.triangle as usize));
        self.wall_thickness = Some(WallThicknessReport {
            min_mm: w.min_mm,
            slivers: w.slivers,
            sliver_min_mm: w.sliver_min_mm,
            nominal_mm: w.nominal_mm,
            max_mm: w.max_mm,
            unknown_area_share: w.unknown_area_share,
            at_gate_mm,
            time_s,
        });
        self.timings.wall_s = Some(time_s);
        self.timings.total_s += time_s;
        self
    }

    /// Adds the directions tried by the automatic demolding choice; a chosen direction with
    /// undercuts adds a warning with its area.
    pub fn with_demold_auto(mut self, auto: AutoDemold) -> Report {
        self.warnings.extend(demold_auto_warning(&auto));
        self.demold_auto = Some(auto);
        self
    }

    /// Assembles the report of an analysis.
    pub fn new(
        input: Input,
        stats: &MeshStats,
        mesh_warnings: &[String],
        material: &Material,
        radius_source: RadiusSource,
        analysis: &Analysis,
        load_s: f64,
    ) -> Report {
        let o = &analysis.options;
        let t = &analysis.times;
        let chosen = analysis.gate();
        let c = &analysis.centres;
        Report {
            schema_version: SCHEMA_VERSION,
            moldgate_version: env!("CARGO_PKG_VERSION"),
            input,
            options: OptionsReport {
                demold: analysis.frame.d.to_array(),
                gate_radius_mm: o.gate_radius_mm,
                // The radius in force: the fitted one when the fit was taken.
                gate_radius_source: match &analysis.radius_fit {
                    Some(f) if f.accepted => RadiusSource::Fitted,
                    _ => radius_source,
                },
                spacing_mm: analysis.grid.spacing,
                spacing_rule: match o.spacing {
                    Spacing::Auto => "auto",
                    Spacing::Mm(_) => "fixed",
                },
                grid_offset: o.grid_offset,
                circle_points: o.circle_points,
                centre: o.centre,
                nearest: o.nearest,
                thickness_rule: o.thickness_rule,
                flat_rule: o.flat_rule,
                flat_tolerance_mm: analysis.flat_tolerance_mm,
                mode: o.mode,
                keep_out: o.keep_out.clone(),
                cosmetic: o.cosmetic.map(|c| c.vector().to_array()),
                parting_line: o.parting,
            },
            mesh: stats.clone(),
            warnings: mesh_warnings
                .iter()
                .chain(&analysis.warnings)
                .cloned()
                .collect(),
            material: MaterialReport {
                material: material.clone(),
                melt_velocity_m_s: material.melt_velocity_m_s(),
                gate_radius_mm: material.gate_radius_mm(),
            },
            centre_of_mass: CentreReport {
                surface: c.surface.to_array(),
                volume: c.volume.map(|v| v.to_array()),
                used: analysis.centre.to_array(),
                // The one used: the surface's when the volume's was asked for and the mesh
                // encloses none.
                kind: match c.get(o.centre) {
                    Some(_) => o.centre,
                    None => CentreKind::Surface,
                },
                area_mm2: c.area_mm2,
                volume_mm3: c.volume_mm3,
            },
            frame: FrameReport {
                d: analysis.frame.d.to_array(),
                u: analysis.frame.u.to_array(),
                w: analysis.frame.w.to_array(),
            },
            grid: analysis.grid,
            counts: analysis.counts,
            gate: chosen.as_ref().ok().map(|g| ChosenReport {
                mode: o.mode,
                strategy: Strategy::Paper,
                point: g.point().to_array(),
                distance_3d_mm: g.point().distance(analysis.centre),
                gates: None,
            }),
            no_gate_reason: chosen.err().map(|e| e.to_string()),
            paper_gate: analysis.grid_gate.as_ref().map(GateReport::from),
            other_rule_gate: analysis.other_rule_gate.as_ref().map(GateReport::from),
            aesthetic_gate: analysis.aesthetic_gate.as_ref().map(AestheticReport::from),
            parting_line: PartingSummary::from(&analysis.parting),
            timings: Timings {
                load_s,
                centre_s: t.centre_s,
                grid_s: t.grid_s,
                projection_s: t.projection_s,
                select_s: t.select_s,
                parting_s: t.parting_s,
                tree_s: None,
                demold_s: None,
                wall_s: None,
                fill_s: None,
                total_s: load_s + t.total_s,
            },
            fill: None,
            wall_thickness: None,
            demold_auto: None,
            radius_fit: analysis.radius_fit.as_ref().map(|f| RadiusFitReport {
                refused_mm: f.refused_mm,
                reason: f.reason.clone(),
                radius_mm: f.radius_mm,
                gate: f.gate.as_ref().map(GateReport::from),
                floor_mm: f.floor_mm,
                probes: f.probes,
                accepted: f.accepted,
                thickest_wall_mm: f.thickest_wall_mm,
            }),
            placed_gates: None,
        }
    }

    /// Adds the fill analysis; with the balanced strategy its gate becomes the answer.
    pub fn with_fill(mut self, fill: FillAnalysis, centre: crate::math::DVec3) -> Report {
        if let (Strategy::Balanced, Some(b), Some(gate)) =
            (fill.strategy, &fill.balanced, &mut self.gate)
        {
            let p = crate::math::DVec3::from_array(b.fill.gate);
            gate.strategy = Strategy::Balanced;
            gate.point = b.fill.gate;
            gate.distance_3d_mm = p.distance(centre);
        }
        let t = &fill.times;
        let fill_s = t.wall_s
            + t.voxels_s
            + t.paper_s
            + t.balanced_s
            + t.several_s
            + t.placed_s
            + t.suitability_s.unwrap_or(0.0);
        // The cells made beside the gate search are in the time of that join already.
        let fill_s = fill_s - t.cells_beside_s;
        self.timings.fill_s = Some(fill_s);
        self.timings.total_s += fill_s;
        self.warnings.extend(fill.warnings.iter().cloned());
        self.fill = Some(fill);
        self
    }
}

/// A time in seconds as people read it, without its unit: [`three_figures`], so that close
/// times on a part that fills in milliseconds still show their order.
pub fn seconds_text(t: f64) -> String {
    three_figures(t)
}

/// An undercut under this share of the surface is said to be a trace (the heatbed clip's
/// 0.00346 mm^2, 0.0002 %, from rays grazing edges).
const TRACE_SHARE: f64 = 1e-4;

/// The warning of an automatic direction with undercuts: its area, and when a tie chose it
/// over a line of less, that line's (the choice's rules, [`crate::undercut`]).
fn demold_auto_warning(auto: &AutoDemold) -> Option<String> {
    let c = auto.candidate();
    if c.undercut.area_mm2 > 0.0 {
        let d = |d: [f64; 3]| format!("({:.4}, {:.4}, {:.4})", d[0], d[1], d[2]);
        // The least undercut drawn; the chosen line may be within the tie of it.
        let least = auto
            .tried
            .iter()
            .filter(|t| t.evaluated)
            .min_by(|a, b| a.undercut.area_mm2.total_cmp(&b.undercut.area_mm2))
            .unwrap_or(c);
        let area = format!(
            "{} mm^2 ({} % of the area)",
            three_figures(c.undercut.area_mm2),
            three_figures(100.0 * c.undercut.share)
        );
        Some(if least.undercut.area_mm2 < c.undercut.area_mm2 {
            format!(
                "--demold auto: no direction without undercuts; chose {}, whose undercut, {area}, is within the tie ({} mm^2, 1 % of the area) of the least, {} mm^2 along {}, by the tie's rules (the shallowest draw, then a line where a gate qualifies)",
                d(c.direction),
                three_figures(auto.tie_mm2),
                three_figures(least.undercut.area_mm2),
                d(least.direction)
            )
        } else {
            format!(
                "--demold auto: no direction without undercuts; chose {}, with the least undercut, {area}{}",
                d(c.direction),
                // A few rays' worth of a large surface: what rays grazing an edge or a
                // vertex give, said as such rather than as an undercut to design for.
                if c.undercut.share < TRACE_SHARE {
                    format!(
                        ", a trace (under {} % of the area), more likely rays grazing edges than an undercut to design for",
                        100.0 * TRACE_SHARE
                    )
                } else {
                    String::new()
                }
            )
        })
    } else {
        None
    }
}

/// A positive value to three significant figures (`0.00612`, `0.0161`, `0.161`, `1.61`,
/// `16.1`, `161`, and `1614` above 999): the fill's times and pressures, which span
/// milliseconds to seconds and hundredths to hundreds of MPa. Zero, negative and
/// non-finite values are written with three decimals. The browser app's `threeFigures`
/// (web/src/format.js) writes the same text.
pub fn three_figures(t: f64) -> String {
    if !t.is_finite() || t <= 0.0 {
        return format!("{t:.3}");
    }
    // A number past any part's size reads by its exponent, not its 300 digits.
    if t >= 1e9 {
        return format!("{t:.2e}");
    }
    let decimals = |v: f64| (2 - v.log10().floor() as i64).clamp(0, 9) as usize;
    let d = decimals(t);
    let text = format!("{t:.d$}");
    // Rounding may carry into the next power of ten (0.009996 -> 0.01000): one digit fewer.
    let carried = match text.parse::<f64>() {
        Ok(v) if v > 0.0 => decimals(v),
        _ => d,
    };
    if carried < d {
        format!("{t:.carried$}")
    } else {
        text
    }
}

/// `text` with every negative zero number (`-0`, `-0.0`, `-0.000`) written without its
/// sign, so a value that rounds to zero never reads `-0.000`. With `json`, text inside
/// double-quoted strings is left alone (escapes honoured).
pub fn without_negative_zeros(text: &str, json: bool) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut in_string = false;
    let mut start = 0;
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if json && in_string {
            if c == b'\\' {
                i += 2;
                continue;
            }
            in_string = c != b'"';
        } else if json && c == b'"' {
            in_string = true;
        } else if c == b'-' && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'.')) {
            // A number made of zeros only, ending at something that is not a digit.
            let mut j = i + 1;
            while j < b.len() && (b[j] == b'0' || b[j] == b'.') {
                j += 1;
            }
            let zeros = j > i + 1
                && b[i + 1] == b'0'
                && b[i + 1..j].iter().all(|&d| d == b'0' || d == b'.');
            let ends = j == b.len() || !(b[j].is_ascii_digit() || b[j] == b'e' || b[j] == b'E');
            if zeros && ends {
                out.push_str(&text[start..i]);
                start = i + 1;
            }
        }
        i += 1;
    }
    out.push_str(&text[start.min(text.len())..]);
    out
}

#[cfg(test)]
mod tests {
    use super::{seconds_text, without_negative_zeros};

    /// An automatic direction with undercuts is warned with its area; one chosen by the tie
    /// over a line of less names that line; one without undercuts is not warned.
    #[test]
    fn an_automatic_direction_with_undercuts_is_warned_with_the_least() {
        use super::{demold_auto_warning, AutoDemold};
        use crate::undercut::{Candidate, CandidateKind, Undercut};
        let line = |direction: [f64; 3], area_mm2: f64, evaluated: bool| Candidate {
            direction,
            kind: CandidateKind::Axis,
            undercut: Undercut {
                area_mm2,
                share: area_mm2 / 2000.0,
            },
            evaluated,
            extent_mm: 10.0,
            gate_qualifies: None,
        };
        let auto = |chosen: usize, tried: Vec<Candidate>| AutoDemold {
            chosen,
            tried,
            tie_mm2: 20.0,
        };
        // The blank tile: -z chosen at 61.7 mm^2, x at 61.5 within the tie.
        let tile = auto(
            1,
            vec![
                line([1.0, 0.0, 0.0], 61.5, true),
                line([0.0, 0.0, -1.0], 61.7, true),
                line([0.0, 1.0, 0.0], 10.0, false),
            ],
        );
        let w = demold_auto_warning(&tile).expect("undercuts");
        assert!(
            w.contains("chose (0.0000, 0.0000, -1.0000), whose undercut, 61.7 mm^2 (3.09 % of the area), is within the tie (20.0 mm^2, 1 % of the area) of the least, 61.5 mm^2 along (1.0000, 0.0000, 0.0000)"),
            "{w}"
        );
        // A line left at a bound is not the least drawn; a tiny area keeps its figures.
        let clip = auto(
            0,
            vec![
                line([0.0, 0.0, 1.0], 0.00346, true),
                line([1.0, 0.0, 0.0], 0.001, false),
            ],
        );
        let w = demold_auto_warning(&clip).expect("undercuts");
        assert!(w.ends_with("chose (0.0000, 0.0000, 1.0000), with the least undercut, 0.00346 mm^2 (0.000173 % of the area), a trace (under 0.01 % of the area), more likely rays grazing edges than an undercut to design for"), "{w}");
        // An undercut above the trace is not called one.
        let hook = auto(0, vec![line([0.0, 0.0, 1.0], 5.0, true)]);
        let w = demold_auto_warning(&hook).expect("undercuts");
        assert!(
            w.ends_with("with the least undercut, 5.00 mm^2 (0.250 % of the area)"),
            "{w}"
        );
        assert_eq!(
            demold_auto_warning(&auto(0, vec![line([0.0, 0.0, 1.0], 0.0, true)])),
            None
        );
    }

    #[test]
    fn seconds_keep_three_significant_figures() {
        for (t, want) in [
            (0.006123, "0.00612"),
            (0.01614, "0.0161"),
            (0.1614, "0.161"),
            (1.614, "1.61"),
            (16.14, "16.1"),
            (161.4, "161"),
            (1614.0, "1614"),
            (0.1, "0.100"),
            (1.0, "1.00"),
            // Rounding that carries into the next power of ten keeps three figures.
            (0.0099996, "0.0100"),
            (9.996, "10.0"),
            (99.96, "100"),
            (0.0, "0.000"),
            (1e-12, "0.000000000"),
        ] {
            assert_eq!(seconds_text(t), want, "{t}");
        }
        // The order of two times on a part that fills in milliseconds shows.
        assert_ne!(seconds_text(0.01512), seconds_text(0.01561));
    }

    #[test]
    fn negative_zeros_lose_their_sign_and_nothing_else_changes() {
        for (text, want) in [
            ("(-0.000, 1.000, -0.000)", "(0.000, 1.000, 0.000)"),
            ("x -0.0,", "x 0.0,"),
            ("-0", "0"),
            (
                "-0.001 -10 -0.5 a-0 1e-0 -00.01",
                "-0.001 -10 -0.5 a-0 1e-0 -00.01",
            ),
        ] {
            assert_eq!(without_negative_zeros(text, false), want);
        }
        assert_eq!(
            without_negative_zeros("(-0.000, -0.000)", false),
            "(0.000, 0.000)"
        );
        assert_eq!(
            without_negative_zeros(
                r#"{"a": -0.0, "p": "x -0.0 \" -0", "b": [-0.0, -1.0]}"#,
                true
            ),
            r#"{"a": 0.0, "p": "x -0.0 \" -0", "b": [0.0, -1.0]}"#
        );
    }
}
