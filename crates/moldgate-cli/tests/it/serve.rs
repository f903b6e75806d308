//! `moldgate serve` end to end over 127.0.0.1 with the real binary: every endpoint, the
//! report against `locate --json`, the picture, the GLB, and every kind of bad input and
//! fault, each followed by a check that the server still serves.

use std::io::{BufReader, Write};
use std::net::SocketAddr;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::common::http::{self, connect, get, head, read_response, request, study_stl, Server};
use crate::common::{self, moldgate};
use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_moldgate");

fn start(args: &[&str]) -> Server {
    Server::start(BIN, args)
}

/// A built-in sample as binary STL, written by `moldgate sample`.
fn sample_stl(name: &str) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let out = moldgate(dir.path(), &["sample", name, "-o", "part.stl"]);
    assert!(out.status.success());
    std::fs::read(dir.path().join("part.stl")).unwrap()
}

/// The server's log line that holds `needle` (a study's end), or a panic with the log.
fn log_line(s: &Server, needle: &str) -> String {
    let log = s.log_text();
    log.lines()
        .find(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("no line with '{needle}' in\n{log}"))
        .to_string()
}

fn assert_alive(addr: SocketAddr) {
    let r = get(addr, "/healthz");
    assert_eq!(r.status, 200);
    assert_eq!(r.json()["status"], "ok");
}

/// The answer has the status and error kind; never a 500; the server still serves.
fn assert_error(server: &Server, r: &http::Response, status: u16, kind: &str) -> Value {
    assert_eq!(
        (r.status, r.kind().as_str()),
        (status, kind),
        "{}",
        String::from_utf8_lossy(&r.body)
    );
    assert_eq!(r.header("content-type"), Some("application/json"));
    assert_alive(server.addr);
    r.json()["error"].clone()
}

/// A report without what depends on the run (timings) and on where the part came from.
fn comparable(mut v: Value) -> Value {
    v.as_object_mut().unwrap().remove("timings");
    v.as_object_mut().unwrap().remove("input");
    if let Some(fill) = v.get_mut("fill").and_then(Value::as_object_mut) {
        fill.remove("times");
        // The fill's flow-cell walls are reported with --wall-thickness too (read from its
        // every-facet walls), with the time it took.
        if let Some(wall) = fill.get_mut("wall").and_then(Value::as_object_mut) {
            wall.remove("time_s");
        }
    }
    if let Some(wall) = v.get_mut("wall_thickness").and_then(Value::as_object_mut) {
        wall.remove("time_s");
    }
    v
}

#[test]
fn small_endpoints_answer_json_with_isolation_headers() {
    let s = start(&[]);
    let h = get(s.addr, "/healthz");
    assert_eq!(h.status, 200);
    assert_eq!(h.json()["running"], 0);
    assert_eq!(h.header("cross-origin-opener-policy"), Some("same-origin"));
    assert_eq!(
        h.header("cross-origin-embedder-policy"),
        Some("require-corp")
    );

    let m = get(s.addr, "/v1/materials").json();
    let names: Vec<&str> = m["materials"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    // The whole library a study takes, the paper's Table 1 first.
    assert_eq!(names.len(), moldgate::material::library().len());
    assert_eq!(names[..3], ["PP", "ABS", "PC"]);
    // Table 1's radius of PP.
    let pp = m["materials"][0]["gate_radius_mm"].as_f64().unwrap();
    assert!((pp - 1.4254).abs() < 1e-3, "{pp}");

    let list = get(s.addr, "/v1/samples").json();
    assert_eq!(list["samples"].as_array().unwrap().len(), 5);
    assert_eq!(list["samples"][1]["href"], "/v1/samples/cover");
    let stl = get(s.addr, "/v1/samples/cover");
    assert_eq!(stl.status, 200);
    assert_eq!(stl.header("content-type"), Some("model/stl"));
    assert_eq!(stl.body, sample_stl("cover"));
    assert_error(&s, &get(s.addr, "/v1/samples/nope"), 404, "not_found");
    // A name that is no UTF-8 text: JSON too (it was axum's plain-text 400).
    let e = assert_error(&s, &get(s.addr, "/v1/samples/%FF"), 404, "not_found");
    assert_eq!(e["where"], "name", "{e}");

    let doc = get(s.addr, "/v1/openapi.json").json();
    assert_eq!(doc["openapi"], "3.1.0");
    assert_error(&s, &get(s.addr, "/nowhere"), 404, "not_found");
    assert_error(&s, &get(s.addr, "/v1/study"), 405, "method");
    // One log line per request: method, path, status, bytes in and out, time.
    let log = s.log_text();
    assert!(log.contains("GET /v1/samples/cover 200 in=0 out="), "{log}");
    assert!(log.contains("ms"), "{log}");
}

#[test]
fn report_is_the_command_lines_for_the_same_part_and_options() {
    let s = start(&[]);
    let dir = tempfile::tempdir().unwrap();
    let stl = sample_stl("cover");
    std::fs::write(dir.path().join("cover.stl"), &stl).unwrap();
    let cases: [(&str, &[&str]); 4] = [
        ("", &[]),
        (
            "material=ABS&demold=%2Bz&keep_out=box:-70,-50,-5,0,50,40&keep_out=sphere:30,0,5,4",
            &[
                "--material",
                "ABS",
                "--demold",
                "+z",
                "--keep-out",
                "box:-70,-50,-5,0,50,40",
                "--keep-out",
                "sphere:30,0,5,4",
            ],
        ),
        (
            "fill=true&gate_radius=1.2&wall_thickness=true",
            &["--fill", "--gate-radius", "1.2", "--wall-thickness"],
        ),
        // Warnings that advise flags: the service names its query's keywords instead.
        ("fill=true&demold=auto", &["--fill", "--demold", "auto"]),
    ];
    // The command line's sentences in the service's words, the rest as it is (the cases
    // here have warnings and no gate reasons; `radius_fit` and placed gates, whose
    // sentences the service converts too, do not occur in them).
    let in_keywords = |mut v: Value| {
        let words = |w: &mut Value| {
            if let Some(text) = w.as_str() {
                *w = Value::from(moldgate::study::keyword_words(text, "true"));
            }
        };
        // (`get_mut`, not indexing, which would make a null `fill` an object.)
        for path in ["/warnings", "/fill/warnings"] {
            if let Some(list) = v.pointer_mut(path).and_then(Value::as_array_mut) {
                list.iter_mut().for_each(words);
            }
        }
        if let Some(reason) = v.get_mut("no_gate_reason") {
            words(reason);
        }
        v
    };
    for (query, flags) in cases {
        let r = study_stl(s.addr, query, &stl);
        assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
        assert_eq!(r.header("content-type"), Some("application/json"));
        let service = r.json();
        assert_eq!(service["input"]["bytes"], stl.len());
        let mut args = vec!["locate", "cover.stl", "--json"];
        args.extend_from_slice(flags);
        let out = moldgate(dir.path(), &args);
        assert!(out.status.success(), "{}", common::stderr(&out));
        let cli: Value = serde_json::from_slice(&out.stdout).unwrap();
        if query.contains("auto") {
            let said = service["warnings"].to_string();
            assert!(said.contains("require_flat=true"), "{said}");
            assert!(!said.contains("--"), "{said}");
            assert!(cli["warnings"].to_string().contains("--require-flat"));
        }
        assert_eq!(
            comparable(service),
            comparable(in_keywords(cli)),
            "options {query:?}"
        );
    }
}

#[test]
fn multipart_options_and_formats_give_the_same_report() {
    let s = start(&[]);
    let stl = sample_stl("plate");
    let by_query = study_stl(s.addr, "material=PC&circle_points=12", &stl);
    assert_eq!(by_query.status, 200);
    // A material parameter at fault is named as its query parameter, not as `material`.
    let bad = study_stl(s.addr, "material=PC&n=0", &stl);
    let e = assert_error(&s, &bad, 400, "options");
    assert_eq!(e["where"], "n", "{e}");
    // Out of range, as well as not positive (it was `material`).
    let bad = study_stl(s.addr, "material=PC&n=2", &stl);
    let e = assert_error(&s, &bad, 400, "options");
    assert_eq!(e["where"], "n", "{e}");
    let b = "moldgateboundary";
    let mut body = format!(
        "--{b}\r\ncontent-disposition: form-data; name=\"options\"\r\ncontent-type: application/json\r\n\r\n{{\"material\": \"PC\", \"circle_points\": 12}}\r\n--{b}\r\ncontent-disposition: form-data; name=\"mesh\"; filename=\"plate.stl\"\r\ncontent-type: application/octet-stream\r\n\r\n"
    )
    .into_bytes();
    body.extend_from_slice(&stl);
    body.extend_from_slice(format!("\r\n--{b}--\r\n").as_bytes());
    let ct = format!("multipart/form-data; boundary={b}");
    let by_part = request(s.addr, "POST", "/v1/study", &[("content-type", &ct)], &body);
    assert_eq!(
        by_part.status,
        200,
        "{}",
        String::from_utf8_lossy(&by_part.body)
    );
    assert_eq!(comparable(by_query.json()), comparable(by_part.json()));
    // The same option in both places is refused.
    let both = request(
        s.addr,
        "POST",
        "/v1/study?material=PP",
        &[("content-type", &ct)],
        &body,
    );
    assert_eq!(assert_error(&s, &both, 400, "options")["where"], "material");
    // The body with `first` put at the start of its options object, and its error.
    let at = body.windows(6).position(|w| w == b"{\"mate").unwrap();
    let refused = |first: &[u8]| {
        let sent = [&body[..at], b"{", first, &body[at + 1..]].concat();
        let r = request(s.addr, "POST", "/v1/study", &[("content-type", &ct)], &sent);
        assert_error(&s, &r, 400, "options")
    };
    // An option given twice in the options part: refused, not the last one taken.
    let e = refused(b"\"material\": \"ABS\", ");
    assert!(
        e["message"]
            .as_str()
            .unwrap()
            .contains("the option 'material' is given more than once"),
        "{e}"
    );
    // The request's own parameters in the options part: refused, saying where they go.
    let e = refused(b"\"units\": \"in\", ");
    assert_eq!(e["where"], "units", "{e}");
    assert!(
        e["message"]
            .as_str()
            .unwrap()
            .starts_with("units is a parameter of the request's query (POST /v1/study?units=...)"),
        "{e}"
    );
    // A number beyond a double is said not finite, as in the query form.
    let e = refused(b"\"cell\": 1e400, ");
    assert!(
        e["message"]
            .as_str()
            .unwrap()
            .contains("a number too large to be finite (beyond 1.8e308)"),
        "{e}"
    );
    // A multipart body without its boundary cannot be read: 400, not a format's 415.
    let unbounded = request(
        s.addr,
        "POST",
        "/v1/study",
        &[("content-type", "multipart/form-data")],
        &body,
    );
    let e = assert_error(&s, &unbounded, 400, "body");
    assert_eq!(e["where"], "Content-Type", "{e}");
    // Two mesh parts, or two options parts: refused, not the last one studied. The body
    // above less its closing line, one more part, and the closing line.
    let closing = format!("\r\n--{b}--\r\n");
    for (head, content) in [
        ("name=\"mesh\"; filename=\"plate.stl\"", &stl[..]),
        ("name=\"options\"", &b"{}"[..]),
    ] {
        let mut twice = body[..body.len() - closing.len()].to_vec();
        twice.extend_from_slice(
            format!("\r\n--{b}\r\ncontent-disposition: form-data; {head}\r\n\r\n").as_bytes(),
        );
        twice.extend_from_slice(content);
        twice.extend_from_slice(closing.as_bytes());
        let r = request(
            s.addr,
            "POST",
            "/v1/study",
            &[("content-type", &ct)],
            &twice,
        );
        let e = assert_error(&s, &r, 400, "body");
        assert!(
            e["message"].as_str().unwrap().contains("more than once"),
            "{e}"
        );
    }
    // application/octet-stream with format=, and the format parameter over the type.
    let octet = request(
        s.addr,
        "POST",
        "/v1/study?format=stl&material=PC&circle_points=12",
        &[("content-type", "application/octet-stream")],
        &stl,
    );
    assert_eq!(comparable(octet.json()), comparable(by_query.json()));
}

#[test]
fn obj_and_ply_bodies_are_read_by_their_content_type() {
    let s = start(&[]);
    let obj = b"v 0 0 0\nv 10 0 0\nv 10 10 0\nv 0 10 0\nv 0 0 10\nv 10 0 10\nv 10 10 10\nv 0 10 10\nf 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
    let r = request(
        s.addr,
        "POST",
        "/v1/study",
        &[("content-type", "model/obj")],
        obj,
    );
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    assert_eq!(r.json()["mesh"]["triangles"], 12);
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n10 0 0\n0 10 0\n0 0 10\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n";
    let r = request(
        s.addr,
        "POST",
        "/v1/study?gate_radius=0.5",
        &[("content-type", "application/x-ply")],
        ply.as_bytes(),
    );
    assert!(r.status == 200 || r.status == 422, "{}", r.status);
    assert_eq!(r.header("content-type"), Some("application/json"));
    let bad = request(
        s.addr,
        "POST",
        "/v1/study",
        &[("content-type", "model/obj")],
        b"v 0 0 0\nv 1 0\nf 1 2 3\n",
    );
    assert_eq!(assert_error(&s, &bad, 422, "mesh")["where"], "line 2");
    // A coordinate beyond the limit is placed as a NaN one is.
    let far = request(
        s.addr,
        "POST",
        "/v1/study",
        &[("content-type", "model/obj")],
        b"v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    assert_eq!(assert_error(&s, &far, 422, "mesh")["where"], "line 2");
}

#[test]
fn png_decodes_and_html_holds_it() {
    let s = start(&[]);
    let stl = sample_stl("tray");
    let r = study_stl(s.addr, "output=png", &stl);
    assert_eq!(r.status, 200);
    assert_eq!(r.header("content-type"), Some("image/png"));
    let decoder = png::Decoder::new(std::io::Cursor::new(r.body.clone()));
    let reader = decoder.read_info().expect("a PNG");
    assert_eq!((reader.info().width, reader.info().height), (1600, 900));
    let page = study_stl(s.addr, "output=html", &stl);
    assert_eq!(
        page.header("content-type"),
        Some("text/html; charset=utf-8")
    );
    let text = String::from_utf8(page.body).unwrap();
    assert!(text.starts_with("<!DOCTYPE html>") || text.starts_with("<!doctype html>"));
    assert!(text.contains("data:image/png;base64,"));
    let e = study_stl(s.addr, "output=svg", &stl);
    assert_eq!(assert_error(&s, &e, 400, "options")["where"], "output");
}

#[test]
fn glb_is_valid_for_the_khronos_validator() {
    let s = start(&[]);
    let r = study_stl(s.addr, "output=glb&fill=true", &sample_stl("cover"));
    assert_eq!(r.status, 200);
    assert_eq!(r.header("content-type"), Some("model/gltf-binary"));
    assert_eq!(&r.body[..4], b"glTF");
    let tool = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/gltf-validator");
    let installed = tool
        .join("node_modules/gltf-validator/package.json")
        .is_file()
        && std::process::Command::new("node")
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success());
    if !installed {
        assert!(
            std::env::var_os("MOLDGATE_REQUIRE_GLTF_VALIDATOR").is_none(),
            "the glTF validator is required but not installed"
        );
        eprintln!("skipped the Khronos validator: node or tools/gltf-validator is not installed");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("study.glb");
    std::fs::write(&file, &r.body).unwrap();
    let out = std::process::Command::new("node")
        .arg(tool.join("validate.js"))
        .arg(&file)
        .output()
        .unwrap();
    let report: Value = serde_json::from_slice(&out.stdout).expect("the validator's JSON");
    assert_eq!(report["issues"]["numErrors"], 0, "{report}");
    assert!(out.status.success());
}

#[test]
fn bad_options_are_400_with_the_librarys_message() {
    let s = start(&[]);
    let stl = sample_stl("plate");
    let cases = [
        ("colour=red", "colour", "unknown field `colour`"),
        (
            "gates=abc",
            "gates",
            "got the text \"abc\", expected a whole number of 1 or more",
        ),
        // A count in a double's notation, or beyond one.
        (
            "gates=1e23",
            "gates",
            "got the decimal number 1e+23, expected a whole number of 1 or more",
        ),
        ("fill=maybe", "fill", "expected a boolean"),
        (
            "circle_points=2.5",
            "circle_points",
            "expected a whole number of 3 or more",
        ),
        ("demold=0,0,0", "demold", "non-zero finite vector"),
        ("gates=0", "gates", "must be at least 1"),
        (
            "material=NoSuchResin",
            "material",
            "unknown material 'NoSuchResin'",
        ),
        (
            "max_nodes=5000000",
            "max_nodes",
            "at most 4000000 on this server",
        ),
        ("keep_out=cube:1,2,3", "keep_out", "keep_out"),
        ("gates=2&gates=3", "gates", "more than once"),
        ("units=furlong", "units", "units"),
        // The library's limits name the option they are about.
        (
            "circle_points=100000",
            "circle_points",
            "circle points must be at most",
        ),
        (
            "spacing=0.0001",
            "spacing",
            "a spacing of 0.0001 mm gives a grid",
        ),
        // Advice names the query's parameters, not the command line's flags.
        (
            "spacing=0.0001",
            "spacing",
            "raise the node limit (max_nodes)",
        ),
        ("flat_tol=-1", "flat_tol", "flat"),
        // The fill's cell, too small for its limits or too large for the part.
        (
            "fill=true&cell=0.001",
            "cell",
            "choose a cell of at least",
        ),
        (
            "fill=true&cell=1e300",
            "cell",
            "a cell of 1.000e300 mm is larger than",
        ),
        // A parameter without a name, and text that is not UTF-8.
        ("=1", "query", "a query parameter has no name (before '=1')"),
        (
            "material=%FF%FE",
            "material",
            "the value of material is not UTF-8 text (its percent-encoded bytes make no characters: '%FF%FE')",
        ),
        ("%FF=1", "query", "the query parameter name '%FF' is not UTF-8 text"),
    ];
    for (query, place, needle) in cases {
        let r = study_stl(s.addr, query, &stl);
        let e = assert_error(&s, &r, 400, "options");
        assert_eq!(e["where"], place, "{query}: {e}");
        assert!(
            e["message"].as_str().unwrap().contains(needle),
            "{query}: {e}"
        );
        // Only the server's own setting is named as its flag, for its operator.
        let message = e["message"]
            .as_str()
            .unwrap()
            .replace("moldgate serve --max-nodes", "");
        assert!(!message.contains("--"), "{query}: {e}");
    }
}

#[test]
fn keep_outs_that_forbid_everything_are_422_with_the_reason_and_the_report() {
    let s = start(&[]);
    let r = study_stl(
        s.addr,
        "keep_out=box:-1000,-1000,-1000,1000,1000,1000",
        &sample_stl("plate"),
    );
    let e = assert_error(&s, &r, 422, "no_gate");
    let message = e["message"].as_str().unwrap();
    assert!(message.contains("kept out"), "{e}");
    // The reason once, as the report gives it.
    assert_eq!(message, r.json()["report"]["no_gate_reason"], "{e}");
    assert!(r.json()["report"]["counts"].is_object());
}

#[test]
fn unknown_formats_are_415() {
    let s = start(&[]);
    let stl = sample_stl("plate");
    for headers in [
        vec![],
        vec![("content-type", "text/csv")],
        vec![("content-type", "application/octet-stream")],
    ] {
        let r = request(s.addr, "POST", "/v1/study", &headers, &stl);
        assert_error(&s, &r, 415, "format");
    }
    let r = request(s.addr, "POST", "/v1/study?format=step", &[], &stl);
    assert_eq!(assert_error(&s, &r, 415, "format")["where"], "format");
}

#[test]
fn malformed_meshes_are_422_with_their_place() {
    let s = start(&[]);
    let stl = sample_stl("plate");
    // Truncated binary STL: cut inside a triangle.
    let r = study_stl(s.addr, "", &stl[..stl.len() - 30]);
    let e = assert_error(&s, &r, 422, "mesh");
    assert!(e["where"].as_str().unwrap().starts_with("byte "), "{e}");
    let r = study_stl(s.addr, "", &stl[..40]);
    assert_error(&s, &r, 422, "mesh");
    let r = study_stl(
        s.addr,
        "",
        b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nope\n",
    );
    assert_eq!(assert_error(&s, &r, 422, "mesh")["where"], "line 4");
    let r = study_stl(s.addr, "", b"");
    assert_error(&s, &r, 422, "mesh");
    // An OBJ sent as STL is named, with the request's way to say OBJ (no file name here).
    let obj = b"# a part\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".repeat(6);
    let e = assert_error(&s, &study_stl(s.addr, "", &obj), 422, "mesh");
    assert!(
        e["message"]
            .as_str()
            .unwrap()
            .ends_with("not an STL: send it as model/obj, or give format=obj"),
        "{e}"
    );
    // A mesh with no place to name (another kind of file) is the body's fault.
    assert_eq!(e["where"], "body", "{e}");
    let gzip = b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03".repeat(20);
    let e = assert_error(&s, &study_stl(s.addr, "", &gzip), 422, "mesh");
    assert_eq!(e["where"], "body", "{e}");
}

#[test]
fn seeded_corruptions_never_give_a_500() {
    let s = start(&[]);
    let stl = sample_stl("cap");
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for case in 0..40 {
        let mut body = stl.clone();
        let cut = (next() as usize) % body.len();
        match case % 4 {
            0 => body.truncate(cut),
            1 => body[cut] ^= 1 << (next() % 8),
            2 => body[80..84].copy_from_slice(&(next() as u32).to_le_bytes()),
            _ => {
                for _ in 0..32 {
                    let i = (next() as usize) % body.len();
                    body[i] = next() as u8;
                }
            }
        }
        let r = study_stl(s.addr, "", &body);
        // 400: a corrupted coordinate can make the part too large for the grid limit.
        assert!(
            [200, 400, 422].contains(&r.status),
            "case {case}: {} {}",
            r.status,
            String::from_utf8_lossy(&r.body)
        );
    }
    assert_alive(s.addr);
    assert!(!s.log_text().contains("internal error"), "{}", s.log_text());
}

#[test]
fn oversized_content_length_is_413_before_the_body_is_sent() {
    let s = start(&["--max-upload", "1"]);
    let mut c = connect(s.addr);
    // Only the head: the answer must come without a byte of the body.
    c.write_all(
        head(
            "POST",
            "/v1/study",
            &[("content-type", "model/stl")],
            Some(1 << 40),
        )
        .as_bytes(),
    )
    .unwrap();
    let r = read_response(&mut BufReader::new(c)).unwrap();
    assert_eq!(
        assert_error(&s, &r, 413, "too_large")["where"],
        "Content-Length"
    );
    // A chunked body is cut at the limit as it streams.
    let mut c = connect(s.addr);
    let mut req = "POST /v1/study HTTP/1.1\r\nhost: x\r\ncontent-type: model/stl\r\ntransfer-encoding: chunked\r\n\r\n".to_string();
    let chunk = "a".repeat(1 << 16);
    for _ in 0..20 {
        req += &format!("{:x}\r\n{chunk}\r\n", chunk.len());
    }
    let _ = c.write_all(req.as_bytes());
    let r = read_response(&mut BufReader::new(c)).unwrap();
    assert_eq!(assert_error(&s, &r, 413, "too_large")["where"], "body");
}

#[test]
fn lying_content_lengths() {
    let s = start(&["--read-timeout", "5"]);
    let stl = sample_stl("plate");
    // Shorter than the body: the mesh read is cut, a malformed mesh.
    let mut c = connect(s.addr);
    c.write_all(
        head(
            "POST",
            "/v1/study",
            &[("content-type", "model/stl"), ("connection", "close")],
            Some(stl.len() - 100),
        )
        .as_bytes(),
    )
    .unwrap();
    c.write_all(&stl).unwrap();
    let r = read_response(&mut BufReader::new(c)).unwrap();
    assert_error(&s, &r, 422, "mesh");
    // Longer than the body, then the client stops sending: the body cannot be read.
    let mut c = connect(s.addr);
    c.write_all(
        head(
            "POST",
            "/v1/study",
            &[("content-type", "model/stl")],
            Some(stl.len() + 1000),
        )
        .as_bytes(),
    )
    .unwrap();
    c.write_all(&stl).unwrap();
    c.shutdown(std::net::Shutdown::Write).unwrap();
    let r = read_response(&mut BufReader::new(c)).unwrap();
    assert_error(&s, &r, 400, "body");
    // A Content-Length that is not a number is refused by the HTTP layer or by us, never 500.
    let mut c = connect(s.addr);
    c.write_all(b"POST /v1/study HTTP/1.1\r\nhost: x\r\ncontent-length: lots\r\n\r\n")
        .unwrap();
    let r = read_response(&mut BufReader::new(c)).unwrap();
    assert_eq!(r.status, 400);
    assert_alive(s.addr);
}

#[test]
fn a_client_that_disconnects_mid_upload_leaves_the_server_serving() {
    let s = start(&[]);
    let stl = sample_stl("cover");
    for _ in 0..5 {
        let mut c = connect(s.addr);
        c.write_all(
            head(
                "POST",
                "/v1/study",
                &[("content-type", "model/stl")],
                Some(stl.len()),
            )
            .as_bytes(),
        )
        .unwrap();
        c.write_all(&stl[..stl.len() / 2]).unwrap();
        drop(c);
    }
    // The log shows each as a body that could not be read, and the slots are free again.
    let t = Instant::now();
    while s.log_text().matches("POST /v1/study 400").count() < 5 && t.elapsed().as_secs() < 10 {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(
        s.log_text().matches("POST /v1/study 400").count(),
        5,
        "{}",
        s.log_text()
    );
    assert_alive(s.addr);
    assert_eq!(get(s.addr, "/healthz").json()["running"], 0);
    assert_eq!(study_stl(s.addr, "", &stl).status, 200);
}

#[test]
fn a_slow_client_gets_408() {
    let s = start(&["--read-timeout", "2"]);
    let mut c = connect(s.addr);
    c.write_all(
        head(
            "POST",
            "/v1/study",
            &[("content-type", "model/stl")],
            Some(1000),
        )
        .as_bytes(),
    )
    .unwrap();
    // A byte a second: the body cannot arrive within the limit.
    let t = Instant::now();
    let mut out = c.try_clone().unwrap();
    let writer = std::thread::spawn(move || {
        for _ in 0..4 {
            if out.write_all(b"s").is_err() {
                break;
            }
            std::thread::sleep(Duration::from_secs(1));
        }
    });
    let r = read_response(&mut BufReader::new(c)).unwrap();
    let elapsed = t.elapsed();
    assert_error(&s, &r, 408, "body_timeout");
    assert!(elapsed < Duration::from_secs(4), "{elapsed:?}");
    writer.join().unwrap();
}

/// What a client that has sent part of a request head reads: the seconds until the server
/// closed the connection, and the bytes it answered before (none when cut off silently).
fn wait_for_close(c: &mut std::net::TcpStream, limit: Duration) -> (Duration, Vec<u8>) {
    use std::io::Read;
    let t = Instant::now();
    c.set_read_timeout(Some(limit)).unwrap();
    let mut got = Vec::new();
    let mut buf = [0u8; 512];
    loop {
        match c.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => break,
            Err(e) => panic!(
                "the connection was not closed within {limit:?} ({e}); read {:?}",
                String::from_utf8_lossy(&got)
            ),
        }
    }
    (t.elapsed(), got)
}

#[test]
fn a_client_sending_its_head_a_byte_a_second_is_cut_off_while_others_are_served() {
    let s = start(&["--header-timeout", "3"]);
    let stl = sample_stl("cover");
    let mut slow = connect(s.addr);
    let mut idle = connect(s.addr);
    let mut out = slow.try_clone().unwrap();
    let writer = std::thread::spawn(move || {
        let head = head("GET", "/healthz", &[], None);
        let mut sent = 0;
        for b in head.as_bytes() {
            if out.write_all(&[*b]).is_err() {
                break;
            }
            sent += 1;
            std::thread::sleep(Duration::from_secs(1));
        }
        sent
    });
    // Meanwhile the others are served, without waiting for the slow one's limit.
    let t = Instant::now();
    for _ in 0..3 {
        assert_alive(s.addr);
        assert_eq!(study_stl(s.addr, "", &stl).status, 200);
    }
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
    // The slow one, and one that sends nothing, are closed at the limit without an answer.
    for c in [&mut slow, &mut idle] {
        let (after, answer) = wait_for_close(c, Duration::from_secs(10));
        assert!(answer.is_empty(), "{}", String::from_utf8_lossy(&answer));
        assert!(
            after < Duration::from_secs(6),
            "closed after {after:?} (limit 3 s)"
        );
    }
    let sent = writer.join().unwrap();
    assert!(
        (1..=6).contains(&sent),
        "{sent} bytes sent before the close"
    );
    let t = Instant::now();
    while s.log_text().matches("did not arrive within 3 s").count() < 2 && t.elapsed().as_secs() < 5
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(
        s.log_text()
            .matches("did not arrive within 3 s (--header-timeout)")
            .count(),
        2,
        "{}",
        s.log_text()
    );
    assert_alive(s.addr);
}

#[test]
fn a_head_over_64_kib_is_431() {
    // The documented limit.
    assert_eq!(moldgate_serve::MAX_HEAD_BYTES, 64 << 10);
    let s = start(&[]);
    let big = "a".repeat(moldgate_serve::MAX_HEAD_BYTES + 1);
    let mut c = connect(s.addr);
    c.write_all(head("GET", "/healthz", &[("x-big", &big)], None).as_bytes())
        .unwrap();
    let r = read_response(&mut BufReader::new(c)).unwrap();
    assert_eq!(r.status, 431);
    // Just under the limit is read.
    let fits = "a".repeat(moldgate_serve::MAX_HEAD_BYTES - 200);
    let r = request(s.addr, "GET", "/healthz", &[("x-big", &fits)], &[]);
    assert_eq!(r.status, 200);
}

#[test]
fn connections_over_the_bound_wait_until_one_closes() {
    let s = start(&["--connections", "2", "--header-timeout", "3"]);
    let request = |c: &mut std::net::TcpStream| {
        c.write_all(head("GET", "/healthz", &[("connection", "close")], None).as_bytes())
            .unwrap();
    };
    // Two idle connections hold both slots: a third is connected by the kernel but not
    // answered.
    let held: Vec<_> = (0..2).map(|_| connect(s.addr)).collect();
    std::thread::sleep(Duration::from_millis(300));
    let mut third = connect(s.addr);
    request(&mut third);
    third
        .set_read_timeout(Some(Duration::from_secs(1)))
        .unwrap();
    let mut reader = BufReader::new(third.try_clone().unwrap());
    let waiting = read_response(&mut reader);
    assert!(
        waiting
            .as_ref()
            .is_err_and(|e| e.kind() == std::io::ErrorKind::WouldBlock
                || e.kind() == std::io::ErrorKind::TimedOut),
        "{waiting:?}"
    );
    // One goes: the third is answered.
    let t = Instant::now();
    drop(held);
    third
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    let r = read_response(&mut reader).unwrap();
    assert_eq!(r.status, 200);
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    drop((reader, third));
    // Idle holders never give their slots back on their own: the header timeout takes them.
    let held: Vec<_> = (0..2).map(|_| connect(s.addr)).collect();
    std::thread::sleep(Duration::from_millis(300));
    let t = Instant::now();
    let r = get(s.addr, "/healthz");
    assert_eq!(r.status, 200);
    let waited = t.elapsed();
    assert!(
        waited > Duration::from_secs(1) && waited < Duration::from_secs(6),
        "answered after {waited:?} (the holders are cut at 3 s)"
    );
    drop(held);
    assert_alive(s.addr);
}

/// Opens `n` uploads of `body`'s length that send only its first `sent` bytes and hold.
fn held_uploads(
    addr: std::net::SocketAddr,
    body: &[u8],
    sent: usize,
    n: usize,
) -> Vec<std::net::TcpStream> {
    (0..n)
        .map(|_| {
            let mut c = connect(addr);
            c.write_all(
                head(
                    "POST",
                    "/v1/study",
                    &[("content-type", "model/stl")],
                    Some(body.len()),
                )
                .as_bytes(),
            )
            .unwrap();
            c.write_all(&body[..sent]).unwrap();
            c
        })
        .collect()
}

/// Waits until `/healthz` says `key` is `value` (at most 30 s).
fn until_health(addr: std::net::SocketAddr, key: &str, value: u64) {
    let t = Instant::now();
    while get(addr, "/healthz").json()[key] != value {
        assert!(t.elapsed() < Duration::from_secs(30), "{key} never {value}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn slow_uploads_hold_no_place_of_the_queue() {
    let s = start(&["--analyses", "1", "--queue", "1"]);
    let stl = sample_stl("plate");
    // Uploads that never finish are received, not admitted: others are served.
    let held = held_uploads(s.addr, &stl, 100, 4);
    until_health(s.addr, "receiving", 4);
    let health = get(s.addr, "/healthz").json();
    assert_eq!(
        (&health["running"], &health["waiting"]),
        (&0.into(), &0.into()),
        "{health}"
    );
    let r = study_stl(s.addr, "", &stl);
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    drop(held);
    until_health(s.addr, "receiving", 0);
}

/// Sends a study of the cover that runs several seconds (the fill's several-gate search
/// and suitability map) on a connection of its own, and waits until it runs: dropping the
/// connection stops it.
fn long_study(addr: std::net::SocketAddr) -> std::net::TcpStream {
    let stl = sample_stl("cover");
    let mut c = connect(addr);
    let query = "/v1/study?fill=true&gates=4&suitability=true&cell=0.5";
    c.write_all(
        head(
            "POST",
            query,
            &[("content-type", "model/stl")],
            Some(stl.len()),
        )
        .as_bytes(),
    )
    .unwrap();
    c.write_all(&stl).unwrap();
    until_health(addr, "running", 1);
    c
}

#[test]
fn studies_beyond_the_queue_are_503() {
    let s = start(&["--analyses", "1", "--queue", "1", "--timeout", "60"]);
    let stl = sample_stl("cover");
    let addr = s.addr;
    // The first holds the one slot, the second takes the one queue place and waits.
    let first = long_study(addr);
    let second = {
        let stl = stl.clone();
        std::thread::spawn(move || study_stl(addr, "", &stl))
    };
    until_health(addr, "waiting", 1);
    let r = study_stl(addr, "", &stl);
    let e = assert_error(&s, &r, 503, "busy");
    assert_eq!(
        e["message"],
        "the server is busy: 1 study running and 1 waiting, as many as it takes (--analyses 1, --queue 1); try again later"
    );
    assert_eq!(r.header("retry-after"), Some("5"));
    // The first's client goes: its study stops, and the one waiting runs.
    drop(first);
    let second = second.join().unwrap();
    assert_eq!(
        second.status,
        200,
        "{}",
        String::from_utf8_lossy(&second.body)
    );
    until_health(addr, "running", 0);
    assert_eq!(study_stl(addr, "", &stl).status, 200);
}

#[test]
fn a_study_that_waits_past_its_time_never_starts() {
    let s = start(&["--analyses", "1", "--queue", "1", "--timeout", "0.1"]);
    let stl = sample_stl("cover");
    let addr = s.addr;
    // Two studies sent at once, each with a grid of about 2 million nodes, whose rays (0.3 s
    // or more) stop only between blocks of 4096 triangles: the cover's 2044 are one block.
    // The one that runs is stopped at the end of its rays, well past the limit; the other
    // waited for the slot all its 0.1 s and never started.
    let send = || {
        let stl = stl.clone();
        std::thread::spawn(move || study_stl(addr, "spacing=0.07", &stl))
    };
    let (a, b) = (send(), send());
    let mut messages: Vec<String> = [a.join().unwrap(), b.join().unwrap()]
        .iter()
        .map(|r| {
            let e = assert_error(&s, r, 504, "timeout");
            e["message"].as_str().unwrap().to_string()
        })
        .collect();
    messages.sort();
    assert!(
        messages[0].starts_with("the study did not finish within 0.1 s (--timeout)"),
        "{messages:?}"
    );
    assert!(
        messages[1].starts_with(
            "the study waited 0.1 s (--timeout) for an analysis slot and did not start"
        ),
        "{messages:?}"
    );
    // When the slot is free, studies are admitted again.
    until_health(addr, "running", 0);
    assert_eq!(study_stl(addr, "", &sample_stl("plate")).status, 200);
}

#[test]
fn uploads_past_the_upload_memory_are_503() {
    // One MiB uploads, one slot and one queue place: 2 MiB of bodies held at most.
    let s = start(&["--analyses", "1", "--queue", "1", "--max-upload", "1"]);
    let body = vec![b' '; 1 << 20];
    let held = held_uploads(s.addr, &body, (1 << 20) - 1, 2);
    until_health(s.addr, "receiving", 2);
    // Let the server read what was sent.
    std::thread::sleep(Duration::from_millis(500));
    let r = study_stl(s.addr, "", &sample_stl("plate"));
    let e = assert_error(&s, &r, 503, "busy");
    assert!(
        e["message"].as_str().unwrap().starts_with(
            "the server is busy: the bodies it holds (2 other uploads being received, and those of the studies admitted) fill its upload memory of 2 MiB"
        ),
        "{e}"
    );
    assert_eq!(r.header("retry-after"), Some("5"));
    drop(held);
    until_health(s.addr, "receiving", 0);
    assert_eq!(study_stl(s.addr, "", &sample_stl("plate")).status, 200);
}

#[test]
fn a_study_past_the_time_limit_is_stopped_with_504() {
    let s = start(&["--timeout", "0.05", "--analyses", "1"]);
    let stl = sample_stl("cover");
    let r = study_stl(s.addr, "fill=true&wall_thickness=true", &stl);
    assert_error(&s, &r, 504, "timeout");
    // The cancelled study frees its slot at its next stage; then the server studies again.
    let t = Instant::now();
    while get(s.addr, "/healthz").json()["running"] != 0 {
        assert!(t.elapsed() < Duration::from_secs(30));
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A study that outlives `--timeout` inside the fill (several gates and the suitability
/// map on fine cells, several seconds) stops in the fill's marches, not at the end of the
/// stage: the server's log says where it stopped and how long it held its slot.
#[test]
fn a_study_past_the_time_limit_stops_inside_its_fill() {
    let s = start(&["--timeout", "1", "--analyses", "1"]);
    let stl = sample_stl("cover");
    let t = Instant::now();
    let r = study_stl(s.addr, "fill=true&gates=4&suitability=true&cell=0.5", &stl);
    let e = assert_error(&s, &r, 504, "timeout");
    assert!(e["message"]
        .as_str()
        .unwrap()
        .contains("it stops within a step of the fill analysis (a step of its cells, a facet of its walls, a march), a facet of the wall map or a block of triangles of the gate's rays"));
    while get(s.addr, "/healthz").json()["running"] != 0 {
        assert!(t.elapsed() < Duration::from_secs(120));
        std::thread::sleep(Duration::from_millis(20));
    }
    println!(
        "slot free {:.2} s after the request",
        t.elapsed().as_secs_f64()
    );
    let ended = log_line(&s, "a study past --timeout ended");
    println!("{ended}");
    assert!(ended.ends_with("(cancelled at the fill stage)"), "{ended}");
}

/// A client that hangs up while its study runs stops the study (it held its slot and its
/// memory to its end, past --timeout, when only the time limit stopped studies): the slot
/// is free within a step of the fill, long before the limit, and the log names why.
#[test]
fn a_study_whose_client_hangs_up_stops_before_its_time_limit() {
    let s = start(&["--timeout", "60", "--analyses", "1"]);
    let c = long_study(s.addr);
    // Well into the study (it takes several seconds), the client goes.
    std::thread::sleep(Duration::from_millis(300));
    drop(c);
    let gone = Instant::now();
    while get(s.addr, "/healthz").json()["running"] != 0 {
        assert!(
            gone.elapsed() < Duration::from_secs(3),
            "the study of a client that hung up still runs"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    println!(
        "slot free {:.2} s after the client hung up",
        gone.elapsed().as_secs_f64()
    );
    let ended = log_line(&s, "a study whose client hung up ended");
    assert!(
        ended.ends_with(": stopped (cancelled at the fill stage)"),
        "{ended}"
    );
}

#[test]
fn sigterm_finishes_the_request_in_flight_then_exits() {
    let mut s = start(&[]);
    let stl = sample_stl("cover");
    let addr = s.addr;
    let inflight = std::thread::spawn(move || study_stl(addr, "fill=true", &stl));
    // Wait until the study runs.
    let t = Instant::now();
    while get(s.addr, "/healthz").json()["running"] == 0 {
        assert!(
            t.elapsed() < Duration::from_secs(10),
            "the study never started"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let kill = std::process::Command::new("kill")
        .args(["-TERM", &s.child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let r = inflight.join().unwrap();
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    let status = s.child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    let t = Instant::now();
    while !s.log_text().contains("moldgate: stopped") && t.elapsed().as_secs() < 5 {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(
        s.log_text().contains("moldgate: stopped"),
        "{}",
        s.log_text()
    );
    assert!(std::net::TcpStream::connect(addr).is_err());
}

#[test]
fn the_web_folder_is_served_with_isolation_headers_and_mime_types() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("index.html"),
        "<!doctype html><title>app</title>",
    )
    .unwrap();
    std::fs::write(dir.path().join("app.wasm"), b"\0asm\x01\0\0\0").unwrap();
    std::fs::write(dir.path().join("app.js"), "export {}").unwrap();
    let s = start(&["--web-dir", dir.path().to_str().unwrap()]);
    let index = get(s.addr, "/");
    assert_eq!(index.status, 200);
    assert!(index
        .header("content-type")
        .unwrap()
        .starts_with("text/html"));
    assert_eq!(
        index.header("cross-origin-opener-policy"),
        Some("same-origin")
    );
    assert_eq!(
        index.header("cross-origin-embedder-policy"),
        Some("require-corp")
    );
    let wasm = get(s.addr, "/app.wasm");
    assert_eq!(wasm.header("content-type"), Some("application/wasm"));
    assert_eq!(wasm.body, b"\0asm\x01\0\0\0");
    assert!(get(s.addr, "/app.js")
        .header("content-type")
        .unwrap()
        .contains("javascript"));
    assert_eq!(get(s.addr, "/missing.js").status, 404);
    assert_eq!(get(s.addr, "/v1/materials").status, 200);
    // A missing folder given on purpose is an error at start.
    let out = moldgate(dir.path(), &["serve", "--web-dir", "no-such-folder"]);
    assert_eq!(out.status.code(), Some(common::INPUT));
}

#[test]
fn bad_limits_are_refused_at_start() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        &["serve", "--analyses", "0"][..],
        &["serve", "--max-upload", "0"],
        &["serve", "--timeout", "0"],
        &["serve", "--max-nodes", "0"],
        &["serve", "--connections", "0"],
        &["serve", "--connections", "70000"],
        &["serve", "--header-timeout", "0"],
        &["serve", "--header-timeout", "nan"],
    ] {
        let out = moldgate(dir.path(), args);
        assert_eq!(out.status.code(), Some(common::USAGE), "{args:?}");
    }
}

/// A server whose node limit is below the options' default serves requests that do not ask
/// for a grid size, within its limit, and still refuses one that asks for more.
#[test]
fn a_lower_node_limit_is_the_default_of_requests_that_give_none() {
    let s = start(&["--max-nodes", "5000"]);
    let stl = sample_stl("cover");
    let r = study_stl(s.addr, "spacing=2", &stl);
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    // A grid finer than the limit allows is refused for its spacing, with the limit named.
    let r = study_stl(s.addr, "spacing=0.01", &stl);
    let e = assert_error(&s, &r, 400, "options");
    assert_eq!(e["where"], "spacing", "{e}");
    let r = study_stl(s.addr, "max_nodes=6000", &stl);
    let e = assert_error(&s, &r, 400, "options");
    assert_eq!(e["where"], "max_nodes", "{e}");
}
