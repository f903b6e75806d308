//! A part read from bytes and studied, and what the page asks of it: the report, the GLB
//! coloured by a chosen field, the PNG and the HTML page. Plain Rust, tested natively; the
//! exports in [`crate::ffi`] only move bytes in and out of it.

use moldgate::clock::Instant;
use moldgate::mesh::{self, LoadedMesh, Units};
use moldgate::report::Input;
use moldgate::scene::{Field, Scene};
use moldgate::study::{Hooks, Progress, Settings, Study, StudyOptions};
use serde::Deserialize;

/// The largest file the page accepts, in bytes. A wasm32 module addresses 4 GiB in all, and
/// a mesh in memory takes about as much as its binary STL; 1 GiB leaves room for the study.
pub const MAX_FILE_BYTES: usize = 1 << 30;

/// What the page asks for: a file (its name says the format) or a sample, the unit of the
/// file, and the study's options (the command line's, [`StudyOptions`]).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Request {
    /// The file's name (`part.stl`): its extension chooses the reader.
    pub file_name: String,
    /// A built-in sample instead of a file (`"cover"`).
    pub sample: Option<String>,
    /// The unit of the file: `mm` (default), `cm`, `m`, `in`.
    pub units: Option<String>,
    /// The study's options.
    pub options: StudyOptions,
    /// A user's materials file (the command line's `--materials-file`): a material of it
    /// is chosen by name in the options, and wins over a built-in of the same name.
    pub materials_file: Option<MaterialsFile>,
}

/// A user's materials file as the page read it: its name (for messages and the listing's
/// origin) and its TOML text.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialsFile {
    /// The file's name (`materials.toml`).
    pub name: String,
    /// Its text, at most [`moldgate::files::MAX_MATERIALS_BYTES`].
    pub text: String,
}

impl MaterialsFile {
    /// The file's materials, each named by its table; an error names the file and the line.
    pub fn materials(&self) -> Result<Vec<moldgate::Material>, String> {
        // Its size is checked by the library's reader, before it parses.
        moldgate::material::materials_from_toml(&self.text)
            .map_err(|e| format!("{}: {e}", self.name))
    }
}

/// The mesh readers, chosen by the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// `.stl`, binary or ASCII.
    Stl,
    /// `.obj`.
    Obj,
    /// `.ply`, ASCII or binary.
    Ply,
}

impl Format {
    /// The format of `file_name` by its extension, in any case; `None` for any other.
    pub fn of(file_name: &str) -> Option<Format> {
        let ext = file_name.rsplit_once('.')?.1;
        [
            ("stl", Format::Stl),
            ("obj", Format::Obj),
            ("ply", Format::Ply),
        ]
        .into_iter()
        .find(|(e, _)| ext.eq_ignore_ascii_case(e))
        .map(|(_, f)| f)
    }
}

/// Which field colours the part in the GLB.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Colouring {
    /// What the study shows: the fill order when the fill ran, the height otherwise, and
    /// the gate-suitability map when it was made (the other colourings leave it out).
    Study,
    /// Height along the demolding direction.
    Height,
    /// Wall thickness (needs `wall_thickness`).
    WallThickness,
    /// The fill analysis's field (`color_by`: by default the fill order from the gate, as
    /// an estimated fill time; needs the fill analysis).
    FillOrder,
}

impl Colouring {
    /// The colouring numbered as the exports number it (0 study, 1 height, 2 wall, 3 fill).
    pub fn from_code(code: u32) -> Option<Colouring> {
        [
            Colouring::Study,
            Colouring::Height,
            Colouring::WallThickness,
            Colouring::FillOrder,
        ]
        .get(code as usize)
        .copied()
    }
}

/// Why a study was refused: the message, and whether the file itself is at fault (it cannot
/// be read as a mesh), which no option can mend.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// moldgate's message.
    pub message: String,
    /// True when the file could not be read.
    pub file: bool,
}

impl From<String> for Failure {
    fn from(message: String) -> Self {
        Failure {
            message,
            file: false,
        }
    }
}

impl std::ops::Deref for Failure {
    type Target = str;
    fn deref(&self) -> &str {
        &self.message
    }
}

impl PartialEq<&str> for Failure {
    fn eq(&self, other: &&str) -> bool {
        self.message == *other
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// A part and its study.
pub struct Session {
    part: LoadedMesh,
    study: Study,
    title: String,
}

/// Reads `bytes` as the format of `file_name`; every error names the file.
pub fn load(bytes: &[u8], file_name: &str, units: Units) -> Result<LoadedMesh, String> {
    let fail = |e: &dyn std::fmt::Display| format!("{file_name}: {e}");
    if bytes.len() > MAX_FILE_BYTES {
        return Err(fail(&format_args!(
            "{} bytes, over the limit of {MAX_FILE_BYTES} bytes the browser can study",
            bytes.len()
        )));
    }
    let format = Format::of(file_name).ok_or_else(|| {
        // A kind of file moldgate knows (STEP, IGES, 3MF, ...) is named with what to do.
        let head = &bytes[..bytes.len().min(1024)];
        match mesh::sniff::not_a_mesh(head, false) {
            Some(e) => fail(&e),
            None => {
                fail(&"unsupported file type: moldgate reads .stl (binary or ASCII), .obj and .ply")
            }
        }
    })?;
    match format {
        Format::Stl => mesh::read_stl(bytes, bytes.len() as u64, units),
        Format::Obj => mesh::read_obj(bytes, units),
        Format::Ply => mesh::read_ply(bytes, units),
    }
    .map_err(|e| fail(&e))
}

impl Session {
    /// The units and the validated settings of `request`: its options checked as a study
    /// checks them, without the file (the page asks before it lets the last results go).
    pub fn settings(request: &Request) -> Result<(Units, Settings), Failure> {
        let units: Units = match &request.units {
            Some(u) => u.parse().map_err(|e: String| format!("units: {e}"))?,
            None => Units::Mm,
        };
        let user = match &request.materials_file {
            Some(file) => file.materials()?,
            None => Vec::new(),
        };
        let settings = request
            .options
            .validate_with(&user)
            .map_err(|e| e.to_string())?;
        Ok((units, settings))
    }

    /// Reads the request's file from `bytes` (or makes its sample) and studies it,
    /// reporting progress through `progress`.
    pub fn new(
        bytes: &[u8],
        request: &Request,
        progress: &(dyn Fn(Progress) + Sync),
    ) -> Result<Session, Failure> {
        // Options first: a bad option is refused before the file is read.
        let (units, settings) = Session::settings(request)?;
        let start = Instant::now();
        let (part, input, title) = match &request.sample {
            Some(name) => {
                let mesh = moldgate::samples::sample(name).ok_or_else(|| {
                    let known: Vec<&str> =
                        moldgate::samples::SAMPLES.iter().map(|s| s.name).collect();
                    format!("unknown sample '{name}' (known: {})", known.join(", "))
                })?;
                let input = Input {
                    path: None,
                    sample: Some(name.clone()),
                    bytes: 0,
                };
                (
                    mesh::from_generated(mesh),
                    input,
                    format!("sample '{name}'"),
                )
            }
            None => {
                let part = load(bytes, &request.file_name, units).map_err(|message| Failure {
                    message,
                    file: true,
                })?;
                let input = Input {
                    path: Some(request.file_name.clone()),
                    sample: None,
                    bytes: bytes.len() as u64,
                };
                (part, input, request.file_name.clone())
            }
        };
        let load_s = start.elapsed().as_secs_f64();
        let hooks = Hooks {
            progress: Some(progress),
            cancel: None,
        };
        let mut study = moldgate::study_with(&part, &settings, &hooks).map_err(|e| {
            let name = input.path.as_ref().or(input.sample.as_ref());
            format!("{}: {e}", name.map_or("", String::as_str))
        })?;
        study.set_input(input, load_s);
        Ok(Session { part, study, title })
    }

    /// The study.
    pub fn study(&self) -> &Study {
        &self.study
    }

    /// The report as the command line's `locate --json` prints it.
    pub fn report_json(&self) -> Result<String, String> {
        self.study.report_json().map_err(|e| e.to_string())
    }

    /// The GLB of the study with the part coloured by `colouring`.
    pub fn glb(&self, colouring: Colouring) -> Result<Vec<u8>, String> {
        let scene = self.scene(colouring)?;
        moldgate::gltf::glb(&scene).map_err(|e| format!("cannot write the GLB: {e}"))
    }

    fn scene(&self, colouring: Colouring) -> Result<Scene<'_>, String> {
        let scene = self
            .study
            .scene(&self.part, self.title.clone())
            .map_err(|e| e.to_string())?;
        let field = match colouring {
            Colouring::Study => return Ok(scene),
            Colouring::Height => {
                let frame = self.study.analysis().frame;
                Field {
                    name: "height along D".into(),
                    unit: "mm".into(),
                    per_vertex: self
                        .part
                        .mesh
                        .vertices
                        .iter()
                        .map(|&p| frame.height(p) as f32)
                        .collect(),
                    cells: None,
                    span: None,
                }
            }
            Colouring::WallThickness => self
                .study
                .wall_field()
                .ok_or("the wall thickness was not measured (turn on 'wall thickness')")?,
            Colouring::FillOrder => self
                .study
                .fill_field()
                .ok_or("the fill was not analysed (turn on 'fill analysis')")?,
        };
        // The part in the chosen field alone: the suitability map's squares, coloured by
        // their own scale, belong to the study's own colouring, and one colour bar cannot
        // describe both.
        let mut scene = scene.with_field(field);
        scene.node_field = None;
        Ok(scene)
    }

    /// The 1600x900 PNG picture, the part coloured by `colouring` as the view shows it.
    pub fn png(&self, colouring: Colouring) -> Result<Vec<u8>, String> {
        let scene = self.scene(colouring)?;
        self.study.png_of(scene).map_err(|e| e.to_string())
    }

    /// The self-contained HTML report, with the picture coloured by `colouring`.
    pub fn html(&self, colouring: Colouring) -> Result<String, String> {
        let png = self.png(colouring)?;
        self.study.html(Some(&png)).map_err(|e| e.to_string())
    }
}

/// The built-in samples as JSON: `[{"name": ..., "description": ...}]`.
pub fn samples_json() -> String {
    let list: Vec<serde_json::Value> = moldgate::samples::SAMPLES
        .iter()
        .map(|s| serde_json::json!({ "name": s.name, "description": s.description }))
        .collect();
    serde_json::Value::Array(list).to_string()
}

/// The materials of the built-in library as JSON, each as `moldgate materials --json` lists
/// it (its parameters, Eq. 7-8, aliases, description and sources; the paper's Table 1
/// first).
pub fn materials_json() -> String {
    let listing = moldgate::material::Listing::builtin();
    serde_json::to_string(&listing.materials).unwrap_or_default()
}

/// [`materials_json`] with a user's materials file (`{"name": ..., "text": ...}`): each of
/// its materials replaces a built-in of the same name or alias, the others follow, as
/// `moldgate materials --materials-file FILE --json` lists them.
pub fn materials_with_json(file: &str) -> Result<String, String> {
    let file: MaterialsFile =
        serde_json::from_str(file).map_err(|e| format!("the materials file's request: {e}"))?;
    let listing = moldgate::material::Listing::new(file.materials()?, &file.name);
    serde_json::to_string(&listing.materials).map_err(|e| e.to_string())
}

/// The study's default options (the command line's) as JSON.
pub fn defaults_json() -> String {
    serde_json::to_string(&StudyOptions::default()).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quiet(_: Progress) {}

    fn request(json: &str) -> Request {
        serde_json::from_str(json).unwrap()
    }

    fn stl_of(sample: &str) -> Vec<u8> {
        let mut out = Vec::new();
        moldgate::samples::sample(sample)
            .unwrap()
            .write_stl(&mut out)
            .unwrap();
        out
    }

    #[test]
    fn options_are_checked_without_the_file_as_a_study_checks_them() {
        let good =
            request(r#"{ "file_name": "a.stl", "options": { "keep_out": ["sphere:0,0,0,1"] } }"#);
        assert!(Session::settings(&good).is_ok());
        let bad = request(r#"{ "file_name": "a.stl", "options": { "keep_out": ["cube:1,2,3"] } }"#);
        let said = Session::settings(&bad).err().unwrap().message;
        let studied = Session::new(&stl_of("plate"), &bad, &quiet)
            .err()
            .unwrap()
            .message;
        assert_eq!(said, studied);
        assert!(said.contains("cube:1,2,3"), "{said}");
    }

    #[test]
    fn format_by_extension_in_any_case() {
        assert_eq!(Format::of("a.STL"), Some(Format::Stl));
        assert_eq!(Format::of("a.b.Obj"), Some(Format::Obj));
        assert_eq!(Format::of("x.ply"), Some(Format::Ply));
        assert_eq!(Format::of("x.step"), None);
        assert_eq!(Format::of("stl"), None);
    }

    #[test]
    fn a_file_gives_the_same_report_as_the_library() {
        let bytes = stl_of("cover");
        let r = request(r#"{ "file_name": "cover.stl", "options": { "demold": "-z" } }"#);
        let s = Session::new(&bytes, &r, &quiet).unwrap();
        let part = mesh::read_stl(&bytes[..], bytes.len() as u64, Units::Mm).unwrap();
        let direct = moldgate::study(&part, &r.options).unwrap();
        assert_eq!(
            s.study().report().gate.as_ref().unwrap().point,
            direct.report().gate.as_ref().unwrap().point
        );
        let json: serde_json::Value = serde_json::from_str(&s.report_json().unwrap()).unwrap();
        assert_eq!(json["input"]["path"], "cover.stl");
        assert_eq!(json["input"]["bytes"], bytes.len());
    }

    #[test]
    fn bad_files_are_refused_with_their_name_and_place() {
        let r = |name: &str| request(&format!(r#"{{ "file_name": "{name}" }}"#));
        let e = Session::new(b"", &r("empty.stl"), &quiet).err().unwrap();
        assert_eq!(e, "empty.stl: empty file");
        assert!(e.file, "a file that cannot be read is the file's fault");
        let e = Session::new(b"v 0 0 0\nv 1 0 0\nf 1 2 x\n", &r("bad.obj"), &quiet)
            .err()
            .unwrap();
        assert!(e.starts_with("bad.obj: line 3"), "{e}");
        let e = Session::new(b"solid", &r("part.unknown"), &quiet)
            .err()
            .unwrap();
        assert!(e.contains("unsupported file type"), "{e}");
        // A STEP file is named as one, with what to do, as the command line does.
        let e = Session::new(b"ISO-10303-21;\nHEADER;\n", &r("part.step"), &quiet)
            .err()
            .unwrap();
        assert!(e.starts_with("part.step: this is a STEP file"), "{e}");
    }

    #[test]
    fn bad_options_are_refused_before_the_file_is_read() {
        let r = request(r#"{ "file_name": "x.stl", "options": { "gate_radius": 0 } }"#);
        let e = Session::new(b"", &r, &quiet).err().unwrap();
        assert!(e.starts_with("gate_radius must be a positive"), "{e}");
        let r = request(r#"{ "sample": "plate", "units": "furlong" }"#);
        assert!(Session::new(b"", &r, &quiet)
            .err()
            .unwrap()
            .contains("furlong"));
        assert!(serde_json::from_str::<Request>(r#"{ "colour": 1 }"#).is_err());
    }

    #[test]
    fn a_grid_too_large_is_refused_before_the_work() {
        let r = request(r#"{ "sample": "plate", "options": { "spacing": 0.001 } }"#);
        let e = Session::new(b"", &r, &quiet).err().unwrap();
        assert!(e.contains("max_nodes") || e.contains("nodes"), "{e}");
        assert!(!e.file, "an option can mend it");
    }

    #[test]
    fn every_colouring_or_a_reason() {
        let r = request(r#"{ "sample": "cover", "options": { "demold": "-z" } }"#);
        let s = Session::new(b"", &r, &quiet).unwrap();
        assert!(s.glb(Colouring::Height).unwrap().starts_with(b"glTF"));
        assert!(s.glb(Colouring::FillOrder).unwrap_err().contains("fill"));
        assert!(s
            .glb(Colouring::WallThickness)
            .unwrap_err()
            .contains("wall"));
        let r = request(
            r#"{ "sample": "cover", "options": { "demold": "-z", "fill": true, "wall_thickness": true } }"#,
        );
        let s = Session::new(b"", &r, &quiet).unwrap();
        for c in [Colouring::FillOrder, Colouring::WallThickness] {
            assert!(s.glb(c).unwrap().starts_with(b"glTF"));
        }
        assert!(s.png(Colouring::Study).unwrap().starts_with(b"\x89PNG"));
        assert!(s.html(Colouring::Study).unwrap().contains("<html"));
        // The picture is coloured as the view: the fill's field is the study's own
        // colouring, the height another picture.
        let study = s.png(Colouring::Study).unwrap();
        assert_eq!(s.png(Colouring::FillOrder).unwrap(), study);
        assert_ne!(s.png(Colouring::Height).unwrap(), study);
        assert_ne!(s.png(Colouring::WallThickness).unwrap(), study);
        let r = request(r#"{ "sample": "cover", "options": { "demold": "-z" } }"#);
        let s = Session::new(b"", &r, &quiet).unwrap();
        assert!(s.png(Colouring::FillOrder).unwrap_err().contains("fill"));
        assert!(s
            .html(Colouring::WallThickness)
            .unwrap_err()
            .contains("wall"));
    }

    #[test]
    fn the_suitability_map_goes_with_the_study_s_own_colouring_only() {
        // One colour bar per view: the map's squares and their scale with the study's
        // colouring, the chosen field alone with any other.
        let r =
            request(r#"{ "sample": "cover", "options": { "demold": "-z", "suitability": true } }"#);
        let s = Session::new(b"", &r, &quiet).unwrap();
        let extras = |c: Colouring| {
            let glb = s.glb(c).unwrap();
            let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
            let doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
            doc["asset"]["extras"].clone()
        };
        assert!(extras(Colouring::Study)["suitability"].is_object());
        let height = extras(Colouring::Height);
        assert!(height["suitability"].is_null(), "{height}");
        assert_eq!(height["field"]["name"], "height along D");
    }

    #[test]
    fn a_materials_file_gives_its_materials_to_the_study_and_the_listing() {
        // A material of the file's own, and one that replaces a built-in by its alias.
        let text = "[MyPP]\nn = 0.3\nt_melt = 230\nt_wall = 50\ngamma_opt = 10000\nmu_opt = 9.88\nk = 0.15\n\n[HDPE]\nn = 0.4\nt_melt = 220\nt_wall = 40\ngamma_opt = 1000\nmu_opt = 300\nk = 0.4\n";
        let file = serde_json::json!({ "name": "mine.toml", "text": text });
        let r = serde_json::json!({ "sample": "plate", "options": { "material": "MyPP" }, "materials_file": file });
        let s = Session::new(b"", &serde_json::from_value(r).unwrap(), &quiet).unwrap();
        let mine = MaterialsFile {
            name: "mine.toml".into(),
            text: text.into(),
        }
        .materials()
        .unwrap();
        let radius_of = |name: &str| {
            let m = mine.iter().find(|m| m.name == name).unwrap();
            m.gate_radius_mm()
        };
        let radius = s.study().analysis().options.gate_radius_mm;
        assert_eq!(radius, radius_of("MyPP"));
        // The built-in name of the replaced material takes the file's.
        let r = serde_json::json!({ "sample": "plate", "options": { "material": "PE-HD" }, "materials_file": file });
        let s = Session::new(b"", &serde_json::from_value(r).unwrap(), &quiet).unwrap();
        assert_eq!(
            s.study().analysis().options.gate_radius_mm,
            radius_of("HDPE")
        );
        // Without the file, the name is unknown.
        let r = request(r#"{ "sample": "plate", "options": { "material": "MyPP" } }"#);
        let e = Session::new(b"", &r, &quiet).err().unwrap();
        assert!(e.message.contains("MyPP"), "{e}");
        // The listing: the built-in library with PE-HD replaced, then the file's own.
        let listed: serde_json::Value =
            serde_json::from_str(&materials_with_json(&file.to_string()).unwrap()).unwrap();
        let listed = listed.as_array().unwrap();
        assert_eq!(listed.len(), moldgate::material::library().len() + 1);
        let hdpe = listed.iter().find(|m| m["name"] == "HDPE").unwrap();
        assert_eq!(hdpe["origin"], "mine.toml");
        assert!(listed.iter().all(|m| m["name"] != "PE-HD"));
        assert_eq!(listed.last().unwrap()["name"], "MyPP");
        // A bad file is refused with its name and line, for the study and the listing alike.
        let bad = serde_json::json!({ "name": "bad.toml", "text": "[X]\nn = 0.3\nk = hot\n" });
        let e = materials_with_json(&bad.to_string()).unwrap_err();
        assert!(e.starts_with("bad.toml: line 3: "), "{e}");
        let r = serde_json::json!({ "sample": "plate", "materials_file": bad });
        let e = Session::new(b"", &serde_json::from_value(r).unwrap(), &quiet)
            .err()
            .unwrap();
        assert!(e.message.starts_with("bad.toml: line 3: "), "{e}");
        assert!(!e.file);
    }

    #[test]
    fn progress_reaches_the_end() {
        let seen = std::sync::Mutex::new(Vec::new());
        let record = |p: Progress| seen.lock().unwrap().push(p.fraction);
        let r = request(r#"{ "sample": "plate", "options": { "fill": true } }"#);
        Session::new(b"", &r, &record).unwrap();
        assert_eq!(seen.lock().unwrap().last(), Some(&1.0));
    }

    #[test]
    fn lists_parse() {
        let s: serde_json::Value = serde_json::from_str(&samples_json()).unwrap();
        assert_eq!(
            s.as_array().unwrap().len(),
            moldgate::samples::SAMPLES.len()
        );
        let m: serde_json::Value = serde_json::from_str(&materials_json()).unwrap();
        assert_eq!(m[0]["name"], "PP");
        assert!(m[0]["gate_radius_mm"].as_f64().unwrap() > 0.0);
        assert_eq!(
            m.as_array().unwrap().len(),
            moldgate::material::library().len()
        );
        let d: StudyOptions = serde_json::from_str(&defaults_json()).unwrap();
        assert_eq!(d, StudyOptions::default());
    }

    #[test]
    fn the_page_offers_the_library_s_limit_of_gates() {
        // The number field's own maximum, so that the page never offers a count the
        // library refuses.
        let page = include_str!("../../../web/index.html");
        let field = page
            .lines()
            .find(|l| l.contains("id=\"gates\""))
            .expect("the gates field");
        let max = moldgate::flow::FlowOptions::default().max_gates;
        assert!(field.contains(&format!("max=\"{max}\"")), "{field}");
    }
}
