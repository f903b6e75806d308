//! Running a study, and what it gives.

use std::sync::{Arc, OnceLock};

use crate::clock::Instant;
use crate::display::Display;

use crate::flow::{self, FillAnalysis, FillError, FillOptions, Strategy};
use crate::gate::{Analysis, ChosenGate, GateMode};
use crate::math::DVec3;
use crate::mesh::LoadedMesh;
use crate::raycast::{Bvh, Sampling};
use crate::render::RenderOptions;
use crate::report::{AnswerGate, Input, Report};
use crate::scene::{Field, Marker, Scene};
use crate::study::{judge, ColorByChoice, Demold, Hooks, Settings, Stage, StudyError};

/// Why a fill asked for was not made on a part without a gate.
const NO_FILL_WITHOUT_GATE: &str =
    "no fill analysis: it starts from the method's gate, and this part has none";
use crate::thickness::{wall_thickness_until, Known, ThicknessOptions, WallThickness};
use crate::undercut::auto_direction_beside_loaded_until;

/// One gate of the answer, as pictures and 3D files show it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GateMarker {
    /// The gate point on the surface, mm.
    pub point: DVec3,
    /// Outward unit normal of the surface there (zero when no triangle is near).
    pub normal: DVec3,
}

/// A finished study of one part: the analysis, its optional parts, and what front ends
/// show of it. It does not hold the mesh: the methods that draw take the part that was
/// studied (and refuse another one).
#[derive(Debug, Clone)]
pub struct Study {
    report: Report,
    analysis: Analysis,
    wall: Option<WallThickness>,
    wall_per_vertex: Option<Vec<f32>>,
    /// What the fill's pictures are coloured by, when the fill ran.
    colour_by: Option<flow::ColourBy>,
    /// Whether the pictures show the wall of every facet when it was measured: without the
    /// fill (which pictures its own fields), unless the height is asked for (`color_by =
    /// "height"`); the fill's colourings have no field then, and the wall map is what the
    /// study measured.
    pictures_wall: bool,
    gates: Vec<GateMarker>,
    /// On a part of several bodies, the own gate of each body the answer's gates do not
    /// reach (by body), drawn with the fill those bodies are shown with.
    body_gates: Vec<(u32, GateMarker)>,
    /// The designer's gates on the surface (`gate_at`).
    placed: Vec<GateMarker>,
    subtitle: String,
    material_name: String,
    size: (usize, usize),
    /// The part refined to the fill field's cells ([`crate::display::refine`]), made the
    /// first time a scene needs it and shared by every later one (the PNG, the GLB and the
    /// HTML page of one run draw the same surface); `None` inside when nothing is refined.
    display: OnceLock<Option<Arc<Display>>>,
}

/// Fewer grid nodes on the part than this (10 x 10) draw a warning: the grid is too coarse
/// for the gate to mean much.
pub const MIN_NODES_ON_PART: usize = 100;

/// The usual share of each stage in the time of a study (for [`crate::study::Progress`]).
fn fraction(stage: Stage) -> f64 {
    match stage {
        Stage::Tree => 0.0,
        Stage::Demold => 0.1,
        Stage::Locate => 0.2,
        Stage::WallThickness => 0.4,
        Stage::Fill => 0.5,
        Stage::Report => 1.0,
    }
}

/// What the ray tree (and the fill's cells) were made beside, and the wall time of that
/// join: the tree counts only the time it ran past the other side.
#[derive(Debug, Clone, Copy)]
enum Joined {
    /// The gate search along the given direction.
    Locate(f64),
    /// The choice of the automatic direction (with the gate search inside it).
    Demold(f64),
}

pub(super) fn run(part: &LoadedMesh, s: &Settings, hooks: &Hooks) -> Result<Study, StudyError> {
    let mesh = &part.mesh;
    let enter = |stage: Stage| hooks.enter(stage, fraction(stage));
    // The designer's gates onto the surface first: a point far from the part is refused
    // before any other work.
    let snapped = judge::snap(mesh, &s.gate_at)?;
    // One ray-casting tree serves the wall thickness and the fill analysis (for its flow
    // resistance); the automatic direction draws its rays without one. Under the automatic
    // direction an aesthetic gate's normal is the nearest triangle's, found in the tree: made
    // beside the choice too.
    let auto_demold = s.demold == Demold::Auto;
    let aesthetic_normal = auto_demold && s.locate.mode == GateMode::Aesthetic;
    let wants_tree = s.wall_thickness || s.fill.is_some() || aesthetic_normal;
    // The fill alone casts one ray per surface cell (a few per cent of the facets), and an
    // aesthetic gate's normal asks one nearest triangle: a tree a fifth as dear to build,
    // whose queries cost a fifth more, gives them the same rays and nearest triangles
    // (`Bvh::new_morton`). The wall of every facet takes the tree of the fastest queries.
    let morton = !s.wall_thickness;
    let build_tree = || {
        let t = Instant::now();
        let bvh = match morton {
            true => Bvh::new_morton(mesh),
            false => Bvh::new(mesh),
        };
        (bvh, t.elapsed().as_secs_f64())
    };
    let mut options = s.locate.clone();
    // With the demolding direction given, the gate does not need the tree: both are built
    // at once (on a machine of two threads the tree costs about as much as the gate).
    // The wall time of the tree and locate together, when built alongside.
    // The fill's bodies and cells need neither the gate nor the tree (only the mesh, its
    // centres summed at load and the limits): made beside them too, they fill the gaps
    // of both threads (the bodies are one serial pass).
    let mut joined_s = None;
    let mut cells = None;
    let prepare = || {
        s.fill
            .as_ref()
            .map(|o| flow::prepare_with(mesh, &part.centres, Some(&part.topology), o, hooks.cancel))
    };
    let (mut bvh, mut tree_s, located) = if wants_tree && !auto_demold {
        enter(Stage::Tree)?;
        enter(Stage::Locate)?;
        let t = Instant::now();
        let (((bvh, tree_s), prepared), located) = rayon::join(
            || rayon::join(build_tree, prepare),
            || crate::gate::locate_until(part, &options, hooks.cancel),
        );
        cells = prepared;
        joined_s = Some(Joined::Locate(t.elapsed().as_secs_f64()));
        (Some(bvh), tree_s, Some(located))
    } else {
        // No tree, or, with the automatic direction, one made beside its choice (below).
        (None, 0.0, None)
    };
    let mut demold_s = None;
    // Whether the gate was located inside the choice of the direction (beside its rays).
    let mut located_beside = false;
    let (auto, located) = match auto_demold {
        true => {
            if wants_tree {
                enter(Stage::Tree)?;
            }
            enter(Stage::Demold)?;
            let t = Instant::now();
            let locate_along = |d| {
                let o = crate::LocateOptions {
                    direction: d,
                    ..options.clone()
                };
                crate::gate::locate_until(part, &o, hooks.cancel)
            };
            // Lines still tied after the shallowest draw go to one on which a gate
            // qualifies; the line located beside the rays is not located again.
            let gate_qualifies = |d, done: Option<&Result<Analysis, _>>| match done {
                Some(located) => located.as_ref().is_ok_and(|a| a.gate().is_ok()),
                None => locate_along(d).is_ok_and(|a| a.gate().is_ok()),
            };
            // The gate along the first line drawn ray by ray (nearly always the one chosen)
            // is located while its rays are drawn: locate does not depend on them, and the
            // two together keep both threads busy. Along another line it is located again.
            // The tree and the fill's cells need no direction: made beside the choice,
            // they fill the gaps its steps leave on both threads.
            let choose = || {
                let t = Instant::now();
                let chosen = auto_direction_beside_loaded_until(
                    part,
                    Sampling::Centroid,
                    locate_along,
                    gate_qualifies,
                    hooks.cancel,
                );
                (chosen, t.elapsed().as_secs_f64())
            };
            let ((chosen, choice_s), made) = match wants_tree {
                true => {
                    let (chosen, made) = rayon::join(choose, || rayon::join(build_tree, prepare));
                    (chosen, Some(made))
                }
                false => (choose(), None),
            };
            if let Some(((tree, built_s), prepared)) = made {
                bvh = Some(tree);
                tree_s = built_s;
                cells = prepared;
                joined_s = Some(Joined::Demold(t.elapsed().as_secs_f64()));
            }
            let (auto, early) = chosen.map_err(|e| match e {
                crate::undercut::DemoldError::Cancelled => StudyError::Cancelled {
                    stage: Stage::Demold,
                    located: None,
                },
                e => StudyError::Demold(e),
            })?;
            demold_s = Some(choice_s);
            options.direction = auto.direction();
            let located = match early {
                Some((d, located)) if d == options.direction => {
                    located_beside = true;
                    Some(located)
                }
                _ => located,
            };
            (Some(auto), located)
        }
        false => (None, located),
    };
    let located = match located {
        Some(located) if located_beside => {
            enter(Stage::Locate)?;
            located
        }
        Some(located) => located,
        None => {
            enter(Stage::Locate)?;
            crate::gate::locate_until(part, &options, hooks.cancel)
        }
    };
    let mut analysis = located.map_err(|e| match e {
        // Its rays stopped by the token: no gate to report.
        crate::OptionsError::Stopped => StudyError::Cancelled {
            stage: Stage::Locate,
            located: None,
        },
        e => StudyError::Locate(e),
    })?;
    analysis.warnings.extend(s.warnings.iter().cloned());
    if analysis.counts.centre_hits < MIN_NODES_ON_PART {
        analysis.warnings.push(format!(
            "only {} grid nodes fall on the part (spacing {} mm): the gate is a coarse guess; use a smaller spacing",
            analysis.counts.centre_hits, crate::report::three_figures(analysis.grid.spacing)
        ));
    }
    // Stopped after the gate was located, a study whose answer is the method's gate (no
    // balanced gate nor layout asked for) gives the located part's report: the gate, the
    // automatic direction, the wall map when made, and a warning naming what is missing.
    let answer_is_located = s
        .fill
        .as_ref()
        .is_none_or(|o| o.strategy == flow::Strategy::Paper && o.gates == 1);
    // The report of the located part, with the automatic direction when chosen: the
    // study's own, and a stopped study's.
    let located_report = |auto: Option<crate::undercut::AutoDemold>| {
        let input = Input {
            path: None,
            sample: None,
            bytes: 0,
        };
        let report = Report::new(
            input,
            &part.stats,
            &part.warnings,
            &s.material,
            s.radius_source,
            &analysis,
            0.0,
        );
        match auto {
            Some(auto) => report.with_demold_auto(auto),
            None => report,
        }
    };
    let stopped = |stage: Stage, wall: Option<&(WallThickness, f64)>, missing: &str| {
        let located = answer_is_located.then(|| {
            let mut located = located_report(auto.clone());
            if let Some((w, time_s)) = wall {
                located = located.with_wall_thickness(w, *time_s);
            }
            located.warnings.push(format!(
                "{missing} was stopped before its end: the gate is the method's, found before the stop, and {missing} is missing"
            ));
            Box::new(located)
        });
        StudyError::Cancelled { stage, located }
    };
    // The full wall map only when asked for; the fill analysis measures its own samples.
    let wall = match (&bvh, s.wall_thickness) {
        (Some(bvh), true) => {
            let stopped_walls = || stopped(Stage::WallThickness, None, "the wall map");
            enter(Stage::WallThickness).map_err(|_| stopped_walls())?;
            crate::thickness::check_work(bvh, mesh.triangles.len()).map_err(StudyError::Locate)?;
            let t = Instant::now();
            let options = ThicknessOptions::default();
            let known = Known::of(&part.topology);
            let w = wall_thickness_until(mesh, bvh, &options, known, hooks.cancel)
                .ok_or_else(stopped_walls)?;
            Some((w, t.elapsed().as_secs_f64()))
        }
        _ => None,
    };
    let placed = (!snapped.is_empty()).then(|| judge::judge(mesh, &analysis, &snapped));
    // The time the cells took beside the gate search, counted in the join's time.
    let cells_beside_s = cells
        .as_ref()
        .and_then(|c| c.as_ref().ok())
        .map_or(0.0, flow::Cells::seconds);
    let fill = match &s.fill {
        Some(o) if analysis.gate().is_ok() => {
            let o = &FillOptions {
                placed: snapped.iter().map(|g| g.point).collect(),
                ..o.clone()
            };
            // Stopped in the fill stage, the study gives what it found before.
            let stopped_fill = || stopped(Stage::Fill, wall.as_ref(), "the fill analysis");
            enter(Stage::Fill).map_err(|_| stopped_fill())?;
            let walls = match (&wall, &bvh) {
                (Some((w, _)), _) if w.nominal_mm.is_some() => flow::Walls::Given(&w.per_triangle),
                (_, Some(bvh)) => {
                    // Its own walls, at most one a facet: the same bound as the wall map's.
                    crate::thickness::check_work(bvh, mesh.triangles.len())
                        .map_err(StudyError::Locate)?;
                    flow::Walls::Measure(bvh)
                }
                _ => flow::Walls::Estimate,
            };
            let prepared = || match cells.take() {
                Some(made) => made,
                None => flow::prepare_with(
                    mesh,
                    &analysis.centres,
                    Some(&part.topology),
                    o,
                    hooks.cancel,
                ),
            };
            let cancel = hooks.cancel;
            let mut f =
                flow::analyse_prepared(mesh, &analysis, &s.material, walls, o, cancel, prepared)
                    .map_err(|e| match e {
                        FillError::Cancelled => stopped_fill(),
                        e => StudyError::from(e),
                    })?;
            f.times.tree_s = tree_s;
            f.times.cells_beside_s = cells_beside_s;
            Some(f)
        }
        _ => None,
    };
    let placed = placed.map(|p| match (&s.fill, fill.as_ref()) {
        (Some(_), Some(f)) => p.with_fill(f.placed.clone(), None),
        (Some(_), None) => p.with_fill(
            None,
            Some("the fill analysis starts from the method's gate, and this part has none"),
        ),
        (None, _) => p,
    });
    // The answer's verdict beside the designer's gates, when it is the balanced gate.
    let placed = placed.map(|p| match fill.as_ref().and_then(|f| f.balanced.as_ref()) {
        Some(b)
            if s.fill
                .as_ref()
                .is_some_and(|o| o.strategy == flow::Strategy::Balanced && o.gates == 1)
                && !b.is_paper_gate =>
        {
            judge::with_balanced(p, mesh, &analysis, DVec3::from_array(b.fill.gate))
        }
        _ => p,
    });
    // Every analysis has run: the report is made even past a cancellation (it takes
    // milliseconds), rather than throw the study away at its last step.
    if let Some(p) = hooks.progress {
        p(crate::study::Progress {
            stage: Stage::Report,
            fraction: fraction(Stage::Report),
        });
    }
    let mut report = located_report(auto);
    let locate_total_s = report.timings.total_s;
    if let Some((w, time_s)) = &wall {
        report = report.with_wall_thickness(w, *time_s);
    }
    let colour_by = s.fill.as_ref().map(|o| o.colour_by);
    let asked_fill = s.fill.is_some();
    if let Some(fill) = fill {
        report = report.with_fill(fill, analysis.centre);
    } else if asked_fill {
        // Asked for and not made: said, not left to a missing section.
        report.warnings.push(NO_FILL_WITHOUT_GATE.into());
    }
    // The tree serves several stages: counted once, on its own.
    if bvh.is_some() {
        report.timings.tree_s = Some(tree_s);
        // Built alongside locate or the choice of the direction (with the fill's cells), the
        // tree adds only the time it ran past theirs.
        report.timings.total_s += match joined_s {
            Some(Joined::Locate(joined)) => {
                (joined - locate_total_s).clamp(0.0, tree_s + cells_beside_s)
            }
            Some(Joined::Demold(joined)) => {
                (joined - demold_s.unwrap_or(0.0)).clamp(0.0, tree_s + cells_beside_s)
            }
            None => tree_s,
        };
    }
    if let Some(d) = demold_s {
        report.timings.demold_s = Some(d);
        // Located inside the choice, the gate's time is part of the choice's: only what
        // the choice took beyond it is added.
        report.timings.total_s += match located_beside {
            true => (d - locate_total_s).max(0.0),
            false => d,
        };
    }
    let (gates, subtitle) = answer_gates(part, &analysis, &mut report, bvh.as_ref());
    let body_gates = own_body_gates(part, &report, bvh.as_ref());
    let placed_markers = placed.as_ref().map_or(Vec::new(), |p| {
        p.gates
            .iter()
            .map(|g| GateMarker {
                point: DVec3::from_array(g.point),
                normal: DVec3::from_array(g.normal),
            })
            .collect()
    });
    if let Some(w) = placed
        .as_ref()
        .and_then(|p| p.not_flat_warning(analysis.flat_tolerance_mm))
    {
        report.warnings.push(w);
    }
    if let Some(w) = placed
        .as_ref()
        .and_then(|p| p.overlap_warning(analysis.options.gate_radius_mm))
    {
        report.warnings.push(w);
    }
    report.placed_gates = placed;
    let wall_per_vertex = wall.as_ref().map(|(w, _)| w.per_vertex(mesh));
    if let Some(p) = hooks.progress {
        p(crate::study::Progress {
            stage: Stage::Report,
            fraction: 1.0,
        });
    }
    Ok(Study {
        report,
        analysis,
        wall: wall.map(|(w, _)| w),
        wall_per_vertex,
        colour_by,
        pictures_wall: s.fill.is_none() && s.color_by != ColorByChoice::Height,
        gates,
        body_gates,
        placed: placed_markers,
        subtitle,
        material_name: s.material.name.clone(),
        size: (mesh.vertices.len(), mesh.triangles.len()),
        display: OnceLock::new(),
    })
}

/// The outward normal of the surface at `p`: that of the nearest triangle (zero without a
/// tree or when no triangle is near).
fn normal_at(part: &LoadedMesh, bvh: Option<&Bvh>, p: DVec3) -> DVec3 {
    let reach = part.mesh.bounds().size().length().max(1.0);
    bvh.and_then(|b| b.nearest_within(p, reach))
        .map_or(DVec3::ZERO, |hit| part.mesh.normal(hit.triangle as usize))
}

/// The own gates of the bodies the pictured gates do not reach, which the fill's pictures
/// show filled from them ([`crate::flow::BodyGate::pictured`]).
fn own_body_gates(part: &LoadedMesh, report: &Report, bvh: Option<&Bvh>) -> Vec<(u32, GateMarker)> {
    let Some(fill) = report.fill.as_ref() else {
        return Vec::new();
    };
    fill.body_gates
        .iter()
        .filter(|b| b.pictured)
        .filter_map(|b| {
            let p = DVec3::from_array(b.gate?);
            Some((
                b.body,
                GateMarker {
                    point: p,
                    normal: normal_at(part, bvh, p),
                },
            ))
        })
        .collect()
}

/// The gates of the answer and the picture's second title line: the paper's (or the
/// aesthetic) gate, the balanced gate under `strategy = "balanced"`, or the K gates of a
/// several-gate layout (which also become the report's `gate`, each with its normal).
fn answer_gates(
    part: &LoadedMesh,
    analysis: &Analysis,
    report: &mut Report,
    bvh: Option<&Bvh>,
) -> (Vec<GateMarker>, String) {
    let r = analysis.options.gate_radius_mm;
    let Ok(chosen) = analysis.gate() else {
        return (Vec::new(), "no gate".to_string());
    };
    let p = chosen.point();
    let mut gates = vec![GateMarker {
        point: p,
        normal: match chosen {
            ChosenGate::Paper(g) => g.normal,
            ChosenGate::Aesthetic(_) => normal_at(part, bvh, p),
        },
    }];
    let mut subtitle = format!(
        "gate ({:.3}, {:.3}, {:.3}) mm, R = {:.3} mm",
        p.x, p.y, p.z, r
    );
    let several = report
        .fill
        .as_ref()
        .and_then(|f| Some((f.several.clone()?, f.objective)));
    let Some(g) = report.gate.as_mut() else {
        return (gates, subtitle);
    };
    if g.strategy == Strategy::Balanced {
        let p = DVec3::from_array(g.point);
        gates[0] = GateMarker {
            point: p,
            normal: normal_at(part, bvh, p),
        };
        subtitle = format!(
            "balanced gate ({:.3}, {:.3}, {:.3}) mm, R = {r:.3} mm",
            g.point[0], g.point[1], g.point[2]
        );
    }
    if let Some((several, objective)) = several {
        let answer: Vec<AnswerGate> = several
            .gates
            .iter()
            .map(|s| AnswerGate {
                point: s.point,
                normal: normal_at(part, bvh, DVec3::from_array(s.point)).to_array(),
                volume_share: s.volume_share,
                l_max_mm: s.l_max_mm,
                fill_time_s: s.fill_time_s,
            })
            .collect();
        gates = answer
            .iter()
            .map(|a| GateMarker {
                point: DVec3::from_array(a.point),
                normal: DVec3::from_array(a.normal),
            })
            .collect();
        if let Some(first) = answer.first() {
            g.point = first.point;
            g.distance_3d_mm = DVec3::from_array(first.point).distance(analysis.centre);
        }
        // The layout's worst value is in its objective's unit (mm of L_max, s of fill time).
        let (what, unit) = objective.value_words();
        subtitle = format!(
            "{} gates, {what} {} {unit}, R = {r:.3} mm",
            answer.len(),
            objective.value_text(several.value())
        );
        g.gates = Some(answer);
    }
    (gates, subtitle)
}

impl Study {
    /// The report (the JSON schema of `docs/json-schema.md`).
    pub fn report(&self) -> &Report {
        &self.report
    }

    /// The report, taken out of the study.
    pub fn into_report(self) -> Report {
        self.report
    }

    /// Says where the part came from and how long it took to load: the report's `input`,
    /// and `timings.load_s` (added to `timings.total_s`).
    pub fn set_input(&mut self, input: Input, load_s: f64) {
        self.report.set_input(input, load_s);
    }

    /// The report as pretty JSON with a final newline (what `locate --json` prints); no
    /// number is written as a negative zero.
    pub fn report_json(&self) -> Result<String, StudyError> {
        json_text(&self.report)
    }

    /// [`Study::report_json`] with its sentences naming the options as keywords
    /// ([`Report::in_keyword_words`]), for the Python package (`truth` "True") and the
    /// service ("true"): the same keys and numbers.
    pub fn report_json_in_keywords(&self, truth: &str) -> Result<String, StudyError> {
        json_text(&self.report.in_keyword_words(truth))
    }

    /// The gate analysis of [`crate::locate`] (grid, counts, centres, parting line).
    pub fn analysis(&self) -> &Analysis {
        &self.analysis
    }

    /// The fill analysis, when it ran.
    pub fn fill(&self) -> Option<&FillAnalysis> {
        self.report.fill.as_ref()
    }

    /// The field the fill's pictures are coloured by (`color_by`), with its name and unit:
    /// per mesh vertex, NaN where the melt does not reach (a body the pictured gates do not
    /// reach takes its own gate's, see [`crate::flow::BodyGate::pictured`]); `None` without
    /// the fill or when the pictures show the height along D.
    pub fn fill_field(&self) -> Option<Field> {
        let fill = self.fill()?;
        let mut field = fill.field(self.colour_by?)?;
        // With the designer's gates placed, the field is theirs (see `FillOptions::placed`).
        if fill.placed.is_some() && field.name != "wall thickness" {
            field.name = match fill.body_gates.iter().any(|b| b.pictured) {
                true => format!(
                    "{} from your gates, other bodies from their own",
                    field.name
                ),
                false => format!("{} from your gates", field.name),
            };
        }
        Some(field)
    }

    /// The gate-suitability map as a value per qualifying point (NaN for a node off the
    /// voxelised part), with its name and unit, when the study ran with `suitability`.
    pub fn suitability_field(&self) -> Option<crate::scene::NodeField> {
        let map = self.fill()?.suitability.as_ref()?;
        let mut per_node = vec![f32::NAN; self.analysis.qualifying_points.len()];
        // On a part of several bodies each node is scored by the fill of its own body, so
        // one scale would paint a small body's every node better than a large body's best:
        // each node is coloured by its score over its body's best instead (1: that best).
        let per_body = map.spans_bodies().then_some(&map.best_per_body);
        for n in &map.nodes {
            let best = per_body
                .and_then(|b| b[n.body as usize])
                .map(|i| map.nodes[i].score);
            if let Some(v) = per_node.get_mut(n.node) {
                *v = match best {
                    Some(best) if best > 0.0 => (n.score / best) as f32,
                    _ => n.score as f32,
                };
            }
        }
        let what = match map.objective {
            flow::Objective::Length => "longest flow",
            flow::Objective::Resistance => "fill time",
        };
        let (name, unit) = match per_body {
            Some(_) => (
                format!(
                    "gate suitability: {what} from a gate here over the best of its body (1: its best)"
                ),
                String::new(),
            ),
            None => (
                format!("gate suitability: {what} from a gate here"),
                map.unit.to_string(),
            ),
        };
        Some(crate::scene::NodeField {
            name,
            unit,
            per_node,
        })
    }

    /// Estimated fill time per mesh vertex, s (NaN where the melt does not reach; with
    /// several gates, of all of them together), when the fill ran with `color_by =
    /// "fill_order"` (the default).
    pub fn fill_time_per_vertex(&self) -> Option<&[f32]> {
        non_empty(&self.fill()?.per_vertex.fill_time_s)
    }

    /// Flow length per mesh vertex, mm (NaN where the melt does not reach), when the fill
    /// ran with `color_by = "flow_length"`.
    pub fn flow_length_per_vertex(&self) -> Option<&[f32]> {
        non_empty(&self.fill()?.per_vertex.flow_length_mm)
    }

    /// The wall the fill analysis used per mesh vertex, mm, when the fill ran with
    /// `color_by = "wall"`.
    pub fn fill_wall_per_vertex(&self) -> Option<&[f32]> {
        non_empty(&self.fill()?.per_vertex.wall_mm)
    }

    /// The wall thickness everywhere, when it was measured (`wall_thickness = true`).
    pub fn wall_thickness(&self) -> Option<&WallThickness> {
        self.wall.as_ref()
    }

    /// Wall thickness per mesh vertex, mm (NaN where unknown), when it was measured.
    pub fn wall_thickness_per_vertex(&self) -> Option<&[f32]> {
        self.wall_per_vertex.as_deref()
    }

    /// Surface points of every node that qualifies as a gate position, in node order.
    pub fn qualifying_points(&self) -> &[DVec3] {
        &self.analysis.qualifying_points
    }

    /// The gates of the answer (one, or the K gates of a several-gate layout), first is the
    /// main one; empty when there is no gate.
    pub fn gates(&self) -> &[GateMarker] {
        &self.gates
    }

    /// The gates the designer placed (`gate_at`), moved onto the surface, in the order
    /// given; their judgement is the report's `placed_gates`.
    pub fn placed_gates(&self) -> &[GateMarker] {
        &self.placed
    }

    fn check_part(&self, part: &LoadedMesh) -> Result<(), StudyError> {
        let (vertices, triangles) = self.size;
        if part.mesh.vertices.len() == vertices && part.mesh.triangles.len() == triangles {
            Ok(())
        } else {
            Err(StudyError::OtherPart {
                vertices,
                triangles,
            })
        }
    }

    /// The wall map as a colour field, when it was measured: each vertex the area-weighted
    /// mean of its facets' walls, the colour bar spanning the facets' own range (the
    /// report's minimum and maximum, which the means narrow).
    pub fn wall_field(&self) -> Option<Field> {
        let per_vertex = self.wall_per_vertex.clone()?;
        let span = self
            .wall
            .as_ref()
            .and_then(|w| Some([w.min_mm? as f32, w.max_mm? as f32]));
        Some(Field {
            name: "wall thickness".into(),
            unit: "mm".into(),
            per_vertex,
            cells: None,
            span,
        })
    }

    /// What pictures and 3D files show: the part coloured by the fill's `color_by` field
    /// when the fill ran, by the wall map when it was measured without the fill, by height
    /// along D otherwise (or with `color_by = "height"`), the answer's gates, the centre of mass, the
    /// parting line, the qualifying points. `title` is the first title line (the file's
    /// name).
    pub fn scene<'a>(
        &self,
        part: &'a LoadedMesh,
        title: impl Into<String>,
    ) -> Result<Scene<'a>, StudyError> {
        self.check_part(part)?;
        let mut scene = Scene::new(&part.mesh, &self.analysis, title).with_topology(&part.topology);
        // The suitability map takes the place of the fill's field (the part is grey), so the
        // field is refined only when it is drawn.
        if let Some(f) = self.suitability_field() {
            scene = scene.with_node_field(f);
        } else if let Some(f) = self.fill_field() {
            let display = self.display(part, &f);
            scene = scene.with_refined_field(f, display);
        } else if let (true, Some(f)) = (self.pictures_wall, self.wall_field()) {
            scene = scene.with_field(f);
        }
        let r = self.analysis.options.gate_radius_mm;
        scene.gates = self
            .gates
            .iter()
            .map(|g| Marker {
                point: g.point,
                normal: g.normal,
                radius_mm: r,
                body: None,
            })
            .chain(self.body_gates.iter().map(|&(b, g)| Marker {
                point: g.point,
                normal: g.normal,
                radius_mm: r,
                body: Some(b),
            }))
            .collect();
        scene.placed = self
            .placed
            .iter()
            .zip(self.report.placed_gates.iter().flat_map(|p| &p.gates))
            .map(|(g, judged)| crate::scene::PlacedMarker {
                marker: Marker {
                    point: g.point,
                    normal: g.normal,
                    radius_mm: r,
                    body: None,
                },
                qualifies: judged.qualifies,
            })
            .collect();
        scene.subtitle = self.subtitle.clone();
        Ok(scene)
    }

    /// The part refined for the fill's field `field` (this study's [`Study::fill_field`]),
    /// made once: the part is the studied one ([`Study::scene`] checks it).
    fn display(&self, part: &LoadedMesh, field: &Field) -> Option<Arc<Display>> {
        self.display
            .get_or_init(|| {
                let cells = field.cells.as_ref()?;
                crate::display::refine(&part.mesh, cells).map(Arc::new)
            })
            .clone()
    }

    /// The 1600x900 PNG picture of the study (the view along D and an isometric view), its
    /// second title line naming the material and the demolding direction.
    pub fn png(&self, part: &LoadedMesh, title: impl Into<String>) -> Result<Vec<u8>, StudyError> {
        self.png_of(self.scene(part, title)?)
    }

    /// [`Study::png`] of `scene`, one of this study's [`Study::scene`] that the caller may
    /// have coloured by another field ([`Scene::with_field`]): a front end's picture of
    /// what its view shows.
    pub fn png_of(&self, mut scene: Scene<'_>) -> Result<Vec<u8>, StudyError> {
        let d = self.report.options.demold;
        // A direction such as -z reads (0.000, 0.000, -1.000), not with negative zeros.
        scene.subtitle = crate::report::without_negative_zeros(
            &format!(
                "{}   ·   {}   ·   D = ({:.3}, {:.3}, {:.3}){}",
                self.material_name,
                scene.subtitle,
                d[0],
                d[1],
                d[2],
                if self.report.demold_auto.is_some() {
                    " (auto)"
                } else {
                    ""
                }
            ),
            false,
        );
        crate::render::png(&scene, &RenderOptions::default()).map_err(StudyError::Render)
    }

    /// The study as binary glTF 2.0 (see [`crate::gltf`]).
    pub fn glb(&self, part: &LoadedMesh, title: impl Into<String>) -> Result<Vec<u8>, StudyError> {
        crate::gltf::glb(&self.scene(part, title)?).map_err(StudyError::Glb)
    }

    /// The self-contained HTML page of the study, with `png` (from [`Study::png`]) as its
    /// picture when given.
    pub fn html(&self, png: Option<&[u8]>) -> Result<String, StudyError> {
        Ok(crate::html::page(&self.report, &self.report_json()?, png))
    }

    /// [`Study::html`] naming the options as keywords: the report's sentences as
    /// [`Study::report_json_in_keywords`] gives them (the page's warnings and its embedded
    /// JSON alike), and the page's own words about the options (`with wall_thickness=True`,
    /// not `with --wall-thickness`).
    pub fn html_in_keywords(&self, png: Option<&[u8]>, truth: &str) -> Result<String, StudyError> {
        let report = self.report.in_keyword_words(truth);
        let page = crate::html::page(&report, &json_text(&report)?, png);
        Ok(super::keyword_words(&page, truth))
    }
}

impl From<FillError> for StudyError {
    fn from(e: FillError) -> Self {
        match e {
            FillError::Cancelled => StudyError::Cancelled {
                stage: Stage::Fill,
                located: None,
            },
            e => StudyError::Fill(e),
        }
    }
}

fn non_empty(values: &[f32]) -> Option<&[f32]> {
    (!values.is_empty()).then_some(values)
}

/// A report as pretty JSON with a final newline, without negative zeros.
fn json_text(report: &Report) -> Result<String, StudyError> {
    serde_json::to_string_pretty(report)
        .map(|s| crate::report::without_negative_zeros(&s, true) + "\n")
        .map_err(|e| StudyError::Encode(e.to_string()))
}
