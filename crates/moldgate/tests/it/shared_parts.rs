//! The shared real parts, checked against independent geometry and against the stored results
//! of the Python reference implementation; and a spacing-halving stability check on those
//! parts and on the built-in samples.
//!
//! The parts are not in this repository. They are looked for at `$MOLDGATE_PARTS`, else at
//! `<workspace>/../shared/data/parts`; the reference results at `$MOLDGATE_REFERENCE`, else at
//! `<workspace>/../shared/reference/results`. A test whose data is missing says so on stdout
//! and stderr and passes without checking anything.
//!
//! Every check runs on every part before a test fails, and the failure lists each part at
//! fault with its numbers. Run with `--nocapture` to see the per-part tables.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use moldgate::gate::{Gate, Spacing, ThicknessRule};
use moldgate::math::{DVec2, DVec3};
use moldgate::mesh::{self, LoadedMesh, Mesh, Units};
use moldgate::{locate, Analysis, Direction, Frame, LocateOptions};
use rayon::prelude::*;
use serde_json::Value;

/// A shared part: its file and its natural demolding direction from the folder's
/// `SOURCES.md`, sign included (the rays come from the +D side).
struct Part {
    file: &'static str,
    demold: &'static str,
}

const PARTS: [Part; 18] = [
    Part::new("comma2_injection_molded_mount.stl", "+x"),
    Part::new("comma_ram_connector_cap.stl", "-z"),
    Part::new("deskhop_case_bottom.stl", "+z"),
    Part::new("esp32s3box_bottom_housing_352k.stl", "+y"),
    Part::new("esp32s3box_top_housing.stl", "-y"),
    Part::new("framework_desktop_blank_tile.stl", "-z"),
    Part::new("framework_desktop_top_cover_121k.stl", "-x"),
    Part::new("framework_expansion_card_shell.stl", "+y"),
    Part::new("prusa_heatbed_cable_cover_clip_ascii.stl", "+z"),
    Part::new("prusa_lcd_knob.stl", "+z"),
    Part::new("prusa_psu_cover_mk3_ascii.stl", "+z"),
    Part::new("prusa_raspberry_cover_ascii_open.stl", "+z"),
    Part::new("sc64_shell_back.stl", "-z"),
    Part::new("screwcap_oralb_75ml_ascii.stl", "+z"),
    Part::new("trimesh_ADIS16480_meters_ascii.STL", "+y"),
    Part::new("trimesh_featuretype_inches.STL", "+z"),
    Part::new("watchy_yatari_bottom.stl", "-z"),
    Part::new("watchy_yatari_top.stl", "+z"),
];

/// Parts where the paper's wall-thickness rule leaves no gate with the default options.
/// The raspberry cover is a vented lid whose plate is 1 mm thick, under R_gate = 1.43 mm for
/// PP; the test confirms the thin wall by casting rays itself.
const NO_GATE_BY_THICKNESS: &[&str] = &["prusa_raspberry_cover_ascii_open"];

/// The bound of the halving check: the gates found with spacings h and h/2 lie within this
/// many h of each other in the projection plane.
const HALVING_BOUND: f64 = 1.5;

/// Parts known to break [`HALVING_BOUND`], with what was measured when they were listed.
///
/// comma2 along +x (h = 0.615 mm): the part is nearly mirror-symmetric about z = 0 (the
/// centre of mass is at z = -0.003 mm), and the qualifying surface nearest the centre is a
/// faceted round on either side of that plane, at z = +1.6 to +1.8 and at z = -1.5 to -1.8.
/// The grid's phase decides which side wins: with h the gate is at (3.03, 5.78, +1.84),
/// 1.968 mm from the centre; with h/2 it is at (3.31, 5.63, -1.54), 1.792 mm away, 3.38 mm
/// = 5.5 h in the plane from the first. Shifting the grid at h by 0.1 to 0.9 spacings makes
/// it alternate between the two sides too (1.786 to 1.968 mm). This is the nearest-point rule
/// meeting a symmetric part, not a defect: the finer gate is nearer the centre of mass, which
/// is what the test asserts for listed parts instead of the bound.
const HALVING_EXCEPTIONS: &[&str] = &["comma2_injection_molded_mount"];

impl Part {
    const fn new(file: &'static str, demold: &'static str) -> Part {
        Part { file, demold }
    }

    fn stem(&self) -> &'static str {
        self.file.rsplit_once('.').map_or(self.file, |(s, _)| s)
    }

    /// The unit, from the file name as the reference reads it.
    fn units(&self) -> Units {
        if self.file.contains("meters") {
            Units::M
        } else if self.file.contains("inches") {
            Units::In
        } else {
            Units::Mm
        }
    }

    fn direction(&self) -> Direction {
        self.demold.parse().expect("valid direction")
    }
}

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn data_dir(var: &str, default: &str) -> Result<PathBuf, String> {
    let dir = std::env::var_os(var)
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join(default));
    if dir.is_dir() {
        Ok(dir)
    } else {
        Err(format!("{} not found (set {var})", dir.display()))
    }
}

fn skip(test: &str, why: &str) {
    eprintln!("{test}: skipped: {why}");
    println!("{test}: skipped: {why}");
}

fn load(dir: &Path, part: &Part) -> Result<LoadedMesh, String> {
    let path = dir.join(part.file);
    let file = File::open(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let len = file.metadata().map_err(|e| e.to_string())?.len();
    mesh::read_stl(BufReader::new(file), len, part.units())
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// Every shared part, loaded once for all the tests of this binary, or why they are absent.
fn shared_parts() -> Result<&'static [Result<LoadedMesh, String>], String> {
    static PARTS_LOADED: OnceLock<Result<Vec<Result<LoadedMesh, String>>, String>> =
        OnceLock::new();
    PARTS_LOADED
        .get_or_init(|| {
            let dir = data_dir("MOLDGATE_PARTS", "../shared/data/parts")?;
            Ok(PARTS.par_iter().map(|p| load(&dir, p)).collect())
        })
        .as_deref()
        .map_err(Clone::clone)
}

/// The loaded part, for tests other than the loading test (which reports load failures).
fn loaded(parts: &[Result<LoadedMesh, String>], i: usize) -> &LoadedMesh {
    parts[i].as_ref().unwrap_or_else(|e| panic!("{e}"))
}

/// The reference's stored run `tag` (`default` or `offset037`) of a part.
fn reference(dir: &Path, part: &Part, tag: &str) -> Value {
    let path = dir.join(format!("{}.{tag}.json", part.stem()));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn number(v: &Value) -> f64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("expected a number, found {v}"))
}

fn vec2(v: &Value) -> DVec2 {
    DVec2::new(number(&v[0]), number(&v[1]))
}

fn vec3(v: &Value) -> DVec3 {
    DVec3::new(number(&v[0]), number(&v[1]), number(&v[2]))
}

fn size_mm(part: &LoadedMesh) -> f64 {
    part.mesh.bounds().diagonal()
}

/// Prints each part's lines on the test's own thread (rayon's threads may belong to another
/// test's output capture) and returns the failures.
fn print_lines(per_part: Vec<(Vec<String>, Vec<String>)>) -> Vec<String> {
    let mut failures = Vec::new();
    for (lines, f) in per_part {
        for line in lines {
            println!("{line}");
        }
        failures.extend(f);
    }
    failures
}

/// Panics with every failure, one per line, when there is any.
fn report(test: &str, failures: &[String]) {
    assert!(
        failures.is_empty(),
        "{test}: {} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// `x <= tol`, false for NaN, so that a NaN is reported as a failure.
fn within(x: f64, tol: f64) -> bool {
    x <= tol
}

/// Pushes a failure when `|a - b| > tol` (vectors: the length of the difference).
macro_rules! check_close {
    ($failures:expr, $a:expr, $b:expr, $tol:expr, $($what:tt)+) => {{
        let (a, b, tol) = ($a, $b, $tol);
        let diff = (a - b).length();
        if !within(diff, tol) {
            $failures.push(format!(
                "{}: {a:?} vs {b:?}, off by {diff:.3e} > {tol:.3e}",
                format!($($what)+)
            ));
        }
    }};
}

// ---------------------------------------------------------------------------------------------
// Independent geometry: brute force over every triangle, with no use of the library's
// rasteriser.

/// The point of triangle (a, b, c) nearest `p` (Ericson, *Real-Time Collision Detection*,
/// 5.1.5).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

fn distance_to_triangle(mesh: &Mesh, t: usize, p: DVec3) -> f64 {
    let [a, b, c] = mesh.corners(t);
    closest_on_triangle(p, a, b, c).distance(p)
}

/// Distance from `p` to the nearest triangle of the mesh.
fn distance_to_surface(mesh: &Mesh, p: DVec3) -> f64 {
    (0..mesh.triangles.len())
        .map(|t| distance_to_triangle(mesh, t, p))
        .fold(f64::INFINITY, f64::min)
}

/// Heights along `d` of every crossing of the line through `q` (in the frame's plane) with
/// the mesh, highest first. Möller-Trumbore on closed triangles (barycentric >= -1e-9, as the
/// reference does); triangles seen edge-on are skipped.
fn crossings(mesh: &Mesh, frame: &Frame, q: DVec2) -> Vec<f64> {
    let origin = frame.u * q.x + frame.w * q.y;
    let dir = -frame.d;
    let mut heights = Vec::new();
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(t);
        let (e1, e2) = (b - a, c - a);
        let pv = dir.cross(e2);
        let det = e1.dot(pv);
        if det.abs() <= 1e-12 * e1.length() * e2.length() {
            continue;
        }
        let inv = 1.0 / det;
        let s = origin - a;
        let bu = s.dot(pv) * inv;
        let qv = s.cross(e1);
        let bv = dir.dot(qv) * inv;
        const EPS: f64 = 1e-9;
        if bu >= -EPS && bv >= -EPS && bu + bv <= 1.0 + EPS {
            // The ray is origin + t dir, so the height along d is -t.
            heights.push(-e2.dot(qv) * inv);
        }
    }
    heights.sort_by(|x, y| y.total_cmp(x));
    heights
}

/// The gate's circle points (Eq. 6) in the projection plane: k points of radius r around the
/// node, starting on +u.
fn circle(node: DVec2, r: f64, k: usize) -> impl Iterator<Item = DVec2> {
    (0..k).map(move |i| {
        let theta = std::f64::consts::TAU * i as f64 / k as f64;
        node + DVec2::new(theta.cos(), theta.sin()) * r
    })
}

/// Checks a grid gate against the mesh by brute force: it lies on the surface, it is the first
/// hit of its node's ray, and every circle point's ray meets the part.
fn check_gate_geometry(
    failures: &mut Vec<String>,
    name: &str,
    part: &LoadedMesh,
    analysis: &Analysis,
    gate: &Gate,
) {
    let mesh = &part.mesh;
    let tol = 1e-9 * size_mm(part);
    let frame = &analysis.frame;
    let on_surface = distance_to_surface(mesh, gate.point);
    if !within(on_surface, tol) {
        failures.push(format!(
            "{name}: gate {:?} is {on_surface:.3e} mm from the surface",
            gate.point
        ));
    }
    let to_own = distance_to_triangle(mesh, gate.triangle as usize, gate.point);
    if !within(to_own, tol) {
        failures.push(format!(
            "{name}: gate is {to_own:.3e} mm from its triangle {}",
            gate.triangle
        ));
    }
    check_close!(
        failures,
        frame.project(gate.point),
        gate.node_uw,
        tol,
        "{name}: gate point projected vs its node"
    );
    match crossings(mesh, frame, gate.node_uw).first() {
        Some(&top) if (frame.height(gate.point) - top).abs() <= tol => {}
        Some(&top) => failures.push(format!(
            "{name}: gate height {} is not the first hit {top} of its ray",
            frame.height(gate.point)
        )),
        None => failures.push(format!("{name}: the gate's own ray misses the part")),
    }
    let r = analysis.options.gate_radius_mm;
    let k = analysis.options.circle_points;
    let missed: Vec<usize> = circle(gate.node_uw, r, k)
        .enumerate()
        .filter(|(_, q)| crossings(mesh, frame, *q).is_empty())
        .map(|(i, _)| i)
        .collect();
    if !missed.is_empty() {
        failures.push(format!(
            "{name}: circle points {missed:?} of the gate at {:?} miss the part",
            gate.node_uw
        ));
    }
}

// ---------------------------------------------------------------------------------------------
// Tests.

/// Every part loads in its unit, with the reference's facet count and projected box.
#[test]
fn every_shared_part_loads_with_its_units() {
    const TEST: &str = "every_shared_part_loads_with_its_units";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let reference_dir = data_dir("MOLDGATE_REFERENCE", "../shared/reference/results");
    let mut failures = Vec::new();
    for (part, loaded) in PARTS.iter().zip(parts) {
        let name = part.stem();
        let lm = match loaded {
            Ok(lm) => lm,
            Err(e) => {
                failures.push(format!("{name}: does not load: {e}"));
                continue;
            }
        };
        let size = size_mm(lm);
        if lm.stats.units != part.units() {
            failures.push(format!("{name}: read as {}", lm.stats.units));
        }
        // A moulded part is millimetres to decimetres across; a wrong unit is off by 25 or 1000.
        if !(5.0..=300.0).contains(&size) {
            failures.push(format!("{name}: {size:.4} mm across; wrong unit?"));
        }
        if lm.warnings.iter().any(|w| w.contains("--units")) {
            failures.push(format!("{name}: unit warning {:?}", lm.warnings));
        }
        let Ok(dir) = &reference_dir else { continue };
        let r = reference(dir, part, "offset037");
        let s = part.units().mm_per_unit();
        if lm.stats.facets_read != r["triangles"].as_u64().unwrap_or(0) {
            failures.push(format!(
                "{name}: {} facets read, the reference has {}",
                lm.stats.facets_read, r["triangles"]
            ));
        }
        // The reference's frame is moldgate's, and its projected box, scaled to mm, is ours.
        let frame = Frame::new(part.direction());
        check_close!(failures, frame.d, vec3(&r["grid"]["D"]), 1e-12, "{name}: D");
        check_close!(failures, frame.u, vec3(&r["grid"]["u"]), 1e-12, "{name}: u");
        check_close!(failures, frame.w, vec3(&r["grid"]["w"]), 1e-12, "{name}: w");
        let (lo, hi) = lm.mesh.vertices.iter().fold(
            (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(frame.project(p)), hi.max(frame.project(p))),
        );
        let tol = 1e-6 * size;
        check_close!(
            failures,
            lo,
            vec2(&r["grid"]["box_lo"]) * s,
            tol,
            "{name}: box low"
        );
        check_close!(
            failures,
            hi,
            vec2(&r["grid"]["box_hi"]) * s,
            tol,
            "{name}: box high"
        );
    }
    if let Err(why) = reference_dir {
        skip(TEST, &format!("reference comparisons: {why}"));
    }
    report(TEST, &failures);
}

/// Every part the sources list as watertight (trimesh's check, which merges corners within
/// a tolerance) loads closed: no open and no non-manifold edge. (The featuretype block's
/// exporter wrote some corners at zero as -2.7e-16; welded by their bits alone, they left
/// 576 open edges.)
#[test]
fn every_part_listed_as_watertight_loads_closed() {
    const TEST: &str = "every_part_listed_as_watertight_loads_closed";
    let (parts, dir) = match (
        shared_parts(),
        data_dir("MOLDGATE_PARTS", "../shared/data/parts"),
    ) {
        (Ok(p), Ok(d)) => (p, d),
        (Err(why), _) | (_, Err(why)) => return skip(TEST, &why),
    };
    let sources = match std::fs::read_to_string(dir.join("SOURCES.md")) {
        Ok(s) => s,
        Err(e) => return skip(TEST, &format!("SOURCES.md: {e}")),
    };
    let mut failures = Vec::new();
    let mut listed = 0;
    for (part, loaded) in PARTS.iter().zip(parts) {
        // The table's row of the part: | file | ... | watertight | ...
        let Some(row) = sources
            .lines()
            .find(|l| l.starts_with(&format!("| {} |", part.file)))
        else {
            failures.push(format!("{}: no row in SOURCES.md", part.stem()));
            continue;
        };
        let Some(watertight) = row.split('|').nth(8).map(str::trim) else {
            failures.push(format!("{}: row without a watertight column", part.stem()));
            continue;
        };
        if !watertight.starts_with("yes") {
            continue;
        }
        listed += 1;
        let stats = &loaded.as_ref().expect("loads").stats;
        println!(
            "{}: {} open, {} non-manifold edges",
            part.stem(),
            stats.open_edges,
            stats.non_manifold_edges
        );
        if !stats.is_closed() {
            failures.push(format!(
                "{}: listed as watertight, loads with {} open and {} non-manifold edges",
                part.stem(),
                stats.open_edges,
                stats.non_manifold_edges
            ));
        }
    }
    // The table was read: most shared parts are listed as watertight.
    if listed < 10 {
        failures.push(format!("only {listed} parts read as listed watertight"));
    }
    report(TEST, &failures);
}

/// With the natural direction and default options, the gate lies on the surface and its whole
/// circle lands on the part, as brute-force rays see it.
#[test]
fn default_gate_is_on_the_surface_with_its_circle_on_the_part() {
    const TEST: &str = "default_gate_is_on_the_surface_with_its_circle_on_the_part";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let per_part: Vec<(Vec<String>, Vec<String>)> = (0..PARTS.len())
        .into_par_iter()
        .map(|i| {
            let (part, lm) = (&PARTS[i], loaded(parts, i));
            let name = part.stem();
            let (mut lines, mut failures) = (Vec::new(), Vec::new());
            let options = LocateOptions {
                direction: part.direction(),
                ..LocateOptions::default()
            };
            let analysis = locate(lm, &options).expect("valid options");
            let expect_gate = !NO_GATE_BY_THICKNESS.contains(&name);
            match (&analysis.grid_gate, expect_gate) {
                (Some(gate), true) => {
                    check_gate_geometry(&mut failures, name, lm, &analysis, gate);
                    lines.push(format!(
                        "{name:38} gate {:?}, {:.3} mm from the centre",
                        gate.point, gate.distance_3d
                    ));
                }
                (Some(gate), false) => failures.push(format!(
                    "{name}: expected no gate (walls thinner than R), found {:?}; update NO_GATE_BY_THICKNESS",
                    gate.point
                )),
                (None, true) => failures.push(format!(
                    "{name}: no gate: {}",
                    analysis.why_no_candidate()
                )),
                (None, false) => {
                    // The thickness rule removed every candidate; without it there is a gate,
                    // on the surface, with its circle on the part, on a wall thinner than R.
                    let c = analysis.counts;
                    if !(c.circle_on_part > 0 && c.thicker_than_radius + c.thickness_unknown == 0)
                    {
                        failures.push(format!("{name}: no gate, but not by thickness: {c:?}"));
                    }
                    let ignore = LocateOptions {
                        thickness_rule: ThicknessRule::Ignore,
                        ..options.clone()
                    };
                    let analysis = locate(lm, &ignore).expect("valid options");
                    match &analysis.grid_gate {
                        Some(gate) => {
                            check_gate_geometry(&mut failures, name, lm, &analysis, gate);
                            let hits = crossings(&lm.mesh, &analysis.frame, gate.node_uw);
                            let wall = hits.first().zip(hits.get(1)).map(|(a, b)| a - b);
                            let r = options.gate_radius_mm;
                            if !wall.is_some_and(|w| w < r) {
                                failures.push(format!(
                                    "{name}: wall at the thickness-ignoring gate is {wall:?}, not under R = {r}"
                                ));
                            }
                            lines.push(format!(
                                "{name:38} no gate by the thickness rule; ignoring it: {:?}, wall {wall:?} mm",
                                gate.point
                            ));
                        }
                        None => failures.push(format!(
                            "{name}: no gate even ignoring thickness: {}",
                            analysis.why_no_candidate()
                        )),
                    }
                }
            }
            (lines, failures)
        })
        .collect();
    report(TEST, &print_lines(per_part));
}

/// The area-weighted centre of mass (Eq. 5) matches the reference's, and on the reference's
/// offset grid, with the thickness rule off as in the reference, the gate is within one
/// spacing of the reference's 3D-rule gate.
#[test]
fn centre_and_offset_grid_gate_match_the_reference() {
    const TEST: &str = "centre_and_offset_grid_gate_match_the_reference";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let dir = match data_dir("MOLDGATE_REFERENCE", "../shared/reference/results") {
        Ok(d) => d,
        Err(why) => return skip(TEST, &why),
    };
    let per_part: Vec<(Vec<String>, Vec<String>)> = (0..PARTS.len())
        .into_par_iter()
        .map(|i| {
            let (part, lm) = (&PARTS[i], loaded(parts, i));
            let name = part.stem();
            let (mut lines, mut failures) = (Vec::new(), Vec::new());
            let r = reference(&dir, part, "offset037");
            let s = part.units().mm_per_unit();
            let size = size_mm(lm);
            let spacing = number(&r["grid"]["spacing"]) * s;
            let options = LocateOptions {
                direction: part.direction(),
                spacing: Spacing::Mm(spacing),
                grid_offset: number(&r["grid"]["offset"]),
                thickness_rule: ThicknessRule::Ignore,
                ..LocateOptions::default()
            };
            let analysis = locate(lm, &options).expect("valid options");
            // The reference counts a repeated facet twice; moldgate drops it at load (a
            // defect, counted in `duplicate_triangles`), so the centres differ there.
            let repeats = lm.stats.duplicate_triangles;
            if repeats == 0 {
                check_close!(
                    failures,
                    analysis.centres.surface,
                    vec3(&r["centre_of_mass"]["area_weighted"]) * s,
                    1e-6 * size,
                    "{name}: area-weighted centre"
                );
            } else {
                lines.push(format!(
                    "{name}: centre not compared: {repeats} repeated facets dropped at load, \
                     which the reference counts twice"
                ));
            }
            // `gate` holds the reference's aesthetic gate (its runs used --aesthetic); the
            // paper's gate is `gate_3d_rule`.
            let theirs = vec3(&r["gate_3d_rule"]["point"]) * s;
            match &analysis.grid_gate {
                Some(ours) => {
                    let d = ours.point.distance(theirs);
                    let (n_ours, n_theirs) = (
                        analysis.counts.circle_on_part as f64,
                        number(&r["counts"]["candidates"]),
                    );
                    lines.push(format!(
                        "{name:38} gate {:.3} spacings from the reference's; candidates {n_ours} / {n_theirs}",
                        d / spacing
                    ));
                    if !within(d, spacing) {
                        failures.push(format!(
                            "{name}: gate {:?} is {d:.4} mm = {:.2} spacings from the reference's {theirs:?}",
                            ours.point,
                            d / spacing
                        ));
                    }
                    // Rays never lie on an edge on this grid, so the edge conventions agree
                    // and the counts differ only where the grids do (see the comparison doc).
                    if !within((n_ours - n_theirs).abs(), 0.005 * n_theirs) {
                        failures.push(format!(
                            "{name}: {n_ours} candidates, the reference has {n_theirs}"
                        ));
                    }
                }
                None => failures.push(format!(
                    "{name}: no gate: {}",
                    analysis.why_no_candidate()
                )),
            }
            (lines, failures)
        })
        .collect();
    report(TEST, &print_lines(per_part));
}

/// One part's gates with spacings h and h/2, compared.
struct Halving {
    name: String,
    spacing: f64,
    plane_shift: f64,
    shift_3d: f64,
    coarse_distance: f64,
    fine_distance: f64,
}

fn halving(name: &str, part: &LoadedMesh, options: LocateOptions) -> Result<Halving, String> {
    let coarse = locate(part, &options).expect("valid options");
    let h = coarse.grid.spacing;
    let fine = locate(
        part,
        &LocateOptions {
            spacing: Spacing::Mm(h / 2.0),
            ..options
        },
    )
    .expect("valid options");
    match (&coarse.grid_gate, &fine.grid_gate) {
        (Some(a), Some(b)) => Ok(Halving {
            name: name.to_string(),
            spacing: h,
            plane_shift: a.node_uw.distance(b.node_uw),
            shift_3d: a.point.distance(b.point),
            coarse_distance: a.distance_3d,
            fine_distance: b.distance_3d,
        }),
        (a, b) => Err(format!(
            "{name}: gate with h = {h}: {}, with h/2: {}",
            a.is_some(),
            b.is_some()
        )),
    }
}

/// Checks each part's halving against [`HALVING_BOUND`] (or, for a listed exception, that the
/// finer gate is nearer the centre of mass) and prints the table.
fn check_halvings(test: &str, results: Vec<Result<Halving, String>>, failures: &mut Vec<String>) {
    println!("{test}: gate shift from spacing h to h/2, bound {HALVING_BOUND} h in the plane");
    for result in results {
        let h = match result {
            Ok(h) => h,
            Err(e) => {
                failures.push(e);
                continue;
            }
        };
        let listed = HALVING_EXCEPTIONS.contains(&h.name.as_str());
        println!(
            "{:38} h = {:.4} mm: shift {:.3} h in the plane, {:.3} h in 3D; distance to the centre {:.4} -> {:.4} mm{}",
            h.name,
            h.spacing,
            h.plane_shift / h.spacing,
            h.shift_3d / h.spacing,
            h.coarse_distance,
            h.fine_distance,
            if listed { " (listed exception)" } else { "" }
        );
        if listed {
            if !within(h.fine_distance, h.coarse_distance) {
                failures.push(format!(
                    "{}: listed exception, but the finer gate is farther from the centre: {:.4} -> {:.4} mm",
                    h.name, h.coarse_distance, h.fine_distance
                ));
            }
        } else if !within(h.plane_shift, HALVING_BOUND * h.spacing) {
            failures.push(format!(
                "{}: halving h = {:.4} mm moves the gate {:.4} mm = {:.2} h in the plane ({:.2} h in 3D), distance to the centre {:.4} -> {:.4} mm",
                h.name,
                h.spacing,
                h.plane_shift,
                h.plane_shift / h.spacing,
                h.shift_3d / h.spacing,
                h.coarse_distance,
                h.fine_distance
            ));
        }
    }
}

/// Halving the default spacing moves the gate by at most [`HALVING_BOUND`] spacings in the
/// projection plane, on every shared part along its natural direction, with default options
/// (the thickness rule off for the parts of [`NO_GATE_BY_THICKNESS`]).
#[test]
fn halving_the_spacing_barely_moves_the_gate_on_the_shared_parts() {
    const TEST: &str = "halving_the_spacing_barely_moves_the_gate_on_the_shared_parts";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let results: Vec<Result<Halving, String>> = (0..PARTS.len())
        .into_par_iter()
        .map(|i| {
            let name = PARTS[i].stem();
            let options = LocateOptions {
                direction: PARTS[i].direction(),
                // A part without a gate under the thickness rule is checked without it.
                thickness_rule: if NO_GATE_BY_THICKNESS.contains(&name) {
                    ThicknessRule::Ignore
                } else {
                    ThicknessRule::Require
                },
                ..LocateOptions::default()
            };
            halving(name, loaded(parts, i), options)
        })
        .collect();
    let mut failures = Vec::new();
    check_halvings(TEST, results, &mut failures);
    report(TEST, &failures);
}

/// The same on the built-in samples, along +z (the default direction).
#[test]
fn halving_the_spacing_barely_moves_the_gate_on_the_samples() {
    const TEST: &str = "halving_the_spacing_barely_moves_the_gate_on_the_samples";
    let results: Vec<Result<Halving, String>> = moldgate::samples::SAMPLES
        .par_iter()
        .map(|s| {
            let part = mesh::from_generated(moldgate::samples::sample(s.name).expect("sample"));
            halving(s.name, &part, LocateOptions::default())
        })
        .collect();
    let mut failures = Vec::new();
    check_halvings(TEST, results, &mut failures);
    report(TEST, &failures);
}

#[test]
fn balanced_gate_never_does_worse_than_the_paper_gate_on_the_shared_parts() {
    const TEST: &str = "balanced_gate_never_does_worse_than_the_paper_gate_on_the_shared_parts";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    // One part at a time: the fill analysis is parallel inside.
    let per_part: Vec<(Vec<String>, Vec<String>)> = (0..PARTS.len())
        .map(|i| {
            let (part, lm) = (&PARTS[i], loaded(parts, i));
            let name = part.stem();
            let (mut lines, mut failures) = (Vec::new(), Vec::new());
            let options = LocateOptions {
                direction: part.direction(),
                thickness_rule: moldgate::gate::ThicknessRule::Ignore,
                ..LocateOptions::default()
            };
            let analysis = locate(lm, &options).expect("valid options");
            let fill = measured_fill(lm, &analysis, &moldgate::flow::FillOptions::default());
            match fill {
                Ok(f) => {
                    let p = f.paper.as_ref().unwrap();
                    let b = &f.balanced.as_ref().unwrap().fill;
                    lines.push(format!(
                        "{name:38} {} cells: L_max paper {:.2}, balanced {:.2} mm",
                        f.cells, p.l_max_mm, b.l_max_mm
                    ));
                    if !within(b.l_max_mm, p.l_max_mm) {
                        failures.push(format!(
                            "{name}: balanced L_max {} above the paper gate's {}",
                            b.l_max_mm, p.l_max_mm
                        ));
                    }
                    for (what, x) in [("L_max", p.l_max_mm), ("pressure", p.pressure_mpa)] {
                        if !(x.is_finite() && x > 0.0) {
                            failures.push(format!("{name}: {what} {x}"));
                        }
                    }
                    failures.extend(fill_invariants(name, &lm.mesh, &f));
                }
                Err(e) => failures.push(format!("{name}: {e}")),
            }
            (lines, failures)
        })
        .collect();
    report(TEST, &print_lines(per_part));
}

/// No two gates of a several-gate layout overlap: on the parts where the search once put
/// two gates 0.24 to 2.8 mm apart (fill time, four gates), every pair is now at least a
/// gate's diameter apart.
#[test]
fn several_gates_on_the_shared_parts_are_a_gate_s_diameter_apart() {
    const TEST: &str = "several_gates_on_the_shared_parts_are_a_gate_s_diameter_apart";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let once_overlapping = [
        "comma_ram_connector_cap",
        "framework_expansion_card_shell",
        "prusa_heatbed_cable_cover_clip_ascii",
        "prusa_psu_cover_mk3_ascii",
    ];
    let per_part: Vec<(Vec<String>, Vec<String>)> = (0..PARTS.len())
        .filter(|&i| once_overlapping.contains(&PARTS[i].stem()))
        .map(|i| {
            let (part, lm) = (&PARTS[i], loaded(parts, i));
            let name = part.stem();
            let (mut lines, mut failures) = (Vec::new(), Vec::new());
            let options = LocateOptions {
                direction: part.direction(),
                ..LocateOptions::default()
            };
            let analysis = locate(lm, &options).expect("valid options");
            let diameter = 2.0 * analysis.options.gate_radius_mm;
            let fill = measured_fill(
                lm,
                &analysis,
                &moldgate::flow::FillOptions {
                    objective: moldgate::flow::Objective::Resistance,
                    gates: 4,
                    ..Default::default()
                },
            );
            match fill {
                Ok(f) => {
                    let layout = f.several.as_ref().expect("a layout of four gates");
                    let g = &layout.gates;
                    let mut nearest = f64::INFINITY;
                    for a in 0..g.len() {
                        for b in a + 1..g.len() {
                            let (p, q) = (g[a].point, g[b].point);
                            nearest =
                                nearest.min(DVec3::from_array(p).distance(DVec3::from_array(q)));
                        }
                    }
                    lines.push(format!(
                        "{name:38} {} gates, nearest pair {nearest:.2} mm (diameter {diameter:.2})",
                        g.len()
                    ));
                    if g.len() != 4 || nearest < diameter {
                        failures.push(format!(
                            "{name}: {} gates, nearest pair {nearest} mm, under {diameter}",
                            g.len()
                        ));
                    }
                }
                Err(e) => failures.push(format!("{name}: {e}")),
            }
            (lines, failures)
        })
        .collect();
    report(TEST, &print_lines(per_part));
}

/// The fill analysis of a shared part in PP, its walls measured through a tree of its own.
fn measured_fill(
    lm: &LoadedMesh,
    analysis: &moldgate::Analysis,
    options: &moldgate::flow::FillOptions,
) -> Result<moldgate::flow::FillAnalysis, moldgate::flow::FillError> {
    let pp = moldgate::Material::builtin("PP").unwrap();
    let bvh = moldgate::raycast::Bvh::new(&lm.mesh);
    moldgate::flow::analyse(
        &lm.mesh,
        analysis,
        &pp,
        moldgate::flow::Walls::Measure(&bvh),
        options,
    )
}

/// What every fill analysis of a real part must keep: the bodies are the mesh's (stray
/// ones aside), a gate reaches only its own body's share of the volume, every place
/// reported lies on the surface, and the balanced search's numbers agree.
fn fill_invariants(name: &str, mesh: &Mesh, f: &moldgate::flow::FillAnalysis) -> Vec<String> {
    let mut failures = Vec::new();
    let bodies = moldgate::flow::Bodies::of(mesh);
    if f.bodies != bodies.count {
        failures.push(format!(
            "{name}: {} bodies, the mesh has {}",
            f.bodies, bodies.count
        ));
    }
    let p = f.paper.as_ref().unwrap();
    if f.bodies > 1 {
        if p.reached_share > 0.999 {
            failures.push(format!("{name}: {} bodies but all reached", f.bodies));
        }
        if f.body_gates.len() != f.bodies {
            failures.push(format!("{name}: {} body gates", f.body_gates.len()));
        }
    }
    // Places on the surface: within a micrometre of the nearest triangle.
    let mut places = vec![("farthest", p.farthest)];
    places.extend(p.last_to_fill.iter().map(|q| ("last to fill", q.point)));
    places.extend(p.weld_lines.iter().map(|w| ("weld line", w.point)));
    let tol = 1e-6 * mesh.bounds().diagonal().max(1.0);
    for (what, q) in places {
        let d = distance_to_mesh(mesh, DVec3::from_array(q));
        if d > tol {
            failures.push(format!("{name}: {what} {q:?} is {d} mm off the surface"));
        }
    }
    if let Some(b) = &f.balanced {
        let s = &b.search;
        let reported = match f.objective {
            moldgate::flow::Objective::Length => b.fill.l_max_mm,
            moldgate::flow::Objective::Resistance => b.fill.fill_time_s,
        };
        if s.value != reported || s.lower_bound > s.value {
            failures.push(format!(
                "{name}: search value {} bound {} proven {}, the gate's value {reported}",
                s.value, s.lower_bound, s.proven
            ));
        }
    }
    failures
}

/// Distance from `p` to the mesh (brute force over every triangle, exact).
fn distance_to_mesh(mesh: &Mesh, p: DVec3) -> f64 {
    (0..mesh.triangles.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = mesh.corners(t);
            let n = (b - a).cross(c - a);
            let mut best = f64::INFINITY;
            if n.length() > 0.0 {
                let n = n.normalize();
                let foot = p - n * n.dot(p - a);
                if [(a, b), (b, c), (c, a)]
                    .iter()
                    .all(|&(u, v)| (v - u).cross(foot - u).dot(n) >= -1e-12)
                {
                    best = foot.distance(p);
                }
            }
            for (u, v) in [(a, b), (b, c), (c, a)] {
                best = best.min(moldgate::math::nearest_on_segment(u, v, p).distance(p));
            }
            best
        })
        .reduce(|| f64::INFINITY, f64::min)
}

#[test]
fn fill_time_at_the_last_place_converges_with_the_cell_on_a_shared_part() {
    const TEST: &str = "fill_time_at_the_last_place_converges_with_the_cell_on_a_shared_part";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let i = PARTS
        .iter()
        .position(|p| p.file == "prusa_heatbed_cable_cover_clip_ascii.stl")
        .unwrap();
    let (part, lm) = (&PARTS[i], loaded(parts, i));
    let options = LocateOptions {
        direction: part.direction(),
        ..LocateOptions::default()
    };
    let analysis = locate(lm, &options).expect("valid options");
    let bvh = moldgate::raycast::Bvh::new(&lm.mesh);
    let pp = moldgate::Material::builtin("PP").unwrap();
    let at = |h: f64| {
        let f = moldgate::flow::analyse(
            &lm.mesh,
            &analysis,
            &pp,
            moldgate::flow::Walls::Measure(&bvh),
            &moldgate::flow::FillOptions {
                flow: moldgate::flow::FlowOptions {
                    cell_mm: Some(h),
                    ..Default::default()
                },
                ..Default::default()
            },
        )
        .unwrap();
        f.paper.unwrap().fill_time_s
    };
    let (coarse, fine) = (at(0.6), at(0.45));
    let change = (coarse - fine).abs() / fine;
    println!(
        "{TEST}: {coarse:.4} s at 0.6 mm, {fine:.4} s at 0.45 mm ({:.1} %)",
        100.0 * change
    );
    // The fill-order maximum of the code before ran 314 and 285 at these cells, and from
    // 108 to 3279 on another part.
    assert!(change < 0.10, "{coarse} vs {fine}");
}

/// The balanced gate and the gate-suitability map of the fill analysis against brute force
/// (a march from every qualifying node, on the analysis's own cells) on small shared parts,
/// with a coarse grid so that brute force stays affordable. The balanced gate is proven and
/// is the brute force's best to within a cell (two when the paper gate is kept against a
/// gain of at most a cell). Every score of the map is at most the
/// node's objective and every upper bound at least it (to the map's tolerance, one cell),
/// exact scores are the objective, the best node is the brute force's best and, when
/// exact, the balanced gate's.
#[test]
fn balanced_gate_and_suitability_map_hold_against_brute_force_on_small_shared_parts() {
    const TEST: &str =
        "balanced_gate_and_suitability_map_hold_against_brute_force_on_small_shared_parts";
    use moldgate::flow::{self, ScoreKind, Source};
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let mut failures = Vec::new();
    for file in [
        "prusa_heatbed_cable_cover_clip_ascii.stl",
        "screwcap_oralb_75ml_ascii.stl",
        "prusa_lcd_knob.stl",
        "framework_expansion_card_shell.stl",
        "comma2_injection_molded_mount.stl",
    ] {
        let i = PARTS.iter().position(|p| p.file == file).unwrap();
        let (part, lm) = (&PARTS[i], loaded(parts, i));
        // A grid of about 25 nodes across the part.
        let options = LocateOptions {
            direction: part.direction(),
            spacing: moldgate::gate::Spacing::Mm(size_mm(lm) / 25.0),
            ..LocateOptions::default()
        };
        let analysis = locate(lm, &options).expect("valid options");
        if analysis.gate().is_err() {
            failures.push(format!("{file}: no gate"));
            continue;
        }
        let pp = moldgate::Material::builtin("PP").unwrap();
        let f = flow::analyse(
            &lm.mesh,
            &analysis,
            &pp,
            flow::Walls::Estimate,
            &flow::FillOptions {
                suitability: true,
                ..Default::default()
            },
        )
        .unwrap();
        let map = f.suitability.as_ref().unwrap();
        let bodies = flow::Bodies::of(&lm.mesh);
        let voxels = flow::Voxels::bounded(
            &lm.mesh,
            f.cell_mm,
            &bodies.of_triangle,
            &flow::FlowOptions::default(),
        )
        .unwrap();
        assert_eq!(voxels.len(), f.cells, "{file}: the analysis's cells");
        let truth: Vec<f64> = map
            .nodes
            .par_iter()
            .map(|n| {
                let c = voxels.cell_near(DVec3::from_array(n.point)).unwrap();
                let s = Source {
                    point: voxels.centre(c),
                    cell: c,
                };
                flow::argmax(&flow::march(&voxels, &[s], None).t).1
            })
            .collect();
        let tol = map.tolerance;
        let mut gaps = Vec::new();
        for (n, &e) in map.nodes.iter().zip(&truth) {
            gaps.push((e - n.score) / e);
            if n.score > e + tol {
                failures.push(format!("{file}: score {} over {e}", n.score));
            }
            if n.upper.is_none_or(|u| u < e - tol) {
                failures.push(format!("{file}: upper {:?} under {e}", n.upper));
            }
            if n.kind == ScoreKind::Exact && (n.score - e).abs() > tol {
                failures.push(format!("{file}: exact {} vs {e}", n.score));
            }
        }
        let brute_best = truth.iter().copied().fold(f64::INFINITY, f64::min);
        let best = map.best.unwrap();
        if truth[best] > brute_best + tol {
            failures.push(format!(
                "{file}: best {} vs brute force {brute_best}",
                truth[best]
            ));
        }
        let balanced = f.balanced.as_ref().unwrap();
        let b = &balanced.search;
        // The balanced search is over the paper gate's body: on a part of one body, that is
        // every node. Its runs start at the nodes' own points and the brute force's at their
        // cells' centres, so they agree to the map's tolerance (a cell). The paper gate is
        // kept against a gate better by at most a cell: within two of the best.
        let slack = if balanced.is_paper_gate { 2.0 } else { 1.0 } * tol;
        // A gate moves only for a gain of more than a cell.
        let paper = f.paper.as_ref().unwrap().l_max_mm;
        if !balanced.is_paper_gate && paper - b.value <= f.cell_mm {
            failures.push(format!(
                "{file}: balanced {} against the paper gate's {paper}, cells of {}",
                b.value, f.cell_mm
            ));
        }
        if f.bodies == 1 && !(b.proven && b.value <= brute_best + slack) {
            failures.push(format!(
                "{file}: balanced {} (proven {}), brute force {brute_best}",
                b.value, b.proven
            ));
        }
        let off = map.nodes[best].score - b.value;
        if off > 2.0 * tol || (map.nodes[best].kind == ScoreKind::Exact && off < -2.0 * tol) {
            failures.push(format!(
                "{file}: map best {} vs balanced {}",
                map.nodes[best].score, b.value
            ));
        }
        gaps.sort_by(f64::total_cmp);
        println!(
            "{TEST}: {file}: balanced {:.3} mm in {} runs, brute force {brute_best:.3}; {} nodes, {} marches (brute force {}), {} exact, gap max {:.2} % median {:.2} %, certified max {:?} %",
            b.value,
            b.runs,
            map.nodes.len(),
            map.runs,
            truth.len(),
            map.exact,
            100.0 * gaps.last().copied().unwrap_or(0.0),
            100.0 * gaps[gaps.len() / 2],
            map.max_gap_pct
        );
    }
    report(TEST, &failures);
}

/// Each body's fill is measured against its own nominal wall: on the PSU cover (a box and a
/// lid in one file) each body filled from the same gate gives, with both bodies in the file,
/// what it gives alone. The body alone keeps every vertex of the file, so the voxel grid
/// (laid from the vertices' box) is the same cell for cell; what may still differ is only
/// rounding (f32 costs summed in a different order of bodies), hence a relative tolerance of
/// 1e-6 on fill time, pressure, flow ratio and L_max, and equality of the body's nominal wall.
/// The PSU cover's balanced search stops before it proves its gate (its far points are
/// spread around two rims): the report page says so, with the most a candidate could still
/// gain below it, rather than calling the gate the best.
#[test]
fn the_page_says_when_the_balanced_search_stopped_unproven() {
    const TEST: &str = "the_page_says_when_the_balanced_search_stopped_unproven";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    let i = PARTS
        .iter()
        .position(|p| p.file == "prusa_psu_cover_mk3_ascii.stl")
        .unwrap();
    let loaded = loaded(parts, i);
    let options: moldgate::study::StudyOptions =
        serde_json::from_str(r#"{ "demold": "+z", "fill": true }"#).unwrap();
    let s = moldgate::study::study(loaded, &options).unwrap_or_else(|e| panic!("{e}"));
    let b = s.report().fill.as_ref().unwrap().balanced.as_ref().unwrap();
    assert!(!b.search.proven, "{:?}", b.search);
    let gap = b.search.unproven_gap_pct().unwrap();
    println!(
        "{TEST}: {} runs, a candidate up to {gap:.2} % lower",
        b.search.runs
    );
    assert!(gap > 0.0 && gap < 100.0, "{gap}");
    let words = b.search.unproven_words();
    assert!(words.contains(&format!("{gap:.1} % lower")), "{words}");
    let page = s.html(None).unwrap();
    assert!(page.contains(&words), "{words} not on the page");
    assert!(!page.contains("no candidate better by more than a flow cell)"));
}

#[test]
fn each_body_of_the_psu_cover_fills_as_it_would_alone() {
    const TEST: &str = "each_body_of_the_psu_cover_fills_as_it_would_alone";
    let dir = match data_dir("MOLDGATE_PARTS", "../shared/data/parts") {
        Ok(d) => d,
        Err(why) => return skip(TEST, &why),
    };
    let part = PARTS
        .iter()
        .find(|p| p.file == "prusa_psu_cover_mk3_ascii.stl")
        .unwrap();
    let whole = load(&dir, part).unwrap_or_else(|e| panic!("{e}"));
    let options = LocateOptions {
        direction: part.direction(),
        ..LocateOptions::default()
    };
    let pp = moldgate::Material::builtin("PP").unwrap();
    let fill_options = |cell: Option<f64>, placed: Vec<DVec3>| moldgate::flow::FillOptions {
        flow: moldgate::flow::FlowOptions {
            cell_mm: cell,
            ..Default::default()
        },
        placed,
        ..Default::default()
    };
    let run = |lm: &LoadedMesh, cell: Option<f64>, placed: Vec<DVec3>| {
        let analysis = locate(lm, &options).expect("valid options");
        let bvh = moldgate::raycast::Bvh::new(&lm.mesh);
        moldgate::flow::analyse(
            &lm.mesh,
            &analysis,
            &pp,
            moldgate::flow::Walls::Measure(&bvh),
            &fill_options(cell, placed),
        )
        .unwrap_or_else(|e| panic!("{e}"))
    };
    let both = run(&whole, None, Vec::new());
    assert_eq!(both.bodies, 2, "the PSU cover is a box and a lid");
    let body_of = moldgate::mesh::topology::body_of_triangle(&whole.mesh);
    let walls: Vec<f64> = both.body_gates.iter().map(|b| b.nominal_wall_mm).collect();
    println!(
        "{TEST}: cell {:.4} mm, body walls {walls:?} mm",
        both.cell_mm
    );
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs());
    for g in &both.body_gates {
        let gate = DVec3::from_array(g.gate.expect("every body has a gate"));
        // The body's triangles (its mesh body: the flow's bodies number them alike, the
        // largest-area rule aside), every vertex kept.
        let own = body_of[(0..whole.mesh.triangles.len())
            .min_by(|&s, &t| {
                let d = |t: usize| {
                    let [a, b, c] = whole.mesh.corners(t);
                    ((a + b + c) / 3.0).distance(gate)
                };
                d(s).total_cmp(&d(t))
            })
            .unwrap()];
        let alone = Mesh {
            vertices: whole.mesh.vertices.clone(),
            triangles: (0..whole.mesh.triangles.len())
                .filter(|&t| body_of[t] == own)
                .map(|t| whole.mesh.triangles[t])
                .collect(),
        };
        let alone = mesh::from_generated(alone);
        assert_eq!(
            alone.mesh.bounds(),
            whole.mesh.bounds(),
            "the grid must be the same"
        );
        let with = run(&whole, Some(both.cell_mm), vec![gate]);
        let solo = run(&alone, Some(both.cell_mm), vec![gate]);
        assert_eq!(solo.bodies, 1);
        let (w, s) = (&with.placed.unwrap().fill, &solo.placed.unwrap().fill);
        println!(
            "{TEST}: body {}: fill {:.4} s with both, {:.4} s alone; nominal {:.3} / {:.3} mm; \
             L_max {:.2} / {:.2} mm; {:.3} / {:.3} MPa; L/t {:.2} / {:.2}",
            g.body,
            w.fill_time_s,
            s.fill_time_s,
            g.nominal_wall_mm,
            solo.nominal_wall_mm,
            w.l_max_mm,
            s.l_max_mm,
            w.pressure_mpa,
            s.pressure_mpa,
            w.flow_ratio,
            s.flow_ratio
        );
        assert_eq!(g.nominal_wall_mm, solo.nominal_wall_mm, "body {}", g.body);
        assert!(
            close(g.fill_time_s.unwrap(), w.fill_time_s),
            "body {}",
            g.body
        );
        for (what, a, b) in [
            ("fill time", w.fill_time_s, s.fill_time_s),
            ("pressure", w.pressure_mpa, s.pressure_mpa),
            ("flow ratio", w.flow_ratio, s.flow_ratio),
            ("L_max", w.l_max_mm, s.l_max_mm),
        ] {
            assert!(
                close(a, b),
                "body {}: {what} {a} with both, {b} alone",
                g.body
            );
        }
    }
}

/// The 352k housing's two thin keyhole slots fill in up to about 0.12 s where 99 % of its
/// cells fill within a quarter of that: one colour scale over both painted the whole part
/// one colour. The fill time's colours stop at the cells' 99th percentile, the GLB says so
/// with the largest value, and the PNG's cells under the bar's top are few; the PSU cover,
/// without such a tail, keeps its whole range.
#[test]
fn a_far_tail_of_slow_cells_does_not_take_the_whole_colour_scale() {
    const TEST: &str = "a_far_tail_of_slow_cells_does_not_take_the_whole_colour_scale";
    let parts = match shared_parts() {
        Ok(p) => p,
        Err(why) => return skip(TEST, &why),
    };
    for (file, demold, tail) in [
        ("esp32s3box_bottom_housing_352k.stl", "+y", true),
        ("prusa_psu_cover_mk3_ascii.stl", "+z", false),
    ] {
        let i = PARTS.iter().position(|p| p.file == file).unwrap();
        let loaded = loaded(parts, i);
        let options: moldgate::study::StudyOptions =
            serde_json::from_str(&format!(r#"{{ "demold": "{demold}", "fill": true }}"#)).unwrap();
        let s = moldgate::study::study(loaded, &options).unwrap_or_else(|e| panic!("{e}"));
        let scene = s.scene(loaded, file).unwrap();
        let range = scene.field.range().unwrap();
        let (span, beyond) = scene.field.colour_span().unwrap();
        println!("{TEST}: {file}: range {range:?}, colours {span:?}, beyond {beyond:?}");
        let glb = s.glb(loaded, file).unwrap();
        let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        let json: Value = serde_json::from_slice(&glb[20..20 + len]).unwrap();
        let field = &json["asset"]["extras"]["field"];
        // The JSON's numbers are the f32 values, written shortest.
        let f32_of = |v: &Value| v.as_f64().unwrap() as f32;
        assert_eq!(f32_of(&field["min"]), span[0], "{file}");
        assert_eq!(f32_of(&field["max"]), span[1], "{file}");
        if tail {
            assert_eq!(beyond, Some(range[1]), "{file}");
            assert!(range[1] > 2.0 * span[1], "{file}: {range:?} {span:?}");
            assert_eq!(f32_of(&field["largest"]), range[1], "{file}");
            // The bar ends at the time the report gives for 99 % of the volume.
            let fill = s.report().fill.as_ref().unwrap().paper.as_ref().unwrap();
            let most = fill.fill_time_99_s;
            assert!(
                (f64::from(span[1]) - most).abs() <= 1e-6 * most,
                "{file}: {span:?} against {most}"
            );
        } else {
            assert_eq!((span, beyond), (range, None), "{file}");
            assert!(field["largest"].is_null(), "{file}");
        }
    }
}
