//! The GLB writer: read back with a small reader of our own (header, chunks, JSON, accessors)
//! and compared with the mesh it came from; and checked by the Khronos glTF validator.
//!
//! The validator is the npm package `gltf-validator`, pinned in `tools/gltf-validator` and
//! installed with `npm ci --prefix tools/gltf-validator`. Without `node` or without the
//! installed package the validator test says why and passes without checking, unless
//! `MOLDGATE_REQUIRE_GLTF_VALIDATOR` is set (CI sets it when node is present), when it fails.
//! The shared real parts are looked for at `$MOLDGATE_PARTS`, else at
//! `<workspace>/../shared/data/parts`; without them the shared-part case is skipped.

use std::path::{Path, PathBuf};
use std::process::Command;

use moldgate::colormap::{self, srgb_to_linear};
use moldgate::gltf::glb;
use moldgate::math::DVec3;
use moldgate::mesh::{self, LoadedMesh, Mesh, Units};
use moldgate::scene::{Field, Marker, Scene};
use moldgate::{locate, Direction, Frame, GateMode, LocateOptions};
use serde_json::Value;

// ---------------------------------------------------------------- a small GLB reader

/// A parsed GLB: its JSON and its binary chunk.
struct Glb {
    json: Value,
    bin: Vec<u8>,
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// Reads a GLB and checks its framing against the spec: magic, version, total length, a
/// JSON chunk padded to 4 bytes, then at most one BIN chunk padded to 4 bytes.
fn read_glb(bytes: &[u8]) -> Glb {
    assert!(bytes.len() >= 20, "too short for a GLB");
    assert_eq!(&bytes[0..4], b"glTF");
    assert_eq!(u32_at(bytes, 4), 2, "version");
    assert_eq!(u32_at(bytes, 8) as usize, bytes.len(), "header length");
    let json_len = u32_at(bytes, 12) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let json: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let rest = &bytes[20 + json_len..];
    let bin = if rest.is_empty() {
        Vec::new()
    } else {
        let bin_len = u32_at(rest, 0) as usize;
        assert_eq!(&rest[4..8], b"BIN\0");
        assert_eq!(bin_len % 4, 0);
        assert_eq!(rest.len(), 8 + bin_len, "bytes after the BIN chunk");
        rest[8..].to_vec()
    };
    if let Some(buffers) = json["buffers"].as_array() {
        assert_eq!(buffers.len(), 1);
        let declared = buffers[0]["byteLength"].as_u64().unwrap() as usize;
        assert!(declared <= bin.len() && bin.len() - declared < 4);
    }
    Glb { json, bin }
}

impl Glb {
    /// The raw bytes of accessor `a`, with its component type, type and count checked.
    fn accessor_bytes(&self, a: usize, component: u64, kind: &str, size: usize) -> &[u8] {
        let acc = &self.json["accessors"][a];
        assert_eq!(acc["componentType"].as_u64(), Some(component));
        assert_eq!(acc["type"].as_str(), Some(kind));
        let count = acc["count"].as_u64().unwrap() as usize;
        let view = &self.json["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
            + acc["byteOffset"].as_u64().unwrap_or(0) as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        assert!(view.get("byteStride").is_none(), "tightly packed");
        assert!(count * size <= len);
        &self.bin[start..start + count * size]
    }

    fn vec3(&self, a: usize) -> Vec<[f32; 3]> {
        self.accessor_bytes(a, 5126, "VEC3", 12)
            .chunks(12)
            .map(|c| {
                let f = |i: usize| f32::from_le_bytes(c[4 * i..4 * i + 4].try_into().unwrap());
                [f(0), f(1), f(2)]
            })
            .collect()
    }

    fn u32s(&self, a: usize) -> Vec<u32> {
        self.accessor_bytes(a, 5125, "SCALAR", 4)
            .chunks(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    /// The node named `name` (a child of the root), if any.
    fn node(&self, name: &str) -> Option<&Value> {
        self.json["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|n| n["name"] == name)
    }

    /// The single primitive of the mesh of node `name`.
    fn primitive(&self, name: &str) -> &Value {
        let node = self.node(name).unwrap_or_else(|| panic!("no node {name}"));
        let m = node["mesh"].as_u64().unwrap() as usize;
        let prims = self.json["meshes"][m]["primitives"].as_array().unwrap();
        assert_eq!(prims.len(), 1);
        &prims[0]
    }

    fn attribute(&self, prim: &Value, name: &str) -> usize {
        prim["attributes"][name].as_u64().unwrap() as usize
    }
}

fn f32s(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

fn dvec(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

// ---------------------------------------------------------------- scenes

fn analysed(part: &LoadedMesh, options: &LocateOptions) -> moldgate::Analysis {
    locate(part, options).unwrap()
}

fn sample(name: &str) -> LoadedMesh {
    mesh::from_generated(moldgate::samples::sample(name).unwrap())
}

fn empty_field() -> Field {
    Field {
        name: "nothing".into(),
        unit: String::new(),
        per_vertex: Vec::new(),
        cells: None,
        span: None,
    }
}

/// A unit cube scaled by `s`, with the right-hand normals outwards.
fn cube(s: f64) -> Mesh {
    let vertices = (0..8)
        .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64) * s)
        .collect();
    // Faces as quads (counter-clockwise seen from outside), split in two.
    let quads = [
        [0, 2, 3, 1], // z = 0
        [4, 5, 7, 6], // z = 1
        [0, 1, 5, 4], // y = 0
        [2, 6, 7, 3], // y = 1
        [0, 4, 6, 2], // x = 0
        [1, 3, 7, 5], // x = 1
    ];
    let triangles = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    Mesh {
        vertices,
        triangles,
    }
}

// ---------------------------------------------------------------- round trip

/// The checks every GLB of a scene must pass: the part's triangles in order with the mesh's
/// positions, the POSITION bounds equal to the mesh's, unit normals within the crease angle
/// of their face, colours from the colour map, the root's scale and rotation.
fn check_round_trip(scene: &Scene, bytes: &[u8]) -> Glb {
    let g = read_glb(bytes);
    let mesh = scene.mesh;

    let part = g.primitive("part");
    assert_eq!(part["mode"].as_u64(), Some(4));
    let indices = g.u32s(part["indices"].as_u64().unwrap() as usize);
    let positions = g.vec3(g.attribute(part, "POSITION"));
    let normals = g.vec3(g.attribute(part, "NORMAL"));
    let colours = g.vec3(g.attribute(part, "COLOR_0"));
    assert_eq!(indices.len(), 3 * mesh.triangles.len(), "triangle count");
    assert_eq!(normals.len(), positions.len());
    assert_eq!(colours.len(), positions.len());

    // Same triangles, same order, same corners (as f32).
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let i = indices[3 * t + k] as usize;
            assert_eq!(
                positions[i],
                f32s(mesh.vertices[tri[k] as usize]),
                "triangle {t}"
            );
        }
    }

    // Bounds: declared min/max, the data's, and the mesh's, all equal.
    let acc = &g.json["accessors"][g.attribute(part, "POSITION")];
    let declared = |k: &str| -> [f32; 3] {
        let a = acc[k].as_array().unwrap();
        [0, 1, 2].map(|i| a[i].as_f64().unwrap() as f32)
    };
    let b = mesh.bounds();
    assert_eq!(declared("min"), f32s(b.min));
    assert_eq!(declared("max"), f32s(b.max));
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in &positions {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    assert_eq!((lo, hi), (f32s(b.min), f32s(b.max)));

    // Normals: unit, and within 30 degrees (plus f32 rounding) of their face.
    for (t, _) in mesh.triangles.iter().enumerate() {
        let face = mesh.normal(t);
        for k in 0..3 {
            let n = dvec(normals[indices[3 * t + k] as usize]);
            assert!((n.length() - 1.0).abs() < 1e-6);
            if face != DVec3::ZERO {
                assert!(n.dot(face) > 0.866 - 1e-6, "triangle {t}: {n} vs {face}");
            }
        }
    }

    // Colours: the field through the map, as linear light; the field's ends get the map's.
    let field = &scene.field.per_vertex;
    if let Some(range) = colormap::Range::of(field) {
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let v = tri[k] as usize;
                let c = colormap::colour(range.t(field[v])).map(srgb_to_linear);
                assert_eq!(colours[indices[3 * t + k] as usize], c);
            }
        }
        let lowest = (0..field.len())
            .min_by(|&a, &b| field[a].total_cmp(&field[b]))
            .unwrap();
        let c0 = colormap::colour(0.0).map(srgb_to_linear);
        let i = positions
            .iter()
            .position(|&p| p == f32s(mesh.vertices[lowest]))
            .unwrap();
        assert_eq!(colours[i], c0);
    }

    // The root: mm to m, and the demolding direction up.
    let root = g.node("moldgate").unwrap();
    assert_eq!(root["scale"], serde_json::json!([0.001, 0.001, 0.001]));
    let q: Vec<f64> = root["rotation"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let q = glam::DQuat::from_xyzw(q[0], q[1], q[2], q[3]);
    assert!((q * scene.frame.d - DVec3::Y).length() < 1e-9);
    let d = &g.json["asset"]["extras"]["demolding_direction"];
    for i in 0..3 {
        assert!((d[i].as_f64().unwrap() - scene.frame.d[i]).abs() < 1e-12);
    }
    g
}

/// The gate disc: every vertex within R (and exactly R on the rim) of the gate's axis, and
/// between the surface point and R/2 above it.
fn check_gate(g: &Glb, marker: &Marker, axis: DVec3) {
    let prim = g.primitive("gate 1");
    let p = g.vec3(g.attribute(prim, "POSITION"));
    let r = marker.radius_mm;
    let mut on_rim = 0;
    for q in &p {
        let v = dvec(*q) - marker.point;
        let along = v.dot(axis);
        let off = (v - axis * along).length();
        let tol = 1e-5 * (1.0 + marker.point.length());
        assert!(along > -tol && along < 0.5 * r + tol, "height {along}");
        assert!(off < r + tol);
        if (off - r).abs() < tol {
            on_rim += 1;
        }
    }
    assert!(on_rim > p.len() / 2, "{on_rim} of {} on the rim", p.len());
}

#[test]
fn sample_parts_round_trip() {
    for name in ["plate", "cover", "cap", "tray", "bracket"] {
        let part = sample(name);
        let options = LocateOptions::default();
        let analysis = analysed(&part, &options);
        let scene = Scene::new(&part.mesh, &analysis, name);
        let bytes = glb(&scene).unwrap();
        let g = check_round_trip(&scene, &bytes);
        let marker = scene.gates[0];
        check_gate(&g, &marker, marker.normal);
        assert!(g.node("centre of mass").is_some());
        let lines = g.primitive("parting line");
        assert_eq!(lines["mode"].as_u64(), Some(1));
        let segments: usize = scene.parting.iter().map(|l| l.len() - 1).sum();
        assert_eq!(g.vec3(g.attribute(lines, "POSITION")).len(), 2 * segments);
        let points = g.primitive("qualifying nodes");
        assert_eq!(
            g.vec3(g.attribute(points, "POSITION")).len(),
            scene.qualifying.len()
        );
    }
}

#[test]
fn cube_has_sharp_edges() {
    // Closed form: a cube's 12 triangles meet at 90 degrees, beyond the crease angle, so each
    // of its 8 corners is split into 3 vertices, one per face, with the face's normal.
    let mesh = cube(10.0);
    let frame = Frame::new(Direction::PLUS_Z);
    let field = Field {
        name: "height along D".into(),
        unit: "mm".into(),
        per_vertex: mesh.vertices.iter().map(|p| p.z as f32).collect(),
        cells: None,
        span: None,
    };
    let scene = Scene {
        mesh: &mesh,
        topology: None,
        frame,
        field,
        display: None,
        gates: vec![],
        placed: vec![],
        centre: DVec3::splat(5.0),
        parting: vec![],
        qualifying: vec![],
        node_field: None,
        title: "cube".into(),
        subtitle: String::new(),
        grid_spacing_mm: 1.0,
        keep_out: Vec::new(),
    };
    let bytes = glb(&scene).unwrap();
    let g = check_round_trip(&scene, &bytes);
    let part = g.primitive("part");
    let normals = g.vec3(g.attribute(part, "NORMAL"));
    assert_eq!(normals.len(), 24);
    for n in normals {
        let axes = n.iter().filter(|c| c.abs() == 1.0).count();
        let zeros = n.iter().filter(|c| **c == 0.0).count();
        assert_eq!((axes, zeros), (1, 2), "{n:?}");
    }
    // The top is yellow (t = 1), the bottom dark purple (t = 0).
    let colours = g.vec3(g.attribute(part, "COLOR_0"));
    let positions = g.vec3(g.attribute(part, "POSITION"));
    for (p, c) in positions.iter().zip(&colours) {
        let t = if p[2] == 0.0 { 0.0 } else { 1.0 };
        assert_eq!(*c, colormap::colour(t).map(srgb_to_linear));
    }
    assert!(g.node("gate 1").is_none());
    assert!(g.node("parting line").is_none());
}

#[test]
fn unknown_values_are_grey_and_missing_gate_normal_uses_d() {
    let part = sample("cover");
    let options = LocateOptions {
        mode: GateMode::Aesthetic,
        direction: "-y".parse().unwrap(),
        ..LocateOptions::default()
    };
    let analysis = analysed(&part, &options);
    let mut scene = Scene::new(&part.mesh, &analysis, "cover, aesthetic");
    // The aesthetic gate has no surface normal: the disc stands along D.
    assert_eq!(scene.gates[0].normal, DVec3::ZERO);
    scene.field.per_vertex[0] = f32::NAN;
    let bytes = glb(&scene).unwrap();
    let g = check_round_trip(&scene, &bytes);
    check_gate(&g, &scene.gates[0], scene.frame.d);
    let part_prim = g.primitive("part");
    let colours = g.vec3(g.attribute(part_prim, "COLOR_0"));
    let positions = g.vec3(g.attribute(part_prim, "POSITION"));
    let grey = colormap::NAN_GREY.map(srgb_to_linear);
    for (p, c) in positions.iter().zip(&colours) {
        if *p == f32s(part.mesh.vertices[0]) {
            assert_eq!(*c, grey);
        } else {
            assert_ne!(*c, grey);
        }
    }
}

/// A scene with nothing in it: no triangles, gates, lines or points.
fn empty_scene(mesh: &Mesh) -> Scene<'_> {
    Scene {
        mesh,
        topology: None,
        frame: Frame::new(Direction::PLUS_Z),
        field: empty_field(),
        display: None,
        gates: vec![],
        placed: vec![],
        centre: DVec3::ZERO,
        parting: vec![],
        qualifying: vec![],
        node_field: None,
        title: "empty".into(),
        subtitle: String::new(),
        grid_spacing_mm: 1.0,
        keep_out: Vec::new(),
    }
}

#[test]
fn empty_scene_is_still_a_glb() {
    let mesh = Mesh::default();
    let scene = empty_scene(&mesh);
    let g = read_glb(&glb(&scene).unwrap());
    assert!(g.bin.is_empty());
    assert!(g.json.get("meshes").is_none());
    assert_eq!(g.json["asset"]["version"], "2.0");
}

// ---------------------------------------------------------------- the Khronos validator

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Where the validator can run, or why it cannot.
fn validator() -> Result<PathBuf, String> {
    let tool = workspace().join("tools/gltf-validator");
    match Command::new("node").arg("--version").output() {
        Ok(o) if o.status.success() => {}
        _ => return Err("node is not installed".into()),
    }
    if !tool
        .join("node_modules/gltf-validator/package.json")
        .is_file()
    {
        return Err(format!(
            "the validator is not installed (npm ci --prefix {})",
            tool.display()
        ));
    }
    Ok(tool.join("validate.js"))
}

fn skip_or_fail(test: &str, why: &str) {
    if std::env::var_os("MOLDGATE_REQUIRE_GLTF_VALIDATOR").is_some() {
        panic!("{test}: MOLDGATE_REQUIRE_GLTF_VALIDATOR is set but {why}");
    }
    eprintln!("{test}: skipped: {why}");
    println!("{test}: skipped: {why}");
}

/// The validator's report on `bytes` and its exit status.
fn run_validator(script: &Path, dir: &Path, name: &str, bytes: &[u8]) -> (Value, bool) {
    let file = dir.join(format!("{name}.glb"));
    std::fs::write(&file, bytes).unwrap();
    let out = Command::new("node")
        .arg(script)
        .arg(&file)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report: Value = serde_json::from_str(&stdout).unwrap_or_else(|e| {
        panic!(
            "{name}: no report from the validator ({e}): {}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    (report, out.status.success())
}

/// A GLB of `json` and `bin`, framed as the spec says (for the negative control).
fn frame_glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).unwrap();
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

/// Runs the validator on `bytes`; returns the report, or panics with its errors.
fn validate(script: &Path, dir: &Path, name: &str, bytes: &[u8]) -> Value {
    let (report, success) = run_validator(script, dir, name, bytes);
    let issues = &report["issues"];
    let messages: Vec<String> = issues["messages"]
        .as_array()
        .map(|m| {
            m.iter()
                .map(|i| {
                    format!(
                        "  [{}] {} {}: {}",
                        i["severity"], i["code"], i["pointer"], i["message"]
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    println!(
        "{name}: {} errors, {} warnings, {} infos, {} hints\n{}",
        issues["numErrors"],
        issues["numWarnings"],
        issues["numInfos"],
        issues["numHints"],
        messages.join("\n")
    );
    assert_eq!(
        issues["numErrors"].as_u64(),
        Some(0),
        "{name}: {messages:#?}"
    );
    assert_eq!(
        issues["numWarnings"].as_u64(),
        Some(0),
        "{name}: {messages:#?}"
    );
    assert!(
        success,
        "{name}: the validator's exit status says it failed"
    );
    report
}

#[test]
fn khronos_validator_accepts_our_files() {
    let script = match validator() {
        Ok(s) => s,
        Err(why) => return skip_or_fail("khronos_validator_accepts_our_files", &why),
    };
    let dir = tempfile::tempdir().unwrap();

    // Every sample part along +z, and one along a slanted direction, with its gate.
    let mut cases: Vec<(String, LoadedMesh, LocateOptions)> = Vec::new();
    for name in ["plate", "cover", "cap", "tray", "bracket"] {
        cases.push((name.into(), sample(name), LocateOptions::default()));
    }
    let slanted = LocateOptions {
        direction: "1,-2,3".parse().unwrap(),
        ..LocateOptions::default()
    };
    cases.push(("bracket-slanted".into(), sample("bracket"), slanted));
    let aesthetic = LocateOptions {
        mode: GateMode::Aesthetic,
        ..LocateOptions::default()
    };
    cases.push(("tray-aesthetic".into(), sample("tray"), aesthetic));

    // One shared real part, when the data is present.
    let parts = std::env::var_os("MOLDGATE_PARTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("../shared/data/parts"));
    let shared = parts.join("watchy_yatari_top.stl");
    if shared.is_file() {
        let bytes = std::fs::read(&shared).unwrap();
        let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).unwrap();
        cases.push(("watchy_yatari_top".into(), part, LocateOptions::default()));
    } else {
        skip_or_fail_shared(&shared);
    }

    for (name, part, options) in &cases {
        let analysis = analysed(part, options);
        let scene = Scene::new(&part.mesh, &analysis, name.clone());
        let bytes = glb(&scene).unwrap();
        check_round_trip(&scene, &bytes);
        let report = validate(&script, dir.path(), name, &bytes);
        let info = &report["info"];
        assert_eq!(
            info["totalTriangleCount"].as_u64().unwrap_or(0) as usize,
            part.mesh.triangles.len() + 8 + 4 * 32 * scene.gates.len(),
            "{name}: triangles the validator counted (part, centre, gates)"
        );
    }

    // A scene with nothing in it but its asset.
    let mesh = Mesh::default();
    let scene = empty_scene(&mesh);
    validate(&script, dir.path(), "empty", &glb(&scene).unwrap());

    // Negative control: the same plate with a wrong POSITION maximum must be refused, so a
    // validator that checks nothing cannot pass this test.
    let part = sample("plate");
    let analysis = analysed(&part, &LocateOptions::default());
    let scene = Scene::new(&part.mesh, &analysis, "plate");
    let g = read_glb(&glb(&scene).unwrap());
    let mut json = g.json.clone();
    let position = g.attribute(g.primitive("part"), "POSITION");
    let max = json["accessors"][position]["max"][0].as_f64().unwrap();
    json["accessors"][position]["max"][0] = serde_json::json!(max + 1.0);
    let (report, success) = run_validator(&script, dir.path(), "broken", &frame_glb(&json, &g.bin));
    assert!(report["issues"]["numErrors"].as_u64().unwrap() > 0);
    assert!(!success);
}

fn skip_or_fail_shared(path: &Path) {
    let why = format!("{} not found (set MOLDGATE_PARTS)", path.display());
    eprintln!("khronos_validator_accepts_our_files: shared part skipped: {why}");
    println!("khronos_validator_accepts_our_files: shared part skipped: {why}");
}

#[test]
fn placed_gates_are_named_nodes_standing_along_their_normals() {
    // The bracket: a point above the base's top (normal +z) and one beside the upright's
    // face (normal +x, not seen along D: it fails, and is still shown).
    let part = sample("bracket");
    let options: moldgate::StudyOptions =
        serde_json::from_str(r#"{ "gate_at": ["30,20,7", "5.5,20,30"] }"#).unwrap();
    let s = moldgate::study(&part, &options).unwrap();
    let bytes = s.glb(&part, "bracket").unwrap();
    let g = read_glb(&bytes);
    let r = s.analysis().options.gate_radius_mm;
    for (name, point, normal, qualifies) in [
        ("your gate 1", DVec3::new(30.0, 20.0, 5.0), DVec3::Z, true),
        ("your gate 2", DVec3::new(5.0, 20.0, 30.0), DVec3::X, false),
    ] {
        let node = g.node(name).unwrap_or_else(|| panic!("no node {name}"));
        let extras = &node["extras"];
        assert_eq!(
            extras["normal"],
            serde_json::json!(normal.to_array()),
            "{name}"
        );
        assert_eq!(
            extras["point_mm"],
            serde_json::json!(point.to_array()),
            "{name}"
        );
        assert_eq!(extras["qualifies"], qualifies, "{name}");
        // The cylinder: every vertex within R of the axis through the point along the
        // normal, between the surface and R/2 above it.
        let p = g.vec3(g.attribute(g.primitive(name), "POSITION"));
        for q in &p {
            let v = dvec(*q) - point;
            let along = v.dot(normal);
            let off = (v - normal * along).length();
            assert!(
                along > -1e-4 && along < 0.5 * r + 1e-4,
                "{name}: height {along}"
            );
            assert!(off < r + 1e-4, "{name}: {off}");
        }
    }
    assert_eq!(
        g.json["asset"]["extras"]["placed_gates"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
    match validator() {
        Ok(script) => {
            let dir = tempfile::tempdir().unwrap();
            validate(&script, dir.path(), "placed", &bytes);
        }
        Err(why) => skip_or_fail(
            "placed_gates_are_named_nodes_standing_along_their_normals",
            &why,
        ),
    }
}
