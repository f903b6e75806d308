//! `moldgate::study` on the built-in samples: the same report as the stages called one by
//! one, the optional parts reachable, progress in order, cancellation honoured.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use moldgate::report::{Input, RadiusSource, Report};
use moldgate::study::{
    study, study_with, Cancel, Hooks, Progress, Stage, StudyError, StudyOptions,
};
use moldgate::{locate, LoadedMesh};

fn sample(name: &str) -> LoadedMesh {
    moldgate::mesh::from_generated(moldgate::samples::sample(name).unwrap())
}

fn options(json: &str) -> StudyOptions {
    serde_json::from_str(json).unwrap()
}

/// The report as JSON less its times.
fn timeless(r: &Report) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(m) => {
                m.retain(|k, _| !matches!(k.as_str(), "timings" | "times" | "time_s"));
                m.values_mut().for_each(strip);
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut v = serde_json::to_value(r).unwrap();
    strip(&mut v);
    v
}

#[test]
fn a_default_study_is_the_paper_s_locate() {
    for info in moldgate::samples::SAMPLES {
        let part = sample(info.name);
        let s = study(&part, &StudyOptions::default()).unwrap();
        let analysis = locate(&part, &moldgate::LocateOptions::default()).unwrap();
        let input = Input {
            path: None,
            sample: None,
            bytes: 0,
        };
        let direct = Report::new(
            input,
            &part.stats,
            &part.warnings,
            &moldgate::Material::builtin("PP").unwrap(),
            RadiusSource::Material,
            &analysis,
            0.0,
        );
        assert_eq!(timeless(s.report()), timeless(&direct), "{}", info.name);
        assert_eq!(s.qualifying_points(), &analysis.qualifying_points[..]);
        assert_eq!(s.gates().len(), usize::from(analysis.gate().is_ok()));
        assert!(s.fill_time_per_vertex().is_none() && s.wall_thickness_per_vertex().is_none());
        let json: serde_json::Value = serde_json::from_str(&s.report_json().unwrap()).unwrap();
        assert_eq!(json["schema_version"], 3);
    }
}

#[test]
fn per_vertex_fields_and_outputs_of_a_full_study() {
    let part = sample("plate");
    let s = study(
        &part,
        &options(r#"{ "fill": true, "wall_thickness": true, "gates": 2, "demold": "auto" }"#),
    )
    .unwrap();
    let n = part.mesh.vertices.len();
    assert_eq!(s.fill_time_per_vertex().unwrap().len(), n);
    // Only the pictured field is computed: the fill time by default.
    assert!(s.flow_length_per_vertex().is_none() && s.fill_wall_per_vertex().is_none());
    let f = s.fill_field().unwrap();
    assert_eq!(
        (f.name.as_str(), f.unit.as_str()),
        ("fill time (estimate)", "s")
    );
    assert!(f.per_vertex.iter().any(|v| v.is_finite() && *v > 0.0));
    assert_eq!(s.wall_thickness_per_vertex().unwrap().len(), n);
    assert!(s.report().demold_auto.is_some());
    assert_eq!(s.gates().len(), 2);
    for g in s.gates() {
        assert!((g.normal.length() - 1.0).abs() < 1e-9, "{g:?}");
    }
    let png = s.png(&part, "plate").unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let glb = s.glb(&part, "plate").unwrap();
    assert_eq!(&glb[..4], b"glTF");
    let page = s.html(Some(&png)).unwrap();
    assert!(page.contains("2 gates at"));
    // The automatic direction says so and lists every line tried, as the summary does.
    let auto = s.report().demold_auto.as_ref().unwrap();
    assert!(page.contains("(chosen automatically: the "));
    assert!(page.contains("<table id=\"demold-auto\">"));
    for c in &auto.tried {
        let cell = format!("<th>{}", moldgate::html::escape(&c.label()));
        assert!(page.contains(&cell), "{cell} not in the table");
    }
    assert_eq!(page.matches(" (chosen)</th>").count(), 1);
    // Another part is refused.
    let other = sample("cover");
    assert!(matches!(
        s.png(&other, "cover"),
        Err(StudyError::OtherPart { .. })
    ));
}

#[test]
fn progress_comes_in_order_and_ends_at_one() {
    let part = sample("plate");
    let seen = Mutex::new(Vec::new());
    let observer = |p: Progress| seen.lock().unwrap().push(p);
    let hooks = Hooks {
        progress: Some(&observer),
        cancel: None,
    };
    let settings = options(r#"{ "fill": true, "wall_thickness": true, "demold": "auto" }"#)
        .validate()
        .unwrap();
    study_with(&part, &settings, &hooks).unwrap();
    let seen = seen.into_inner().unwrap();
    let stages: Vec<Stage> = seen.iter().map(|p| p.stage).collect();
    assert_eq!(
        stages,
        [
            Stage::Tree,
            Stage::Demold,
            Stage::Locate,
            Stage::WallThickness,
            Stage::Fill,
            Stage::Report,
            Stage::Report
        ]
    );
    assert!(seen.windows(2).all(|w| w[0].fraction <= w[1].fraction));
    assert_eq!(seen.last().unwrap().fraction, 1.0);
}

#[test]
fn a_cancelled_study_stops_before_the_next_stage() {
    let part = sample("plate");
    let settings = options(r#"{ "fill": true }"#).validate().unwrap();
    let cancel = Cancel::new();
    cancel.cancel();
    let hooks = Hooks {
        progress: None,
        cancel: Some(&cancel),
    };
    match study_with(&part, &settings, &hooks) {
        Err(StudyError::Cancelled { stage, .. }) => assert_eq!(stage, Stage::Tree),
        other => panic!("{other:?}"),
    }
    // Cancelled as the locate stage starts: its rays stop (they ran to their end before,
    // and the study stopped at the fill), and the fill never starts.
    let cancel = Cancel::new();
    let observer = |p: Progress| {
        if p.stage == Stage::Locate {
            cancel.cancel();
        }
    };
    let hooks = Hooks {
        progress: Some(&observer),
        cancel: Some(&cancel),
    };
    match study_with(&part, &settings, &hooks) {
        Err(e @ StudyError::Cancelled { .. }) => {
            assert_eq!(e.to_string(), "cancelled at the locate stage")
        }
        other => panic!("{other:?}"),
    }
}

/// The fill stage reads the token inside: set as the stage starts, the study stops in it
/// (before, it ran the whole fill and stopped at the report).
#[test]
fn a_study_cancelled_in_its_fill_stops_there() {
    let json = r#"{ "fill": true, "gates": 3, "suitability": true }"#;
    assert_eq!(cancelled_as(json, Stage::Fill), Stage::Fill);
}

/// Stopped after its gate was located, a study whose answer is the method's gate gives
/// what it found before: the report of the part located without what was stopped, its
/// gate the one a study without it finds. A study whose answer is a balanced gate or a
/// layout gives none: the gate it asked for was not found.
#[test]
fn a_study_stopped_after_its_gate_gives_the_located_part() {
    let part = sample("cover");
    let stopped_at = |json: &str, stage: Stage| stopped_at(&part, json, stage);
    let unfilled = study(&part, &options(r#"{ "wall_thickness": true }"#)).unwrap();
    let expected = unfilled.report();
    let json = r#"{ "fill": true, "wall_thickness": true }"#;
    let (stage, located) = stopped_at(json, Stage::Fill);
    assert_eq!(stage, Stage::Fill);
    let located = located.expect("the located part");
    assert_eq!(
        located.gate.as_ref().map(|g| g.point),
        expected.gate.as_ref().map(|g| g.point)
    );
    assert!(located.fill.is_none());
    assert_eq!(
        located.wall_thickness.as_ref().map(|w| w.nominal_mm),
        expected.wall_thickness.as_ref().map(|w| w.nominal_mm)
    );
    assert!(located.warnings.iter().any(
        |w| w.starts_with("the fill analysis was stopped before its end: the gate is the method's")
    ));
    // Stopped in the wall map: the gate, without the map.
    let (stage, located) = stopped_at(json, Stage::WallThickness);
    assert_eq!(stage, Stage::WallThickness);
    let located = located.expect("the located part");
    assert_eq!(
        located.gate.as_ref().map(|g| g.point),
        expected.gate.as_ref().map(|g| g.point)
    );
    assert!(located.wall_thickness.is_none());
    assert!(located
        .warnings
        .iter()
        .any(|w| w.starts_with("the wall map was stopped before its end")));
    // A balanced gate or a layout asked for: nothing that could be read as the answer.
    for json in [
        r#"{ "fill": true, "gates": 3 }"#,
        r#"{ "strategy": "balanced", "wall_thickness": true }"#,
    ] {
        for stage in [Stage::Fill, Stage::WallThickness] {
            if stage == Stage::WallThickness && !json.contains("wall") {
                continue;
            }
            let (_, located) = stopped_at(json, stage);
            assert!(located.is_none(), "{json} at {stage}");
        }
    }
}

/// The stage a study of the cover sample with options `json` stops at when its token is
/// set as `stage` starts.
fn cancelled_as(json: &str, stage: Stage) -> Stage {
    stopped_at(&sample("cover"), json, stage).0
}

/// The stage a study of `part` with options `json` stops at when its token is set as
/// `stage` starts, and the located part it gives.
fn stopped_at(part: &LoadedMesh, json: &str, stage: Stage) -> (Stage, Option<Box<Report>>) {
    let settings = options(json).validate().unwrap();
    let cancel = Cancel::new();
    let observer = |p: Progress| {
        if p.stage == stage {
            cancel.cancel();
        }
    };
    let hooks = Hooks {
        progress: Some(&observer),
        cancel: Some(&cancel),
    };
    match study_with(part, &settings, &hooks) {
        Err(StudyError::Cancelled { stage, located }) => (stage, located),
        other => panic!("{other:?}"),
    }
}

/// Set at any moment of a long fill (several gates and the suitability map, about 1 s),
/// the token ends the study with `Cancelled` at the fill stage, or the study finishes whole:
/// marches cut short never give a wrong answer or a panic. Prints how soon it stopped.
#[test]
fn a_fill_cancelled_at_any_moment_stops_cleanly() {
    let part = sample("cover");
    let fine = r#"{ "fill": true, "gates": 3, "suitability": true, "cell": 1.0 }"#;
    let settings = options(fine).validate().unwrap();
    let whole = study(&part, &options(fine)).unwrap();
    let expected = timeless(whole.report());
    let fill_started = Mutex::new(None);
    for delay_ms in [0, 5, 30, 100, 300, 700] {
        let cancel = Cancel::new();
        let observer = |p: Progress| {
            if p.stage == Stage::Fill {
                *fill_started.lock().unwrap() = Some(Instant::now());
            }
        };
        let hooks = Hooks {
            progress: Some(&observer),
            cancel: Some(&cancel),
        };
        let (result, returned, cancelled) = std::thread::scope(|scope| {
            let timer = cancel.clone();
            let started = &fill_started;
            let cancelling = scope.spawn(move || {
                // Waits for the fill stage, then lets it run `delay_ms`.
                let deadline = Instant::now() + Duration::from_secs(60);
                while started.lock().unwrap().is_none() && Instant::now() < deadline {
                    std::thread::sleep(Duration::from_micros(200));
                }
                std::thread::sleep(Duration::from_millis(delay_ms));
                timer.cancel();
                Instant::now()
            });
            let result = study_with(&part, &settings, &hooks);
            let returned = Instant::now();
            (result, returned, cancelling.join().unwrap())
        });
        *fill_started.lock().unwrap() = None;
        match result {
            Err(StudyError::Cancelled { stage, .. }) => {
                assert_eq!(stage, Stage::Fill, "cancelled after {delay_ms} ms");
                let late = returned.saturating_duration_since(cancelled);
                println!("cancelled {delay_ms} ms into the fill: returned {late:?} later");
            }
            Ok(s) => assert_eq!(
                timeless(s.report()),
                expected,
                "finished after {delay_ms} ms"
            ),
            Err(e) => panic!("cancelled after {delay_ms} ms: {e}"),
        }
    }
}

/// The HTML report's table of bodies gives each body's own nominal wall, the one its fill
/// time is taken against: two plates of 2 and 6 mm, side by side.
#[test]
fn the_html_report_gives_each_body_its_own_nominal_wall() {
    let mut two = moldgate::samples::BoxUnion::default();
    two.add([0.0, 0.0, 0.0], [40.0, 20.0, 2.0]);
    two.add([50.0, 0.0, 0.0], [90.0, 20.0, 6.0]);
    let part = moldgate::mesh::from_generated(two.mesh());
    let s = study(&part, &options(r#"{ "fill": true, "demold": "+z" }"#)).unwrap();
    let bodies = &s.report().fill.as_ref().unwrap().body_gates;
    assert_eq!(bodies.len(), 2);
    let page = s.html(None).unwrap();
    assert!(page.contains("<th>nominal wall</th>"));
    for b in bodies {
        let own = if b.centre_of_mass[0] < 45.0 { 2.0 } else { 6.0 };
        assert!(
            (b.nominal_wall_mm - own).abs() < 0.1,
            "body {}: {} mm, its own is {own} mm",
            b.body,
            b.nominal_wall_mm
        );
        let cell = format!("<td class=\"n\">{:.2} mm</td>", b.nominal_wall_mm);
        assert!(page.contains(&cell), "{cell} not in the bodies table");
    }
}

/// The page counts the parting line's pieces and cycles in words that agree with their
/// number: one plate has one piece of rim and one cycle, two plates side by side two.
#[test]
fn the_html_report_counts_the_parting_line_s_loops_in_the_singular_and_the_plural() {
    let mut one = moldgate::samples::BoxUnion::default();
    one.add([0.0, 0.0, 0.0], [40.0, 20.0, 2.0]);
    let mut two = moldgate::samples::BoxUnion::default();
    two.add([0.0, 0.0, 0.0], [40.0, 20.0, 2.0]);
    two.add([50.0, 0.0, 0.0], [90.0, 20.0, 2.0]);
    for (boxes, words) in [
        (
            one,
            "(the outer rim: 1 piece of rim edges joined into 1 cycle, one a body)",
        ),
        (
            two,
            "(the outer rim: 2 pieces of rim edges joined into 2 cycles, one a body)",
        ),
    ] {
        let part = moldgate::mesh::from_generated(boxes.mesh());
        let s = study(&part, &options(r#"{ "demold": "+z" }"#)).unwrap();
        let page = s.html(None).unwrap();
        assert!(page.contains(words), "{words} not on the page");
        // A part with neither a file nor a sample's name is not named by nothing.
        assert!(page.contains("<h1>Injection gate of an unnamed part</h1>"));
        assert!(page.contains("<title>moldgate: an unnamed part</title>"));
    }
}

#[test]
fn a_grid_gate_on_a_rib_is_warned_not_flat_alike_in_the_report_and_the_page() {
    // A plate 40 x 40 x 2 with a rib 2 mm wide and 1 mm high across its middle: the centre
    // of mass is over the rib, the grid gate on its top, and the gate's circle (R = 1.43 mm
    // for PP) reaches down the rib's sides onto the plate, 1 mm lower.
    let mut part = moldgate::samples::BoxUnion::default();
    part.add([-20.0, -20.0, 0.0], [20.0, 20.0, 2.0]);
    part.add([-1.0, -20.0, 2.0], [1.0, 20.0, 3.0]);
    let part = moldgate::mesh::from_generated(part.mesh());
    let s = study(&part, &options(r#"{"demold": "+z"}"#)).unwrap();
    let gate = s.report().paper_gate.as_ref().unwrap();
    assert!(!gate.flat, "{gate:?}");
    let warning = s
        .report()
        .warnings
        .iter()
        .find(|w| w.contains("not flat"))
        .unwrap_or_else(|| panic!("no flatness warning in {:?}", s.report().warnings));
    assert!(warning.contains("1.00 mm"), "{warning}");
    // It names the seat the flat rule would take instead, and how far that is.
    let flat = study(&part, &options(r#"{"demold": "+z", "require_flat": true}"#)).unwrap();
    let seat = flat.report().gate.as_ref().unwrap().point;
    let away = (0..3)
        .map(|k| (seat[k] - gate.point[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let named = format!(
        "the nearest flat seat is at ({:.3}, {:.3}, {:.3}) mm, {away:.2} mm away",
        seat[0], seat[1], seat[2]
    );
    assert!(warning.contains(&named), "{warning} lacks {named}");
    assert!(away > 0.5, "{away}");
    let page = s.html(None).unwrap();
    assert!(
        page.contains(&moldgate::html::escape(warning)),
        "the page's warnings lack {warning}"
    );
    // The page names the method's gate as the summary, the fill table and the app do.
    assert!(page.contains("<th>Paper gate</th>"), "no paper gate row");
    assert!(
        !page.contains("Grid gate"),
        "the page names the gate two ways"
    );
}

#[test]
fn asking_for_the_wall_of_every_facet_does_not_change_the_fill() {
    // With --wall-thickness the fill reads the walls of every facet instead of measuring its
    // own samples; it used to take their area-weighted median as its nominal wall and its
    // cell size from it, so every number of the fill moved (on the 352k housing the cell went
    // from 0.689 to 0.750 mm and the balanced gate's flow-cell wall from 1.00 to 1.50 mm).
    for info in moldgate::samples::SAMPLES {
        let part = sample(info.name);
        let fill = study(&part, &options(r#"{"fill": true, "gates": 2}"#)).unwrap();
        let both = study(
            &part,
            &options(r#"{"fill": true, "gates": 2, "wall_thickness": true}"#),
        )
        .unwrap();
        assert_eq!(
            timeless(fill.report())["fill"],
            timeless(both.report())["fill"],
            "{}",
            info.name
        );
    }
}

#[test]
fn a_layout_of_gates_is_titled_in_its_objective_s_unit() {
    let part = sample("tray");
    for (objective, words) in [
        ("length", "longest flow path L_max "),
        ("resistance", "fill time "),
    ] {
        let json = format!(r#"{{ "gates": 2, "objective": "{objective}" }}"#);
        let s = study(&part, &options(&json)).unwrap();
        let subtitle = s.scene(&part, "tray").unwrap().subtitle;
        let (_, unit) = s.report().fill.as_ref().unwrap().objective.value_words();
        assert!(
            subtitle.starts_with(&format!("2 gates, {words}")),
            "{subtitle}"
        );
        assert!(subtitle.contains(&format!(" {unit}, R = ")), "{subtitle}");
        // R to the thousandth, as the summary and the page give it (it read 1.43 by 1.425).
        let r = s.report().options.gate_radius_mm;
        assert!(subtitle.ends_with(&format!("R = {r:.3} mm")), "{subtitle}");
        // The pictures colour the layout's fill time: the page gives it and says that a
        // layout of the longest flow path was not chosen for it.
        let page = s.html(None).unwrap();
        let note = "a time the layout does not minimise (it minimises the longest flow path): it may end later than a single gate's fill. The pictures colour this fill time.";
        assert_eq!(page.contains(note), objective == "length", "{objective}");
    }
}

/// A part whose size suggests other units: the no-gate reason quotes the size the loader's
/// warning does (the box's diagonal in the mesh's axes), not another measure of it.
#[test]
fn a_part_of_suspicious_size_is_one_size_in_every_message() {
    let mut mesh = moldgate::samples::sample("cover").unwrap();
    for v in &mut mesh.vertices {
        *v *= 0.001;
    }
    let part = moldgate::mesh::from_generated(mesh);
    let warning = part
        .warnings
        .iter()
        .find(|w| w.contains("mm across"))
        .expect("the size warning");
    let size = |text: &str| {
        let at = text.find(" mm across").unwrap();
        text[..at].rsplit(' ').next().unwrap().to_string()
    };
    let a = locate(&part, &moldgate::LocateOptions::default()).unwrap();
    let reason = a.gate().unwrap_err().to_string();
    assert!(reason.contains("mm across as read"), "{reason}");
    assert_eq!(size(warning), size(&reason), "{warning} / {reason}");
    // The box seen along D, which the reason used to quote, is another size.
    let seen = moldgate::math::DVec2::from_array(a.grid.box_hi)
        .distance(moldgate::math::DVec2::from_array(a.grid.box_lo));
    assert_ne!(format!("{seen:.4}"), size(warning));
}

/// A gate of a layout whose node's disc is not flat is warned, with its step; a gate on a
/// flat seat is not; with `require_flat` every candidate is flat and nothing is warned.
#[test]
fn layout_gates_off_a_flat_seat_are_warned() {
    let part = sample("bracket");
    let mut warned = 0;
    for (json, flat_only) in [
        (r#"{ "gates": 2 }"#, false),
        (r#"{ "gates": 3 }"#, false),
        (r#"{ "gates": 3, "require_flat": true }"#, true),
    ] {
        let s = study(&part, &options(json)).unwrap();
        let a = s.analysis();
        let fill = s.report().fill.as_ref().unwrap();
        for (k, g) in fill.several.as_ref().unwrap().gates.iter().enumerate() {
            let p = moldgate::math::DVec3::from_array(g.point);
            let i = a.qualifying_points.iter().position(|&q| q == p).unwrap();
            let step = a.qualifying_step_mm[i] as f64;
            // Alone: "gate 2 of the layout of 3 at ... reaches 1.23 mm off its height";
            // several: "2 gates of the layout of 3 are not on a flat seat: gate 1 1.23 mm, ...".
            let alone = format!("gate {} of the layout", k + 1);
            let listed = format!("gate {} {step:.2} mm", k + 1);
            let said = fill.warnings.iter().find(|w| {
                w.starts_with(&alone) || (w.contains("gates of the layout") && w.contains(&listed))
            });
            match said {
                Some(w) => {
                    warned += 1;
                    assert!(step > a.flat_tolerance_mm && !flat_only, "{json}: {w}");
                    let quoted = format!("{step:.2} mm off its height");
                    assert!(w.contains(&quoted) || w.contains(&listed), "{w}");
                }
                None => assert!(step <= a.flat_tolerance_mm, "{json}: gate {k}, step {step}"),
            }
        }
    }
    assert!(warned > 0, "the bracket's layouts have a gate on a step");
}

/// The wall stage reads the token before each facet's rays: set as the stage starts, the
/// study stops in it (before, it measured every facet and stopped at the next stage).
#[test]
fn a_study_cancelled_in_its_wall_stage_stops_there() {
    let json = r#"{ "wall_thickness": true }"#;
    let stage = Stage::WallThickness;
    assert_eq!(cancelled_as(json, stage), stage);
    let part = sample("cover");
    let settings = options(json).validate().unwrap();
    // Not set: the whole wall map, as without a token.
    let token = Cancel::new();
    let hooks = Hooks {
        progress: None,
        cancel: Some(&token),
    };
    let with = study_with(&part, &settings, &hooks).unwrap();
    let without = study(&part, &options(r#"{ "wall_thickness": true }"#)).unwrap();
    assert_eq!(timeless(with.report()), timeless(without.report()));
}

#[test]
fn two_gates_on_a_long_tray_split_it_across_its_length() {
    // The tray is 80 x 60 mm (a floor and walls). From the best single gate and from the
    // place it reaches last, the search's moves brought both gates to the middle (L_max
    // 57.7 mm, 2 % better than one gate); the start from the cells split into two clusters
    // puts one gate in each half along x.
    let tray = sample("tray");
    let s = study(&tray, &options(r#"{"gates": 2}"#)).unwrap();
    let layout = s.report().fill.as_ref().unwrap().several.as_ref().unwrap();
    let x: Vec<f64> = layout.gates.iter().map(|g| g.point[0]).collect();
    assert!(
        x[0] * x[1] < 0.0 && x.iter().all(|x| x.abs() > 10.0),
        "gates at x {x:?}"
    );
    let l_max = layout.l_max_mm.unwrap();
    assert!(l_max < 50.0, "{l_max}");
    assert!(layout.improvement_pct > 15.0, "{}", layout.improvement_pct);
}

/// Without the fill, the pictures are coloured by the wall map when it was measured and
/// asked for (they were coloured by height, without a word).
#[test]
fn the_wall_map_colours_the_pictures_without_the_fill_when_asked_for() {
    let part = sample("cover");
    let s = study(
        &part,
        &options(r#"{ "wall_thickness": true, "color_by": "wall" }"#),
    )
    .unwrap();
    let scene = s.scene(&part, "cover").unwrap();
    assert_eq!(scene.field.name, "wall thickness");
    let walls = s.wall_thickness_per_vertex().unwrap();
    assert_eq!(scene.field.per_vertex.len(), walls.len());
    assert!(scene
        .field
        .per_vertex
        .iter()
        .zip(walls)
        .all(|(a, b)| a == b || (a.is_nan() && b.is_nan())));
    assert!(s
        .report()
        .warnings
        .iter()
        .all(|w| !w.contains("--color-by")));
    // Its colour bar spans the facets' walls, as the report gives them (the vertices'
    // means of their facets are narrower).
    let w = s.report().wall_thickness.as_ref().unwrap();
    let [lo, hi] = scene.field.range().unwrap();
    assert_eq!(
        [lo as f64, hi as f64],
        [
            w.min_mm.unwrap() as f32 as f64,
            w.max_mm.unwrap() as f32 as f64
        ]
    );
    let means = moldgate::colormap::Range::of(walls).unwrap();
    assert!(means.min >= lo && means.max <= hi, "{means:?}");
    // Measured without the fill, the wall map is what the pictures show unless the height
    // is asked for.
    let s = study(&part, &options(r#"{ "wall_thickness": true }"#)).unwrap();
    assert_eq!(
        s.scene(&part, "cover").unwrap().field.name,
        "wall thickness"
    );
    let s = study(
        &part,
        &options(r#"{ "wall_thickness": true, "color_by": "height" }"#),
    )
    .unwrap();
    assert_eq!(
        s.scene(&part, "cover").unwrap().field.name,
        "height along D"
    );
    // Not measured: height, and a warning saying so.
    let s = study(&part, &options(r#"{ "color_by": "wall" }"#)).unwrap();
    assert_eq!(
        s.scene(&part, "cover").unwrap().field.name,
        "height along D"
    );
    assert!(s
        .report()
        .warnings
        .iter()
        .any(|w| w.starts_with("--color-by wall changes nothing")));
}

/// A layout chosen by its flow length gives its fill time too: the time the pictures colour
/// (the largest of the pictured cells'), the same with the designer's gates taking the
/// pictures over (marched on its own then), and under the resistance objective the value
/// the layout minimised. The summary page gives it, said not minimised.
#[test]
fn a_layout_gives_its_fill_time_whichever_objective_chose_it() {
    let tray = sample("tray");
    let s = study(&tray, &options(r#"{"gates": 2}"#)).unwrap();
    let fill = s.report().fill.as_ref().unwrap();
    let layout = fill.several.as_ref().unwrap();
    assert!(layout.fill_time_s.is_none());
    let t = layout.layout_fill_time_s.expect("the layout's fill time");
    let [_, pictured] = fill.field_cells.as_ref().unwrap().range().unwrap();
    assert!(
        (t - pictured as f64).abs() <= 1e-6 * t,
        "{t} s, the pictures' {pictured} s"
    );
    let page = s.html(None).unwrap();
    let said = format!(
        "These gates together fill the part in {} s",
        moldgate::report::seconds_text(t)
    );
    assert!(page.contains(&said), "the page lacks {said}");
    assert!(page.contains("The pictures colour this fill time."));
    // The designer's gate takes the pictures over: the layout's time is marched on its own.
    let g = layout.gates[0].point;
    let placed = format!(
        r#"{{"gates": 2, "gate_at": ["{},{},{}"]}}"#,
        g[0], g[1], g[2]
    );
    let with_placed = study(&tray, &options(&placed)).unwrap();
    let other = with_placed.report().fill.as_ref().unwrap();
    let other = other.several.as_ref().unwrap();
    assert_eq!(other.gates.len(), 2);
    assert_eq!(other.layout_fill_time_s, Some(t));
    let page = with_placed.html(None).unwrap();
    assert!(page.contains(&said) && !page.contains("The pictures colour this fill time."));
    // So does the suitability map.
    let with_map = study(&tray, &options(r#"{"gates": 2, "suitability": true}"#)).unwrap();
    let page = with_map.html(None).unwrap();
    assert!(page.contains(&said) && !page.contains("The pictures colour this fill time."));
    // Chosen by the fill time, it is the value minimised.
    let s = study(
        &tray,
        &options(r#"{"gates": 2, "objective": "resistance"}"#),
    )
    .unwrap();
    let layout = s.report().fill.as_ref().unwrap().several.as_ref().unwrap();
    let minimised = layout.fill_time_s.unwrap();
    let t = layout.layout_fill_time_s.unwrap();
    assert!(
        (t - minimised).abs() <= 1e-9 * minimised,
        "{t} against {minimised}"
    );
    assert!(!s.html(None).unwrap().contains("layout-fill-time"));
    // On a part of two bodies each body gets a gate of the layout (no melt crosses between
    // them), and the extra gate goes to the body whose layout is the worse: the longer one.
    let mut two = moldgate::samples::BoxUnion::default();
    two.add([0.0, 0.0, 0.0], [60.0, 30.0, 2.0]);
    two.add([80.0, 0.0, 0.0], [120.0, 30.0, 2.0]);
    let two = moldgate::mesh::from_generated(two.mesh());
    let body_of = |g: &moldgate::flow::GateShare| usize::from(g.point[0] > 70.0);
    let s = study(&two, &options(r#"{"gates": 2, "demold": "+z"}"#)).unwrap();
    let fill = s.report().fill.as_ref().unwrap();
    assert_eq!(fill.bodies, 2);
    let layout = fill.several.as_ref().unwrap();
    let mut bodies: Vec<usize> = layout.gates.iter().map(body_of).collect();
    bodies.sort_unstable();
    assert_eq!(bodies, [0, 1], "{:?}", layout.gates);
    // Each gate names its body, as the bodies' own gates are numbered.
    for g in &layout.gates {
        assert_eq!(g.body as usize, body_of(g), "{g:?}");
    }
    assert_eq!(layout.bodies, 2);
    assert!(!layout.leaves_a_body());
    assert!(layout.fill.as_ref().unwrap().reached_share > 0.9995);
    let shares: f64 = layout.gates.iter().map(|g| g.volume_share).sum();
    assert!((shares - 1.0).abs() < 1e-9, "{shares}");
    // The part's longest flow is the longer body's, from its own gate near its middle.
    let longest = layout.l_max_mm.unwrap();
    assert!(longest > 25.0 && longest < 40.0, "{longest}");
    assert!(
        !s.report()
            .warnings
            .iter()
            .any(|w| w.contains("none of its gates")),
        "{:?}",
        s.report().warnings
    );
    let t = layout.layout_fill_time_s.unwrap();
    let page = s.html(None).unwrap();
    let said = format!(
        "These gates together fill the part in {} s",
        moldgate::report::seconds_text(t)
    );
    assert!(page.contains(&said), "the page lacks {said}");
    assert!(page.contains("The pictures colour this fill time."));
    let three = study(&two, &options(r#"{"gates": 3, "demold": "+z"}"#)).unwrap();
    let layout = three
        .report()
        .fill
        .as_ref()
        .unwrap()
        .several
        .as_ref()
        .unwrap();
    let on_long = layout.gates.iter().filter(|g| body_of(g) == 0).count();
    assert_eq!(on_long, 2, "{:?}", layout.gates);
    assert!(layout.l_max_mm.unwrap() < longest, "{:?}", layout.l_max_mm);
}

#[test]
fn the_keyword_report_names_options_as_keywords_and_changes_nothing_else() {
    // The cover with the automatic direction and the fill: warnings that advise
    // `--require-flat` and name `--demold auto` (both the report's and the fill's own).
    let part = sample("cover");
    let s = study(&part, &options(r#"{ "fill": true, "demold": "auto" }"#)).unwrap();
    let cli: serde_json::Value = serde_json::from_str(&s.report_json().unwrap()).unwrap();
    let text = s.report_json_in_keywords("True").unwrap();
    assert!(text.ends_with("}\n"));
    let python: serde_json::Value = serde_json::from_str(&text).unwrap();
    let sentences = |r: &serde_json::Value| -> Vec<String> {
        let mut all: Vec<String> = r["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .chain(r["fill"]["warnings"].as_array().unwrap())
            .map(|w| w.as_str().unwrap().to_owned())
            .collect();
        all.extend(r["no_gate_reason"].as_str().map(str::to_owned));
        all
    };
    let (flags, keywords) = (sentences(&cli), sentences(&python));
    assert!(
        flags.iter().any(|w| w.contains("--require-flat")),
        "{flags:?}"
    );
    assert!(
        keywords.iter().any(|w| w.contains("require_flat=True")),
        "{keywords:?}"
    );
    assert!(keywords.iter().all(|w| !w.contains("--")), "{keywords:?}");
    assert_eq!(flags.len(), keywords.len());
    for (f, k) in flags.iter().zip(&keywords) {
        assert_eq!(moldgate::study::keyword_words(f, "True"), *k);
    }
    // Everything else is the command line's report, key for key.
    let without = |mut r: serde_json::Value| {
        r["warnings"] = serde_json::Value::Null;
        r["fill"]["warnings"] = serde_json::Value::Null;
        r["no_gate_reason"] = serde_json::Value::Null;
        r
    };
    assert_eq!(without(cli), without(python));
    // The same order of keys as the command line's, for a reader that keeps it.
    let keys = |t: &str| -> Vec<String> {
        t.lines()
            .filter_map(|l| l.trim_start().strip_prefix('"'))
            .filter_map(|l| l.split_once("\":").map(|(k, _)| k.to_owned()))
            .collect()
    };
    assert_eq!(keys(&s.report_json().unwrap()), keys(&text));
    // The HTML page alike: its warnings, its embedded JSON and its own words about the
    // options; the command line's page keeps the flags.
    let page = s.html_in_keywords(None, "True").unwrap();
    assert!(page.contains("require_flat=True") && !page.contains("--require-flat"));
    let flags = s.html(None).unwrap();
    assert!(flags.contains("--require-flat") && flags.contains("--objective"));
    assert!(!page.contains("--objective") && page.contains("objective"));
}

/// A fill asked for on a part without a gate is said not made, not left to a missing
/// section.
#[test]
fn a_fill_asked_for_without_a_gate_says_it_was_not_made() {
    let part = sample("cover");
    let s = study(&part, &options(r#"{ "fill": true, "gate_radius": 40 }"#)).unwrap();
    let r = s.report();
    assert!(r.gate.is_none() && r.fill.is_none());
    assert!(
        r.warnings
            .iter()
            .any(|w| w
                == "no fill analysis: it starts from the method's gate, and this part has none"),
        "{:?}",
        r.warnings
    );
    // Without the fill asked for, no such word.
    let s = study(&part, &options(r#"{ "gate_radius": 40 }"#)).unwrap();
    assert!(s.report().warnings.iter().all(|w| !w.contains("no fill")));
}

/// The centre of mass of the volume asked for on a mesh that encloses none: the surface's
/// is used, and the report says which it used.
#[test]
fn the_centre_used_is_reported_when_the_volume_s_cannot_be() {
    let sheet = moldgate::mesh::Mesh {
        vertices: vec![
            moldgate::math::DVec3::new(0.0, 0.0, 0.0),
            moldgate::math::DVec3::new(10.0, 0.0, 0.0),
            moldgate::math::DVec3::new(10.0, 10.0, 0.0),
            moldgate::math::DVec3::new(0.0, 10.0, 0.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let part = moldgate::mesh::from_generated(sheet);
    let s = study(
        &part,
        &options(r#"{ "centre": "volume", "thickness_rule": "ignore" }"#),
    )
    .unwrap();
    let r = s.report();
    assert_eq!(r.centre_of_mass.kind, moldgate::CentreKind::Surface);
    assert!(r
        .warnings
        .iter()
        .any(|w| w.contains("the surface centre of mass is used")));
    // A closed part gives the volume's.
    let s = study(&sample("cover"), &options(r#"{ "centre": "volume" }"#)).unwrap();
    assert_eq!(s.report().centre_of_mass.kind, moldgate::CentreKind::Volume);
}

/// With the aesthetic gate and no grid node qualifying, the fill says there is no balanced
/// gate and why, names the aesthetic gate (it said "the paper gate's fill time" and "no
/// qualifying candidate feeds the gate's body"), and suggests nothing already asked for.
#[test]
fn an_aesthetic_fill_without_a_qualifying_node_says_why_there_is_no_balanced_gate() {
    let s = study(
        &sample("cover"),
        &options(r#"{"aesthetic": true, "fill": true, "gate_radius": 8}"#),
    )
    .unwrap();
    let warnings = s.report().warnings.join("\n");
    assert!(
        warnings.contains("no balanced gate: no grid node qualifies for a gate (")
            && warnings.contains("so the fill is the aesthetic gate's alone"),
        "{warnings}"
    );
    assert!(!warnings.contains("--aesthetic"), "{warnings}");
    assert!(!warnings.contains("paper gate"), "{warnings}");
}

/// A keep-out region that moves the aesthetic gate is not said to keep nothing out (it
/// was, as it held no qualifying node); one that holds neither is.
#[test]
fn a_keep_out_that_moves_the_aesthetic_gate_is_not_said_to_do_nothing() {
    let plate = sample("plate");
    let free = study(&plate, &options(r#"{"aesthetic": true}"#)).unwrap();
    let [x, y, z] = free.report().gate.as_ref().unwrap().point;
    let kept = study(
        &plate,
        &options(&format!(
            r#"{{"aesthetic": true, "keep_out": ["sphere:{x},{y},{z},2"]}}"#
        )),
    )
    .unwrap();
    let moved = kept.report().gate.as_ref().unwrap().point;
    assert!(moved != [x, y, z], "the region did not move the gate");
    let warnings = kept.report().warnings.join("\n");
    assert!(!warnings.contains("keeps out no node"), "{warnings}");
    let far = study(
        &plate,
        &options(&format!(
            r#"{{"aesthetic": true, "keep_out": ["sphere:{x},{y},{},2"]}}"#,
            z + 50.0
        )),
    )
    .unwrap();
    let warnings = far.report().warnings.join("\n");
    assert!(
        warnings.contains("keeps out no node that qualifies nor the aesthetic gate's point"),
        "{warnings}"
    );
}
