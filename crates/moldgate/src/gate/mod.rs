//! The paper's gate location: nodal quadrature, projection along the demolding direction,
//! candidate rules, and the candidate nearest the centre of mass.

pub mod projection;
pub mod quadrature;

use crate::clock::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::centre::{CentreKind, Centres};
use crate::error::{LocateError, OptionsError};
use crate::frame::{Direction, Frame};
use crate::keepout::Region;
use crate::math::{Aabb, DVec2, DVec3};
use crate::mesh::LoadedMesh;
pub use crate::parting::PartingRule;
use crate::parting::{AestheticGate, PartingLine};
use projection::{Hit, Projection, RayLattice};
pub use quadrature::{auto_spacing, Grid, Spacing};

/// How "nearest the centre of mass" is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Nearest {
    /// 3D distance from the node's surface point (the first hit of its centre ray).
    #[default]
    #[serde(rename = "3d")]
    Surface3d,
    /// Distance in the projection plane.
    #[serde(rename = "2d")]
    Plane2d,
}

/// Whether the paper's rule "R_gate below the wall thickness" removes candidates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ThicknessRule {
    /// A node qualifies only if the wall under its whole disc is thicker than R_gate (the
    /// paper's rule; nodes whose rays never leave an open mesh pass with unknown thickness).
    #[default]
    Require,
    /// Thickness is measured and reported but does not remove candidates.
    Ignore,
}

/// What [`locate`] does when the thickness rule removes every node that passed the others.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ThicknessFallback {
    /// No gate; the analysis says the largest gate radius that fits ([`Analysis::radius_fit`])
    /// and the gate it gives.
    #[default]
    Report,
    /// The gate is the one of the largest gate radius that fits (the rule that removed the
    /// last nodes at R_gate is still said in [`Analysis::warnings`]).
    LargestFitting,
}

/// The search for the largest gate radius that fits where the thickness rule removed every
/// node: bisection over R below R_gate, on the grid of R_gate.
///
/// A radius *fits* when some node qualifies with it under every rule in force. The search
/// tries R_gate / [`FIT_FLOOR_DIVISOR`] first (none fitting there: no radius is given), then
/// halves the interval between the largest radius known to fit and the smallest known not
/// to, [`FIT_STEPS`] times: at most 1 + [`FIT_STEPS`] runs of the projection, each as costly
/// as the first, and a radius within (R_gate - floor) / 2^[`FIT_STEPS`] of the largest
/// fitting one (if fitting is monotone in R; it need not be, the radius found fits anyway).
#[derive(Debug, Clone, PartialEq)]
pub struct RadiusFit {
    /// The gate radius the thickness rule refused, mm.
    pub refused_mm: f64,
    /// The smallest radius tried, mm.
    pub floor_mm: f64,
    /// The largest radius found to fit, mm, if any.
    pub radius_mm: Option<f64>,
    /// The gate that radius gives.
    pub gate: Option<Gate>,
    /// Projections run by the search.
    pub probes: usize,
    /// Which rule removed the last nodes at the refused radius (the sentence of
    /// [`Analysis::why_no_candidate`] without the search's result).
    pub reason: String,
    /// Whether the fitting gate is the answer ([`ThicknessFallback::LargestFitting`]).
    pub accepted: bool,
    /// The thickest wall under a disc wholly on the part at the refused radius, mm (`None`
    /// when no such disc has a known wall): the radius had to fall below it, and the
    /// thicker walls of the part, if any, are too narrow for that disc.
    pub thickest_wall_mm: Option<f64>,
}

/// The search's smallest radius is R_gate divided by this.
pub const FIT_FLOOR_DIVISOR: f64 = 10.0;
/// Bisection steps of the search.
pub const FIT_STEPS: usize = 8;

/// The runs of the rays of the search for the largest radius that fits, at most (the
/// refused radius's run, the floor's and [`FIT_STEPS`]): the search is run only when these
/// runs together stay within [`RAY_TEST_BUDGET`].
const FIT_RUNS: f64 = (2 + FIT_STEPS) as f64;

/// Whether a flat seat is required.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FlatRule {
    /// Flatness is reported, not required (the paper does not require it).
    #[default]
    Report,
    /// A node qualifies only if its circle lies within the flatness tolerance of its centre.
    Require,
}

/// Which gate is the answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GateMode {
    /// The qualifying node nearest the centre of mass (the paper's main rule).
    #[default]
    Paper,
    /// The point of the parting line nearest the centre of mass (the paper's aesthetic rule).
    Aesthetic,
}

impl GateMode {
    /// The gate's name in the report's words: `paper` or `aesthetic`.
    pub fn name(self) -> &'static str {
        match self {
            GateMode::Paper => "paper",
            GateMode::Aesthetic => "aesthetic",
        }
    }
}

/// Options of [`locate`]. Every field documents its default.
#[derive(Debug, Clone, PartialEq)]
pub struct LocateOptions {
    /// Demolding direction; rays come from its + side. Default +Z.
    pub direction: Direction,
    /// Gate radius R_gate in mm, usually [`crate::Material::gate_radius_mm`]. Default: PP's
    /// 1.4254 mm.
    pub gate_radius_mm: f64,
    /// Grid spacing. Default [`Spacing::Auto`].
    pub spacing: Spacing,
    /// Grid shift as a fraction of the spacing, along u and w. Default 0.
    pub grid_offset: f64,
    /// Points on each node's circle. Default 16.
    pub circle_points: usize,
    /// Centre of mass the gate is placed by. Default [`CentreKind::Surface`] (Eq. 5).
    pub centre: CentreKind,
    /// How nearness is measured. Default [`Nearest::Surface3d`].
    pub nearest: Nearest,
    /// Wall-thickness rule. Default [`ThicknessRule::Require`].
    pub thickness_rule: ThicknessRule,
    /// When that rule removes every node. Default [`ThicknessFallback::Report`].
    pub thickness_fallback: ThicknessFallback,
    /// Which edges make the parting line. Default [`PartingRule::Outline`].
    pub parting: PartingRule,
    /// Flat-seat rule. Default [`FlatRule::Report`].
    pub flat_rule: FlatRule,
    /// Flatness tolerance along D in mm. Default `None`: 0.1 R_gate.
    pub flat_tolerance_mm: Option<f64>,
    /// Which gate is the answer. Default [`GateMode::Paper`].
    pub mode: GateMode,
    /// Largest grid accepted, in nodes. Default 4 000 000.
    pub max_nodes: usize,
    /// Regions no gate disc may reach into. Default none.
    pub keep_out: Vec<Region>,
    /// A visible direction: candidates on faces turned towards it are forbidden. Default
    /// none.
    pub cosmetic: Option<Direction>,
}

/// The most points a node's circle may have: one a degree, far more than the rule needs
/// (16 is the default) and a bound on the circle lattices' memory and time.
pub const MAX_CIRCLE_POINTS: usize = 360;

/// The largest node limit accepted ([`LocateOptions::max_nodes`]).
pub const MAX_NODES_LIMIT: usize = 20_000_000;

/// The most keep-out regions: each is tested at every node that hits the part (64 regions
/// on the largest grid, 20 million nodes, are about a second of tests).
pub const MAX_KEEP_OUT: usize = 64;

/// The memory the rays' hit records may take, in bytes (3 GiB): with up to
/// [`projection::MAX_RUNS`] sets of hits, one 24-byte record a node and one 8-byte record a
/// node and circle point. The default 4 million nodes and 16 circle points need 2.3 GiB at
/// most (four sets), 1.1 GiB on two threads.
pub const RAY_MEMORY_BUDGET_BYTES: u64 = 3 << 30;

/// The most ray-triangle tests the rays may make, summed over the node and circle
/// lattices: the lattice points inside every triangle's projection, estimated from the
/// triangles' projected areas before any ray is cast. A part whose surface each ray
/// crosses a few times stays far below it (the 352k-triangle shared part, default grid of
/// 9,393 nodes: at most 3.0e4 a lattice by its surface area, 5e5 in all); 1.17 million
/// random triangles over a 100 mm box would make 1.5e10, which took over 300 s on two
/// threads, so the budget is of the order of 20 s of rays.
pub const RAY_TEST_BUDGET: f64 = 1e9;

impl LocateOptions {
    /// The flatness tolerance at gate radius `r`, mm: the one given, else a tenth of `r`.
    pub(crate) fn flat_tolerance_at(&self, r: f64) -> f64 {
        self.flat_tolerance_mm.unwrap_or(0.1 * r)
    }

    /// The parting line's gate of the aesthetic rule: the point of `parting` nearest
    /// `centre` outside the keep-out regions (searched along each edge in steps of a
    /// quarter of the gate radius), among the points `also` keeps.
    pub(crate) fn parting_gate(
        &self,
        parting: &PartingLine,
        mesh: &crate::mesh::Mesh,
        frame: &Frame,
        centre: DVec3,
        also: impl Fn(DVec3) -> bool,
    ) -> Option<AestheticGate> {
        let r = self.gate_radius_mm;
        // Keep-out regions apply to the parting-line gate too (cosmetic faces do not: the
        // line is the boundary between the two halves).
        parting.nearest_allowed(mesh, frame, centre, 0.25 * r, |p| {
            also(p) && !self.keep_out.iter().any(|k| k.touches(p, r))
        })
    }

    /// The parting line's gate as if there were no keep-out regions (the point a region that
    /// moved the aesthetic gate holds).
    fn parting_gate_ignoring_keep_outs(
        &self,
        parting: &PartingLine,
        mesh: &crate::mesh::Mesh,
        frame: &Frame,
        centre: DVec3,
    ) -> Option<AestheticGate> {
        parting.nearest_allowed(mesh, frame, centre, 0.25 * self.gate_radius_mm, |_| true)
    }

    /// Checks every option against its range and stated limit before any work: a front end
    /// calls it when it builds the options, and [`locate`] calls it again.
    pub fn validate(&self) -> Result<(), OptionsError> {
        let r = self.gate_radius_mm;
        if !(r.is_finite() && r > 0.0) {
            return Err(OptionsError::NonPositive {
                option: "gate radius",
                value: r,
            });
        }
        if self.circle_points == 0 {
            return Err(OptionsError::NonPositive {
                option: "circle points",
                value: 0.0,
            });
        }
        for (option, value, limit) in [
            ("circle points", self.circle_points, MAX_CIRCLE_POINTS),
            ("the node limit", self.max_nodes, MAX_NODES_LIMIT),
            ("keep-out regions", self.keep_out.len(), MAX_KEEP_OUT),
        ] {
            if value > limit {
                return Err(OptionsError::AboveLimit {
                    option,
                    value: value as u64,
                    limit: limit as u64,
                });
            }
        }
        if self.max_nodes == 0 {
            return Err(OptionsError::NonPositive {
                option: "the node limit",
                value: 0.0,
            });
        }
        if let Spacing::Mm(h) = self.spacing {
            if !(h.is_finite() && h > 0.0) {
                return Err(OptionsError::NonPositive {
                    option: "spacing",
                    value: h,
                });
            }
        }
        if !(self.grid_offset.is_finite() && self.grid_offset.abs() < 1.0) {
            return Err(OptionsError::GridOffset(self.grid_offset));
        }
        if let Some(t) = self.flat_tolerance_mm {
            if !(t.is_finite() && t >= 0.0) {
                return Err(OptionsError::NonPositive {
                    option: "flatness tolerance",
                    value: t,
                });
            }
        }
        Ok(())
    }
}

/// Refuses a grid of `nodes` whose rays' hit records, with `circle_points` points a node,
/// could take more than [`RAY_MEMORY_BUDGET_BYTES`]: counted with the most sets of hits any
/// machine draws, so that a grid accepted here is accepted everywhere.
fn check_ray_memory(grid: &Grid, circle_points: usize) -> Result<(), OptionsError> {
    let nodes = grid.len();
    let per_node = 24 + 8 * circle_points as u64;
    let runs = projection::MAX_RUNS as u64;
    let bytes = (nodes as u64).saturating_mul(per_node * runs);
    if bytes <= RAY_MEMORY_BUDGET_BYTES {
        return Ok(());
    }
    let per_grid = (nodes as u64).max(1) * runs;
    Err(OptionsError::RayMemory {
        nodes: nodes as u64,
        circle_points: circle_points as u64,
        runs,
        bytes,
        budget: RAY_MEMORY_BUDGET_BYTES,
        points_within: (RAY_MEMORY_BUDGET_BYTES / per_grid).saturating_sub(24) / 8,
        nodes_within: RAY_MEMORY_BUDGET_BYTES / (per_node * runs),
        min_spacing_mm: quadrature::least_spacing(
            DVec2::from_array(grid.box_hi) - DVec2::from_array(grid.box_lo),
            (RAY_MEMORY_BUDGET_BYTES / (per_node * runs)) as usize,
        ),
    })
}

/// Hit records below this many bytes are not checked against the machine's memory (a read
/// of the process's limits and the kernel's figures, about a tenth of a millisecond).
const MACHINE_CHECK_FROM_BYTES: u64 = 64 << 20;

/// Refuses a grid whose rays' hit records, on the threads that will draw them, would take
/// more memory than the process may still use ([`crate::files::memory_limit`]), counted
/// twice over: the measured peak of `locate` on a fine grid is those records and little
/// else (about 306 bytes a node with 16 circle points on two threads, 1,080 with 64), but
/// under a limit on address space a grid at 0.9 of the room once counted still failed an
/// allocation (arrays grown by doubling, mapped and not yet used). Unlike
/// [`check_ray_memory`] this depends on the machine: it stands where an allocation would
/// fail part way and abort the process.
fn check_machine_memory(grid: &Grid, circle_points: usize) -> Result<(), OptionsError> {
    let nodes = grid.len() as u64;
    let per_node = 24 + 8 * circle_points as u64;
    let runs = rayon::current_num_threads().clamp(1, projection::MAX_RUNS) as u64;
    // Twice the records: their arrays grow by doubling (up to twice what they hold), and the
    // limits count what is mapped, not what is used.
    let per_node = 2 * per_node;
    let bytes = nodes.saturating_mul(per_node * runs);
    if bytes < MACHINE_CHECK_FROM_BYTES {
        return Ok(());
    }
    let Some(room) = crate::files::memory_limit() else {
        return Ok(());
    };
    if bytes <= room {
        return Ok(());
    }
    // What fits is named with a quarter of the room to spare: the room itself moves from
    // run to run (the threads' allocator arenas are mapped as they first allocate, and a
    // limit on address space counts them).
    let spare = room / 4 * 3;
    let nodes_within = spare / (per_node * runs);
    Err(OptionsError::MachineMemory {
        nodes,
        circle_points: circle_points as u64,
        runs,
        bytes,
        room,
        points_within: (spare / (2 * nodes.max(1) * runs)).saturating_sub(24) / 8,
        nodes_within,
        min_spacing_mm: quadrature::least_spacing(
            DVec2::from_array(grid.box_hi) - DVec2::from_array(grid.box_lo),
            nodes_within.max(1) as usize,
        ),
    })
}

impl Default for LocateOptions {
    fn default() -> Self {
        LocateOptions {
            direction: Direction::PLUS_Z,
            gate_radius_mm: crate::Material::builtin("PP")
                .expect("PP is built in")
                .gate_radius_mm(),
            spacing: Spacing::Auto,
            grid_offset: 0.0,
            circle_points: 16,
            centre: CentreKind::Surface,
            nearest: Nearest::Surface3d,
            thickness_rule: ThicknessRule::Require,
            thickness_fallback: ThicknessFallback::Report,
            parting: PartingRule::Outline,
            flat_rule: FlatRule::Report,
            flat_tolerance_mm: None,
            mode: GateMode::Paper,
            max_nodes: 4_000_000,
            keep_out: Vec::new(),
            cosmetic: None,
        }
    }
}

/// How many nodes pass each rule, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct RuleCounts {
    /// Nodes of the grid.
    pub nodes: usize,
    /// Nodes whose own ray hits the part.
    pub centre_hits: usize,
    /// Nodes whose ray and every circle ray hit the part (the paper's candidates).
    pub circle_on_part: usize,
    /// Of those, nodes whose wall under the disc is thicker than R_gate.
    pub thicker_than_radius: usize,
    /// Of the circle-on-part nodes, those whose thickness is unknown (the ray never leaves
    /// an open mesh); they pass the thickness rule.
    pub thickness_unknown: usize,
    /// Of the circle-on-part nodes, those whose circle lies within the flatness tolerance.
    pub flat: usize,
    /// Nodes that pass the paper's rules but whose gate disc reaches into a keep-out region.
    pub kept_out: usize,
    /// Nodes that pass the paper's rules but sit on a face turned towards the cosmetic
    /// direction (counted only if not already kept out).
    pub cosmetic: usize,
    /// Nodes that pass every rule in force: the pool the gate is chosen from.
    pub qualifying: usize,
}

/// The gate chosen on the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gate {
    /// Node index (`iw * n_u + iu`).
    pub node: usize,
    /// Node column and row.
    pub node_iu_iw: (usize, usize),
    /// Node position in the projection plane.
    pub node_uw: DVec2,
    /// The gate point on the surface (first hit of the node's ray).
    pub point: DVec3,
    /// Outward unit normal of the triangle hit there.
    pub normal: DVec3,
    /// Index of that triangle.
    pub triangle: u32,
    /// Wall thickness along D at the node, if the ray leaves the solid.
    pub thickness_mm: Option<f64>,
    /// Smallest wall thickness along D over the node and its circle.
    pub disc_thickness_mm: Option<f64>,
    /// Whether the circle lies within the flatness tolerance.
    pub flat: bool,
    /// How far the circle reaches off the gate's height along D, mm (at most the flatness
    /// tolerance when `flat`).
    pub step_mm: f64,
    /// 3D distance from the gate point to the centre of mass.
    pub distance_3d: f64,
    /// Distance in the projection plane.
    pub distance_2d: f64,
    /// How many nodes were equally near (within round-off); the lowest index wins.
    pub ties: usize,
}

/// Seconds spent in each stage of [`locate`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct StageTimes {
    /// Centres of mass (taken from the part, which sums them at load, alongside the rays,
    /// before the parting line).
    pub centre_s: f64,
    /// Frame, projection of the vertices and grid.
    pub grid_s: f64,
    /// Casting the rays.
    pub projection_s: f64,
    /// Rules and selection.
    pub select_s: f64,
    /// Parting line and aesthetic gate. They are computed alongside the rays, so this time
    /// overlaps `projection_s` (the two share the threads).
    pub parting_s: f64,
    /// The whole of [`locate`], from start to end: less than the sum of the stages, since
    /// the centre of mass and the parting line overlap the rays.
    pub total_s: f64,
}

/// Everything [`locate`] found.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// Options in force (the spacing used is in `grid`).
    pub options: LocateOptions,
    /// Both centres of mass.
    pub centres: Centres,
    /// The centre the gate was placed by.
    pub centre: DVec3,
    /// The demolding frame.
    pub frame: Frame,
    /// The diagonal of the part's box in the mesh's axes, mm (the size the loader's units
    /// warning quotes).
    pub diagonal_mm: f64,
    /// The units the part was read in.
    pub units: crate::mesh::Units,
    /// The grid of nodes.
    pub grid: Grid,
    /// Flatness tolerance used, in mm.
    pub flat_tolerance_mm: f64,
    /// Nodes passing each rule.
    pub counts: RuleCounts,
    /// The thickest wall under a disc wholly on the part (the thickness rule's measure over
    /// the nodes of [`RuleCounts::circle_on_part`]), mm; `None` when none is known.
    pub thickest_disc_wall_mm: Option<f64>,
    /// Surface points (first hit of the node's ray) of every qualifying node, in node
    /// order; when the gate of the largest fitting radius is the answer
    /// ([`ThicknessFallback::LargestFitting`]), the nodes that qualify at that radius.
    pub qualifying_points: Vec<DVec3>,
    /// For each qualifying point, how far its node's circle reaches off its height along D,
    /// mm: above [`Analysis::flat_tolerance_mm`] the seat is not flat (a step, rib or
    /// slope). The fill's gates are qualifying points: their seats are warned by it.
    pub qualifying_step_mm: Vec<f32>,
    /// The nearest qualifying node, if any.
    pub grid_gate: Option<Gate>,
    /// The qualifying node nearest by the other measure (2D when the rule is 3D and back),
    /// since the paper does not say which distance it means.
    pub other_rule_gate: Option<Gate>,
    /// The parting line.
    pub parting: PartingLine,
    /// The point of the parting line nearest the centre.
    pub aesthetic_gate: Option<AestheticGate>,
    /// The largest gate radius that fits, searched when the thickness rule removed every
    /// node that passed the other rules (`None` otherwise).
    pub radius_fit: Option<RadiusFit>,
    /// Time per stage.
    pub times: StageTimes,
    /// Warnings about the analysis (not the mesh).
    pub warnings: Vec<String>,
}

/// The answer: a grid gate or an aesthetic gate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ChosenGate {
    /// The paper's grid gate.
    Paper(Gate),
    /// The parting-line gate.
    Aesthetic(AestheticGate),
}

impl ChosenGate {
    /// The gate point.
    pub fn point(&self) -> DVec3 {
        match self {
            ChosenGate::Paper(g) => g.point,
            ChosenGate::Aesthetic(g) => g.point,
        }
    }
}

impl Analysis {
    /// The gate of the chosen mode, or why there is none.
    pub fn gate(&self) -> Result<ChosenGate, LocateError> {
        match self.options.mode {
            GateMode::Paper => self
                .grid_gate
                .map(ChosenGate::Paper)
                .ok_or_else(|| LocateError::NoCandidate {
                    reason: self.why_no_candidate(),
                }),
            GateMode::Aesthetic => self.aesthetic_gate.map(ChosenGate::Aesthetic).ok_or_else(|| {
                LocateError::NoCandidate {
                    reason: if self.parting.edges_all == 0 {
                        "the part has no parting line for this demolding direction (no edge between a face towards +D and one away from it)".into()
                    } else if self.parting.edges.is_empty() {
                        format!(
                            "no parting line was kept of the part's {} edges between faces towards +D and away from it (--parting-line longest takes their longest loop)",
                            self.parting.edges_all
                        )
                    } else {
                        "the keep-out regions cover the whole parting line".into()
                    },
                }
            }),
        }
    }

    /// One sentence saying which rule removed the last nodes, with the largest gate radius
    /// that fits when it was the thickness rule, and what to try.
    pub fn why_no_candidate(&self) -> String {
        let mut s = self.rule_that_removed_the_last_nodes();
        if let Some(fit) = self.radius_fit.as_ref().filter(|f| !f.accepted) {
            s += &match (fit.radius_mm, &fit.gate) {
                (Some(r_fit), Some(g)) => format!(
                    "; the largest gate radius that fits is {r_fit:.3} mm, with the gate at ({:.3}, {:.3}, {:.3}) mm on a wall {} thick (--fit-radius takes it)",
                    g.point.x,
                    g.point.y,
                    g.point.z,
                    g.disc_thickness_mm
                        .map_or("of unknown".into(), |t| format!("{t:.3} mm")),
                ),
                _ => format!("; no gate radius down to {:.3} mm fits", fit.floor_mm),
            };
        }
        // A part whose size suggests other units fails for that reason more often than any,
        // so that comes first.
        let across = self.diagonal_mm;
        // The parting line's gate is suggested only when there is one (keep-out regions may
        // cover the whole line too), and not to a study that already asked for it.
        let aesthetic = if self.aesthetic_gate.is_some() && self.options.mode != GateMode::Aesthetic
        {
            ", or --aesthetic"
        } else {
            ""
        };
        let (comma, or) = if aesthetic.is_empty() {
            (" or", "")
        } else {
            (",", aesthetic)
        };
        if crate::mesh::units::size_is_suspicious(across) {
            s += &format!(
                "; the part is {across:.4} mm across as read in {}: {}; otherwise try a smaller gate radius or spacing{comma} another demolding direction{or}",
                self.units.long_name(),
                crate::mesh::units::units_advice(across, self.units)
            );
        } else if self.counts.kept_out + self.counts.cosmetic > 0 {
            // The designer's own regions took nodes: they come first.
            s += &format!(" (try smaller keep-out regions or no cosmetic side, a smaller gate radius or spacing{comma} another demolding direction{or})");
        } else {
            s += &format!(
                " (try a smaller gate radius or spacing{comma} another demolding direction{or})"
            );
        }
        s
    }

    /// The counts of the rules in force, up to the one that removed the last nodes.
    fn rule_that_removed_the_last_nodes(&self) -> String {
        let c = &self.counts;
        let r = self.options.gate_radius_mm;
        let mut s = format!(
            "of {} nodes, {} hit the part and {} have their whole circle of radius {r:.3} mm on it",
            c.nodes, c.centre_hits, c.circle_on_part
        );
        if self.options.thickness_rule == ThicknessRule::Require {
            s += &format!(
                "; {} of those have walls thicker than {r:.3} mm",
                c.thicker_than_radius + c.thickness_unknown
            );
            if let Some(th) = self.thickest_disc_wall_mm.filter(|&th| th <= r) {
                s += &format!(
                    " (the thickest {th:.3} mm; any thicker wall is too narrow for the disc)"
                );
            }
        }
        if self.options.flat_rule == FlatRule::Require {
            s += &format!("; {} are flat", c.flat);
        }
        if c.kept_out > 0 {
            s += &format!("; {} are kept out by the keep-out regions", c.kept_out);
        }
        if c.cosmetic > 0 {
            s += &format!("; {} lie on cosmetic faces", c.cosmetic);
        }
        s
    }

    /// True when the thickness rule removed every node that passed the other rules.
    fn thickness_removed_all(&self) -> bool {
        let c = &self.counts;
        self.options.thickness_rule == ThicknessRule::Require
            && self.options.mode == GateMode::Paper
            && self.grid_gate.is_none()
            && c.circle_on_part > 0
            && c.thicker_than_radius + c.thickness_unknown == 0
    }
}

/// The qualifying points of an analysis and their steps ([`Analysis::qualifying_points`],
/// [`Analysis::qualifying_step_mm`]).
type Qualifying = (Vec<DVec3>, Vec<f32>);

/// Searches the largest gate radius below `analysis`'s that fits (see [`RadiusFit`]).
/// Also the qualifying points at the radius found, and their steps (empty when none fits).
/// `None` when `cancel` stopped the search during its first run.
fn largest_fitting_radius(
    part: &LoadedMesh,
    analysis: &Analysis,
    cancel: Option<&crate::cancel::Cancel>,
) -> Result<Option<(RadiusFit, Qualifying)>, OptionsError> {
    let refused = analysis.options.gate_radius_mm;
    let options = LocateOptions {
        spacing: Spacing::Mm(analysis.grid.spacing),
        thickness_fallback: ThicknessFallback::Report,
        mode: GateMode::Paper,
        ..analysis.options.clone()
    };
    let mut probes = 0;
    // A probe's gate, or `None` when the search was stopped during it (its rays cut short,
    // so it tells nothing).
    type Probe = Option<Option<(Gate, Qualifying)>>;
    let mut gate_at = |r: f64| -> Result<Probe, OptionsError> {
        let o = LocateOptions {
            gate_radius_mm: r,
            ..options.clone()
        };
        // A probe needs the nodes only: not the parting line.
        let a = match locate_once(part, &o, Parting::Skip, cancel) {
            Err(OptionsError::Stopped) => return Ok(None),
            a => a?,
        };
        probes += 1;
        Ok(Some(
            a.grid_gate
                .map(|g| (g, (a.qualifying_points, a.qualifying_step_mm))),
        ))
    };
    let floor = refused / FIT_FLOOR_DIVISOR;
    let Some(first) = gate_at(floor)? else {
        return Ok(None);
    };
    let mut best = first.map(|g| (floor, g));
    if best.is_some() {
        let (mut lo, mut hi) = (floor, refused);
        for _ in 0..FIT_STEPS {
            // Stopped, the search keeps the largest radius found so far.
            if crate::cancel::is_set(cancel) {
                break;
            }
            let mid = 0.5 * (lo + hi);
            match gate_at(mid)? {
                Some(Some(g)) => {
                    lo = mid;
                    best = Some((mid, g));
                }
                Some(None) => hi = mid,
                None => break,
            }
        }
    }
    let radius_mm = best.as_ref().map(|b| b.0);
    let (gate, points) = best.map_or((None, Default::default()), |(_, (g, p))| (Some(g), p));
    let fit = RadiusFit {
        refused_mm: refused,
        floor_mm: floor,
        radius_mm,
        gate,
        probes,
        reason: analysis.rule_that_removed_the_last_nodes(),
        accepted: false,
        thickest_wall_mm: analysis.thickest_disc_wall_mm,
    };
    Ok(Some((fit, points)))
}

/// Locates the gate on a loaded part: the paper's algorithm, end to end.
///
/// Does no I/O. Fails only on invalid options; a part where no node qualifies is an
/// [`Analysis`] whose [`Analysis::gate`] says why.
pub fn locate(part: &LoadedMesh, options: &LocateOptions) -> Result<Analysis, OptionsError> {
    locate_until(part, options, None)
}

/// [`locate`] that a set `cancel` token cuts short where it may: the search for the largest
/// radius that fits (up to 1 + [`FIT_STEPS`] runs of the rays) stops within its run,
/// keeping what its earlier runs found; the gate's own rays stop within a block of
/// triangles, and then there is no analysis ([`OptionsError::Stopped`]). The caller reads
/// the token after it returns.
pub fn locate_until(
    part: &LoadedMesh,
    options: &LocateOptions,
    cancel: Option<&crate::cancel::Cancel>,
) -> Result<Analysis, OptionsError> {
    let start = Instant::now();
    let mut analysis = locate_once(part, options, Parting::Find, cancel)?;
    if !analysis.thickness_removed_all() {
        return Ok(analysis);
    }
    let searched = match fit_search_skipped(part, &analysis, cancel) {
        Some(why) => Err(why),
        None => largest_fitting_radius(part, &analysis, cancel)?.ok_or_else(|| {
            "the search for the largest gate radius that fits was stopped during its first run (time limit or cancel): no radius was found".to_string()
        }),
    };
    let (mut fit, points) = match searched {
        Ok(found) => found,
        Err(why) => {
            analysis.warnings.push(why);
            return Ok(analysis);
        }
    };
    if fit.probes < 1 + FIT_STEPS && fit.radius_mm.is_some() {
        analysis.warnings.push(format!(
            "the search for the largest gate radius that fits was stopped (time limit or cancel) after {} of its {} runs: a larger radius may fit",
            fit.probes,
            1 + FIT_STEPS
        ));
    }
    if options.thickness_fallback == ThicknessFallback::LargestFitting {
        if let (Some(r_fit), Some(gate)) = (fit.radius_mm, fit.gate) {
            analysis.warnings.push(format!(
                "no node passes the thickness rule with R_gate = {:.3} mm ({}); the gate is the one of the largest radius that fits, {r_fit:.3} mm",
                fit.refused_mm, fit.reason
            ));
            analysis.grid_gate = Some(gate);
            // The radius in force is the fitted one: the picture's disc, the report and the
            // fill's gates (their spacing, their seats) read it.
            analysis.options.gate_radius_mm = r_fit;
            // And the flatness tolerance that follows it, as the runs at that radius judged
            // their seats.
            analysis.flat_tolerance_mm = options.flat_tolerance_at(r_fit);
            // The nodes that qualify at that radius: the fill's candidates (the balanced
            // gate, several gates, the suitability map).
            (analysis.qualifying_points, analysis.qualifying_step_mm) = points;
            fit.accepted = true;
        }
    }
    analysis.radius_fit = Some(fit);
    analysis.times.total_s = start.elapsed().as_secs_f64();
    Ok(analysis)
}

/// Why the search for the largest radius that fits is not run on `analysis`, if it is not:
/// the study was stopped, or its runs of the rays would pass [`RAY_TEST_BUDGET`].
fn fit_search_skipped(
    part: &LoadedMesh,
    analysis: &Analysis,
    cancel: Option<&crate::cancel::Cancel>,
) -> Option<String> {
    if crate::cancel::is_set(cancel) {
        return Some(
            "the search for the largest gate radius that fits was not run: the study was stopped (time limit or cancel)".into(),
        );
    }
    // Over its share of the budget, a run's estimate is the projected areas' (exact).
    let (spacing, points) = (analysis.grid.spacing, analysis.options.circle_points);
    let cap = RAY_TEST_BUDGET / FIT_RUNS;
    let tests = ray_tests_within(part, &analysis.frame, spacing, points, cap) * FIT_RUNS;
    (tests > RAY_TEST_BUDGET).then(|| {
        format!(
            "the search for the largest gate radius that fits was not run: its {FIT_RUNS} runs of the rays would make about {tests:.1e} ray-triangle tests, over the budget of {RAY_TEST_BUDGET:.0e} (the part's surface lies many layers deep along D)"
        )
    })
}

/// Whether [`locate_once`] finds the parting line.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Parting {
    Find,
    Skip,
}

/// [`locate`] without the radius search.
fn locate_once(
    part: &LoadedMesh,
    options: &LocateOptions,
    find_parting: Parting,
    cancel: Option<&crate::cancel::Cancel>,
) -> Result<Analysis, OptionsError> {
    let mesh = &part.mesh;
    let r = options.gate_radius_mm;
    options.validate()?;
    let start = Instant::now();
    let mut warnings = Vec::new();
    let mut times = StageTimes::default();

    let t = Instant::now();
    let frame = Frame::new(options.direction);
    // The box of the part seen along D, and its box in the mesh's axes (whose diagonal the
    // loader's size warning gives, so that a message about the units quotes the same size).
    let empty = || {
        let (lo, hi) = (f64::INFINITY, f64::NEG_INFINITY);
        (DVec2::splat(lo), DVec2::splat(hi), Aabb::EMPTY)
    };
    let (lo, hi, bounds) = mesh
        .vertices
        .par_iter()
        .fold(empty, |(lo, hi, b), &p| {
            let q = frame.project(p);
            (lo.min(q), hi.max(q), b.grown(p))
        })
        .reduce(empty, |a, b| {
            (
                a.0.min(b.0),
                a.1.max(b.1),
                a.2.grown(b.2.min).grown(b.2.max),
            )
        });
    let spacing = match options.spacing {
        Spacing::Auto => auto_spacing(hi - lo, r),
        Spacing::Mm(h) => h,
    };
    let grid = match Grid::new(lo, hi, spacing, options.grid_offset, options.max_nodes) {
        // The automatic spacing is the gate's size: a grid too large for it is the part's
        // size at fault (most often its units), not an option's.
        Err(OptionsError::GridTooLarge {
            nodes,
            limit,
            min_spacing_mm,
            ..
        }) if options.spacing == Spacing::Auto => {
            return Err(OptionsError::PartTooLarge {
                span_mm: (hi - lo).max_element(),
                spacing_mm: spacing,
                nodes,
                limit,
                min_spacing_mm,
            })
        }
        grid => grid?,
    };
    check_ray_memory(&grid, options.circle_points)?;
    check_machine_memory(&grid, options.circle_points)?;
    check_ray_tests(part, &frame, &grid, options.circle_points, lo, hi)?;
    let flat_tolerance_mm = options.flat_tolerance_at(r);
    if !(flat_tolerance_mm.is_finite() && flat_tolerance_mm >= 0.0) {
        return Err(OptionsError::NonPositive {
            option: "flatness tolerance",
            value: flat_tolerance_mm,
        });
    }
    // The node lattice, and for each circle point k the node lattice shifted by
    // R (cos theta_k, sin theta_k) (Eq. 6).
    let k = options.circle_points;
    let node_lattice = RayLattice {
        origin: DVec2::from_array(grid.first),
        spacing,
        n_u: grid.n_u,
        n_w: grid.n_w,
    };
    let circle_lattices = circle_lattices(&node_lattice, r, k);
    times.grid_s = t.elapsed().as_secs_f64();

    // The rays need neither the centre of mass nor the parting line: the two run side by
    // side with them, and their sequential steps fill time the rays would leave a thread
    // idle.
    let ((hits, projection_s), (centres, centre, parting, aesthetic_gate, parting_s)) = rayon::join(
        || {
            let t = Instant::now();
            let hits = projection::cast_until(
                &mesh.vertices,
                &frame,
                &mesh.triangles,
                &node_lattice,
                &circle_lattices,
                cancel,
            );
            // Set by now, the token may have cut the rays short: no hit is used.
            let hits = (!crate::cancel::is_set(cancel)).then_some(hits);
            (hits, t.elapsed().as_secs_f64())
        },
        || {
            let t = Instant::now();
            let centres = part.centres;
            // The surface centre when the mesh encloses no volume (warned below).
            let centre = centres.get(options.centre).unwrap_or(centres.surface);
            times.centre_s = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let parting = match (find_parting, options.parting) {
                (Parting::Skip, _) => PartingLine::default(),
                (_, PartingRule::Longest) => PartingLine::new(mesh, &part.topology, &frame),
                (_, PartingRule::Outline) => PartingLine::outline(mesh, &part.topology, &frame),
            };
            let aesthetic_gate = options.parting_gate(&parting, mesh, &frame, centre, |_| true);
            (
                centres,
                centre,
                parting,
                aesthetic_gate,
                t.elapsed().as_secs_f64(),
            )
        },
    );
    if centres.get(options.centre).is_none() {
        warnings.push("the mesh encloses no volume, so the surface centre of mass is used".into());
    } else if options.centre == crate::centre::CentreKind::Volume && part.topology.open_edges > 0 {
        // An open surface encloses no definite volume: its sum depends on where the hole is
        // closed, straight across from the origin.
        warnings.push(format!(
            "the mesh is open ({} edges of one facet), so the volume centre of mass is that of the surface closed across its holes by straight lines to a point, not of the solid: close the mesh, or use the surface centre (the default)",
            part.topology.open_edges
        ));
    }
    // A body whose outline the rule could not close (walls seen at a slant) has its
    // longest loop instead: said, as the line in the pictures is then not the outline.
    let fell_back: Vec<&crate::parting::Rim> = parting.longest_loop_rims().collect();
    if !fell_back.is_empty() {
        let whose = if parting.rims.len() == 1 {
            "the part".to_string()
        } else {
            let numbers: Vec<String> = fell_back.iter().map(|r| (r.body + 1).to_string()).collect();
            format!(
                "{} {}",
                if numbers.len() == 1 { "body" } else { "bodies" },
                numbers.join(", ")
            )
        };
        warnings.push(format!(
            "no closed rim runs round the outline of {whose} seen along D (its walls do not run along D, so the outline is made of edges at different depths that no edges near it join): the parting line there is the longest loop of edges between faces towards +D and faces away from it ({:.1} mm, {}), the silhouette seen along D; check it in the picture",
            fell_back.iter().map(|r| r.length_mm).sum::<f64>(),
            if fell_back.iter().all(|r| r.closed) { "closed" } else { "open" },
        ));
    }
    // The aesthetic gate on a line that is not one closed rim may sit on a hole, a thread or
    // an inner edge rather than where the mould splits.
    if let (GateMode::Aesthetic, Some(g)) = (options.mode, &aesthetic_gate) {
        if !parting.edges.is_empty() && !parting.closed {
            warnings.push(format!(
                "the parting line the aesthetic gate lies on is open ({:.1} mm long, the line kept of {} connected pieces of edges between the two sides): the gate at ({:.3}, {:.3}, {:.3}) mm may sit on a hole, a thread or an inner edge, not on the rim where the mould splits; {}",
                parting.length_mm,
                parting.loops,
                g.point.x,
                g.point.y,
                g.point.z,
                match options.parting {
                    PartingRule::Longest => "the default line (--parting-line outline) is the part's outer rim, closed",
                    PartingRule::Outline => "check the mesh's rim there",
                }
            ));
        }
    }
    let hits = hits.ok_or(OptionsError::Stopped)?;
    times.projection_s = projection_s;
    times.parting_s = parting_s;

    let t = Instant::now();
    let centre_hits = &hits.nodes;
    let nodes: Vec<NodeVerdict> = (0..grid.len())
        .into_par_iter()
        .map(|i| judge(i, &hits, flat_tolerance_mm))
        .collect();
    let mut counts = RuleCounts {
        nodes: grid.len(),
        ..RuleCounts::default()
    };
    let mut thickest_disc_wall_mm: Option<f64> = None;
    for v in &nodes {
        counts.centre_hits += v.centre_hit as usize;
        counts.circle_on_part += v.circle_on_part as usize;
        if v.circle_on_part {
            if let Some(th) = v.disc_thickness {
                thickest_disc_wall_mm = Some(thickest_disc_wall_mm.map_or(th, |t| t.max(th)));
            }
            match v.disc_thickness {
                Some(th) if th > r => counts.thicker_than_radius += 1,
                Some(_) => {}
                None => counts.thickness_unknown += 1,
            }
            counts.flat += v.flat as usize;
        }
    }
    let qualifies = |v: &NodeVerdict| {
        v.circle_on_part
            && (options.thickness_rule == ThicknessRule::Ignore
                || v.disc_thickness.is_none_or(|th| th > r))
            && (options.flat_rule == FlatRule::Report || v.flat)
    };
    let oriented_normal = |t: u32| {
        let n = mesh.normal(t as usize);
        if n.dot(frame.d) < 0.0 {
            -n
        } else {
            n
        }
    };
    let mut pool = Vec::new();
    // Which keep-out regions keep some node out: one that keeps none out is said.
    let mut region_used = vec![false; options.keep_out.len()];
    for i in (0..grid.len()).filter(|&i| qualifies(&nodes[i])) {
        let hit = centre_hits[i];
        let p = frame.point(grid.node(i), hit.first);
        let mut kept = false;
        for (used, k) in region_used.iter_mut().zip(&options.keep_out) {
            if k.touches(p, r) {
                *used = true;
                kept = true;
            }
        }
        if kept {
            counts.kept_out += 1;
        } else if options.cosmetic.is_some_and(|c| {
            oriented_normal(hit.triangle).dot(c.vector()) > crate::keepout::COSMETIC_COS
        }) {
            counts.cosmetic += 1;
        } else {
            pool.push(i);
        }
    }
    counts.qualifying = pool.len();
    // The aesthetic gate is the parting line's point nearest the centre of mass outside the
    // regions: a region that holds that point of the whole line moved the gate.
    if options.mode == GateMode::Aesthetic && !options.keep_out.is_empty() {
        let free = options.parting_gate_ignoring_keep_outs(&parting, mesh, &frame, centre);
        if let Some(g) = free {
            for (used, k) in region_used.iter_mut().zip(&options.keep_out) {
                *used |= k.touches(g.point, r);
            }
        }
    }
    for (k, region) in options.keep_out.iter().enumerate() {
        if !region_used[k] {
            warnings.push(format!(
                "keep-out region {} ({}) keeps out no node that qualifies{}: {}",
                k + 1,
                region.describe(),
                if options.mode == GateMode::Aesthetic {
                    " nor the aesthetic gate's point of the parting line"
                } else {
                    ""
                },
                match region.meets_box(bounds.min, bounds.max, r) {
                    false => "it lies outside the part's box (check its coordinates and units)",
                    true =>
                        "no node that passes the paper's rules lies within the gate radius of it",
                }
            ));
        }
    }
    let qualifying_points = pool
        .iter()
        .map(|&i| frame.point(grid.node(i), centre_hits[i].first))
        .collect();
    let qualifying_step_mm = pool.iter().map(|&i| nodes[i].step as f32).collect();
    let pick = |rule: Nearest| {
        nearest_node(&pool, &grid, &frame, centre, centre_hits, rule).map(|(i, ties)| {
            let hit = centre_hits[i];
            let node_uw = grid.node(i);
            let point = frame.point(node_uw, hit.first);
            // A ray that met the triangle from its back means the winding is inverted.
            let normal = oriented_normal(hit.triangle);
            Gate {
                node: i,
                node_iu_iw: grid.coords(i),
                node_uw,
                point,
                normal,
                triangle: hit.triangle,
                thickness_mm: hit.thickness(),
                disc_thickness_mm: nodes[i].disc_thickness,
                flat: nodes[i].flat,
                step_mm: nodes[i].step,
                distance_3d: point.distance(centre),
                distance_2d: node_uw.distance(frame.project(centre)),
                ties,
            }
        })
    };
    let grid_gate = pick(options.nearest);
    if let Some(g) = grid_gate.filter(|g| !g.flat) {
        // Where the gate would be on a flat seat: the node `--require-flat` takes.
        let flat: Vec<usize> = pool.iter().copied().filter(|&i| nodes[i].flat).collect();
        let seat = nearest_node(&flat, &grid, &frame, centre, centre_hits, options.nearest)
            .map(|(i, _)| frame.point(grid.node(i), centre_hits[i].first));
        warnings.push(not_flat_warning(
            nodes[g.node].step,
            flat_tolerance_mm,
            seat.map(|p| (p, p.distance(g.point))),
        ));
    }
    let other_rule_gate = pick(match options.nearest {
        Nearest::Surface3d => Nearest::Plane2d,
        Nearest::Plane2d => Nearest::Surface3d,
    });
    times.select_s = t.elapsed().as_secs_f64();
    times.total_s = start.elapsed().as_secs_f64();

    Ok(Analysis {
        options: options.clone(),
        centres,
        centre,
        frame,
        diagonal_mm: bounds.diagonal(),
        units: part.stats.units,
        grid,
        flat_tolerance_mm,
        counts,
        thickest_disc_wall_mm,
        qualifying_points,
        qualifying_step_mm,
        grid_gate,
        other_rule_gate,
        parting,
        aesthetic_gate,
        radius_fit: None,
        times,
        warnings,
    })
}

/// Refuses a part whose triangles overlap so deeply along the demolding direction that the
/// rays would make more than [`RAY_TEST_BUDGET`] ray-triangle tests. A triangle covers
/// about (projected area / spacing^2) rays of each lattice; the surface area bounds the sum
/// of projected areas, so for most parts the check costs nothing, and the projected areas
/// are summed (one pass over the triangles) only when the bound is over the budget.
fn check_ray_tests(
    part: &LoadedMesh,
    frame: &Frame,
    grid: &Grid,
    circle_points: usize,
    lo: DVec2,
    hi: DVec2,
) -> Result<(), OptionsError> {
    let ray_tests = ray_tests_within(part, frame, grid.spacing, circle_points, RAY_TEST_BUDGET);
    if ray_tests <= RAY_TEST_BUDGET {
        return Ok(());
    }
    // Over the cap, the tests are the projected areas' (not the bound).
    let projected = ray_tests / ray_tests_per_area(grid.spacing, circle_points);
    let span = hi - lo;
    Err(OptionsError::OverlappingSurface {
        depth: projected / (span.x * span.y).max(grid.spacing * grid.spacing),
        ray_tests,
        budget: RAY_TEST_BUDGET,
    })
}

/// The rays of every lattice (the node's and each circle point's) per mm^2 of projected
/// triangle.
fn ray_tests_per_area(spacing: f64, circle_points: usize) -> f64 {
    (1 + circle_points) as f64 / (spacing * spacing)
}

/// The ray-triangle tests of one run of the rays, estimated from the triangles' projected
/// areas: the surface area's bound when it is within `cap` (no pass over the triangles),
/// else the sum of the projected areas.
fn ray_tests_within(
    part: &LoadedMesh,
    frame: &Frame,
    spacing: f64,
    circle_points: usize,
    cap: f64,
) -> f64 {
    let per_area = ray_tests_per_area(spacing, circle_points);
    let bound = part.stats.area_mm2 * per_area;
    if bound <= cap {
        return bound;
    }
    projected_area(part, frame) * per_area
}

/// The sum of the triangles' areas projected along the frame's D, mm^2.
fn projected_area(part: &LoadedMesh, frame: &Frame) -> f64 {
    let mesh = &part.mesh;
    mesh.triangles
        .par_chunks(16 * 1024)
        .map(|block| {
            block
                .iter()
                .map(|&[a, b, c]| {
                    let [a, b, c] = [a, b, c].map(|v| frame.project(mesh.vertices[v as usize]));
                    0.5 * crate::math::orient2d(a, b, c).abs()
                })
                .sum::<f64>()
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum()
}

/// For each of the `k` circle points, the node lattice shifted by
/// R (cos theta_k, sin theta_k) (Eq. 6).
fn circle_lattices(nodes: &RayLattice, r: f64, k: usize) -> Vec<RayLattice> {
    (0..k)
        .map(|i| {
            let theta = std::f64::consts::TAU * i as f64 / k as f64;
            RayLattice {
                origin: nodes.origin + DVec2::new(theta.cos(), theta.sin()) * r,
                ..*nodes
            }
        })
        .collect()
}

/// The rays of a node at each of `nodes_uw` in the projection plane (not necessarily on the
/// grid) and of its circle, with the options and frame of `analysis`: what [`locate`] casts
/// for each grid node, for gates placed anywhere ([`crate::study::judge`]). One pass over
/// the triangles keeps, for each node, those whose projected box meets its disc's square;
/// each node's rays are then cast against those alone.
pub(crate) fn rays_at(
    mesh: &crate::mesh::Mesh,
    analysis: &Analysis,
    nodes_uw: &[DVec2],
) -> Vec<(Hit, NodeVerdict)> {
    let o = &analysis.options;
    let frame = &analysis.frame;
    let r = o.gate_radius_mm;
    let n = nodes_uw.len();
    let lists: Vec<Vec<[u32; 3]>> = mesh
        .triangles
        .par_chunks(4096)
        .map(|chunk| {
            let mut lists = vec![Vec::new(); n];
            for &tri in chunk {
                let [a, b, c] = tri.map(|v| frame.project(mesh.vertices[v as usize]));
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                for (list, q) in lists.iter_mut().zip(nodes_uw) {
                    // A margin beyond R so that round-off never drops a triangle the rays meet.
                    let reach = r * (1.0 + 1e-6) + 1e-6 * (1.0 + q.abs().max_element());
                    if lo.x <= q.x + reach
                        && hi.x >= q.x - reach
                        && lo.y <= q.y + reach
                        && hi.y >= q.y - reach
                    {
                        list.push(tri);
                    }
                }
            }
            lists
        })
        .reduce(
            || vec![Vec::new(); n],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    x.extend(y);
                }
                a
            },
        );
    nodes_uw
        .iter()
        .zip(&lists)
        .map(|(&uw, triangles)| {
            let node = RayLattice {
                origin: uw,
                spacing: analysis.grid.spacing,
                n_u: 1,
                n_w: 1,
            };
            let circles = circle_lattices(&node, r, o.circle_points);
            let hits = projection::cast(&mesh.vertices, frame, triangles, &node, &circles);
            (hits.nodes[0], judge(0, &hits, analysis.flat_tolerance_mm))
        })
        .collect()
}

/// What the rays of one node found.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NodeVerdict {
    /// The node's own ray meets the part.
    pub(crate) centre_hit: bool,
    /// It and every circle ray meet the part.
    pub(crate) circle_on_part: bool,
    /// The smallest wall along D under the node and its circle.
    pub(crate) disc_thickness: Option<f64>,
    /// Every circle point within the flatness tolerance of the node's height.
    pub(crate) flat: bool,
    /// How far the circle reaches off the node's height along D, mm (when it is on the
    /// part; else 0).
    pub(crate) step: f64,
}

/// The warning of a grid gate whose circle is not flat (the paper does not require it, so
/// the gate may sit on a step or a rib): how far its circle's points lie from the gate's
/// height along D. It is one of the analysis's warnings, so every front end (the summary,
/// the JSON, the page, the batch rows) says it alike. `step` is the node's
/// ([`NodeVerdict::step`]).
fn not_flat_warning(step: f64, flat_tol: f64, seat: Option<(DVec3, f64)>) -> String {
    let instead = match seat {
        Some((p, d)) => format!(
            "the nearest flat seat is at ({:.3}, {:.3}, {:.3}) mm, {d:.2} mm away (--require-flat keeps only flat nodes)",
            p.x, p.y, p.z
        ),
        None => "no qualifying node is flat".into(),
    };
    format!(
        "the grid gate's disc is not flat: its circle reaches {step:.2} mm off the gate's height along D (a step, rib or slope; flatness tolerance {flat_tol:.3} mm); {instead}"
    )
}

fn judge(i: usize, hits: &Projection, flat_tol: f64) -> NodeVerdict {
    let c = hits.nodes[i];
    let circle = |k: usize| hits.circle(k, i);
    let circles = 0..hits.circle_count();
    let circle_on_part = c.is_hit() && circles.clone().all(|k| circle(k).is_some());
    let disc_thickness = std::iter::once(c.thickness())
        .chain(circles.clone().map(|k| circle(k).and_then(|p| p.thickness)))
        .flatten()
        .reduce(f64::min);
    let step = match circle_on_part {
        true => circles
            .filter_map(circle)
            .map(|p| (p.height - c.first).abs())
            .fold(
                0.0f64,
                |m, d| if d.is_nan() { f64::INFINITY } else { m.max(d) },
            ),
        false => 0.0,
    };
    let flat = circle_on_part && step <= flat_tol;
    NodeVerdict {
        centre_hit: c.is_hit(),
        circle_on_part,
        disc_thickness,
        flat,
        step,
    }
}

/// The pool node nearest `centre` by `rule`, and how many tie with it. Distances within
/// 1e-9 of the larger of the best distance and the spacing count as ties, and the lowest node
/// index wins, so the answer does not depend on thread scheduling or summation order.
fn nearest_node(
    pool: &[usize],
    grid: &Grid,
    frame: &Frame,
    centre: DVec3,
    hits: &[Hit],
    rule: Nearest,
) -> Option<(usize, usize)> {
    let c2 = frame.project(centre);
    let distance = |i: usize| {
        let q = grid.node(i);
        match rule {
            Nearest::Surface3d => frame.point(q, hits[i].first).distance(centre),
            Nearest::Plane2d => q.distance(c2),
        }
    };
    let d: Vec<f64> = pool.iter().map(|&i| distance(i)).collect();
    let best = d.iter().copied().reduce(f64::min)?;
    let tol = 1e-9 * best.max(grid.spacing);
    let mut near = pool.iter().zip(&d).filter(|(_, &di)| di <= best + tol);
    let (&first, _) = near.next()?;
    Some((first, 1 + near.count()))
}
