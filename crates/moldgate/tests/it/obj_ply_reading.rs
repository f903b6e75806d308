//! Reading OBJ and PLY files: the same part written as STL, OBJ, ASCII PLY and binary PLY
//! (both byte orders) loads to the same mesh and stats and gets the same gate; malformed
//! files are refused with their place and never panic.
//!
//! The files are written in code from a built-in sample saved as binary STL and read back, so
//! every coordinate is an f32 value that each format holds exactly.

use std::fmt::Write as _;

use moldgate::error::{LoadError, Place};
use moldgate::mesh::{read_obj, read_ply, read_stl, Format, LoadedMesh, Mesh, Units};
use moldgate::{locate, samples, LocateOptions};

use crate::common::SplitMix;

/// The sample `name` as it reads back from a binary STL.
fn sample_via_stl(name: &str) -> (Vec<u8>, LoadedMesh) {
    let mesh = samples::sample(name).expect("a built-in sample");
    let mut stl = Vec::new();
    mesh.write_stl(&mut stl).unwrap();
    let part = read_stl(&stl[..], stl.len() as u64, Units::Mm).unwrap();
    (stl, part)
}

/// An OBJ of `mesh`: the vertices in reverse order (welding numbers them by first use, so
/// the order in the file must not matter), faces in the four corner forms, every other face
/// with negative (relative) indices, and the statements a reader skips.
fn obj(mesh: &Mesh) -> Vec<u8> {
    let n = mesh.vertices.len();
    let mut text = String::from("# written by a test\nmtllib part.mtl\no part\n");
    for v in mesh.vertices.iter().rev() {
        writeln!(text, "v {} {} {}", v.x, v.y, v.z).unwrap();
    }
    text.push_str("vt 0 0\nvn 0 0 1\ng all\nusemtl grey\ns 1\n");
    let file_index = |v: u32| n - v as usize; // 1-based, reversed
    for (t, tri) in mesh.triangles.iter().enumerate() {
        text.push('f');
        for (k, &v) in tri.iter().enumerate() {
            let i = file_index(v) as i64;
            let i = if t % 2 == 1 { i - n as i64 - 1 } else { i };
            match (t + k) % 4 {
                0 => write!(text, " {i}"),
                1 => write!(text, " {i}/1"),
                2 => write!(text, " {i}/1/1"),
                _ => write!(text, " {i}//1"),
            }
            .unwrap();
        }
        text.push('\n');
    }
    text.into_bytes()
}

#[derive(Clone, Copy)]
enum Ply {
    Ascii,
    Little,
    Big,
}

/// A PLY of `mesh` with an extra vertex property, an extra face property and an extra
/// element, all of which the reader must skip by their types. Binary little-endian holds
/// float coordinates and uchar counts; big-endian doubles and ushort counts.
fn ply(mesh: &Mesh, encoding: Ply) -> Vec<u8> {
    let (format, coord, count) = match encoding {
        Ply::Ascii => ("ascii", "float", "uchar"),
        Ply::Little => ("binary_little_endian", "float", "uchar"),
        Ply::Big => ("binary_big_endian", "double", "ushort"),
    };
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment test\nelement vertex {}\nproperty {coord} x\n\
         property {coord} y\nproperty {coord} z\nproperty uchar quality\nelement face {}\n\
         property list {count} int vertex_indices\nproperty short flags\nelement material 1\n\
         property list uchar float rgb\nend_header\n",
        mesh.vertices.len(),
        mesh.triangles.len()
    )
    .into_bytes();
    let mut put = |bytes: &[u8]| out.extend_from_slice(bytes);
    match encoding {
        Ply::Ascii => {
            let mut text = String::new();
            for v in &mesh.vertices {
                writeln!(text, "{} {} {} 7", v.x, v.y, v.z).unwrap();
            }
            for [a, b, c] in &mesh.triangles {
                writeln!(text, "3 {a} {b} {c} -2").unwrap();
            }
            text.push_str("3 0.5 0.5 0.5\n");
            put(text.as_bytes());
        }
        Ply::Little => {
            for v in &mesh.vertices {
                for c in v.to_array() {
                    put(&(c as f32).to_le_bytes());
                }
                put(&[7]);
            }
            for tri in &mesh.triangles {
                put(&[3]);
                for &i in tri {
                    put(&(i as i32).to_le_bytes());
                }
                put(&(-2i16).to_le_bytes());
            }
            put(&[3]);
            for c in [0.5f32; 3] {
                put(&c.to_le_bytes());
            }
        }
        Ply::Big => {
            for v in &mesh.vertices {
                for c in v.to_array() {
                    put(&c.to_be_bytes());
                }
                put(&[7]);
            }
            for tri in &mesh.triangles {
                put(&3u16.to_be_bytes());
                for &i in tri {
                    put(&(i as i32).to_be_bytes());
                }
                put(&(-2i16).to_be_bytes());
            }
            put(&[3]);
            for c in [0.5f32; 3] {
                put(&c.to_be_bytes());
            }
        }
    }
    out
}

/// The stats as JSON, without the format.
fn stats_but_format(part: &LoadedMesh) -> serde_json::Value {
    let mut v = serde_json::to_value(&part.stats).unwrap();
    v.as_object_mut().unwrap().remove("format");
    v
}

#[test]
fn every_sample_gives_the_same_mesh_stats_and_gate_in_every_format() {
    for info in samples::SAMPLES {
        let (_, stl) = sample_via_stl(info.name);
        let stl_gate = locate(&stl, &LocateOptions::default()).unwrap();
        let files = [
            (Format::Obj, read_obj(&obj(&stl.mesh)[..], Units::Mm)),
            (
                Format::PlyAscii,
                read_ply(&ply(&stl.mesh, Ply::Ascii)[..], Units::Mm),
            ),
            (
                Format::PlyBinaryLittleEndian,
                read_ply(&ply(&stl.mesh, Ply::Little)[..], Units::Mm),
            ),
            (
                Format::PlyBinaryBigEndian,
                read_ply(&ply(&stl.mesh, Ply::Big)[..], Units::Mm),
            ),
        ];
        for (format, part) in files {
            let part = part.unwrap_or_else(|e| panic!("{} as {format:?}: {e}", info.name));
            let what = format!("{} as {format:?}", info.name);
            assert_eq!(part.stats.format, format, "{what}");
            assert_eq!(part.mesh.vertices, stl.mesh.vertices, "{what}");
            assert_eq!(part.mesh.triangles, stl.mesh.triangles, "{what}");
            assert_eq!(stats_but_format(&part), stats_but_format(&stl), "{what}");
            assert_eq!(part.warnings, stl.warnings, "{what}");
            let gate = locate(&part, &LocateOptions::default()).unwrap();
            assert!(stl_gate.grid_gate.is_some(), "{what}");
            assert_eq!(
                format!("{:?}", gate.grid_gate),
                format!("{:?}", stl_gate.grid_gate),
                "{what}"
            );
            assert_eq!(
                format!("{:?}", gate.aesthetic_gate),
                format!("{:?}", stl_gate.aesthetic_gate),
                "{what}"
            );
            assert_eq!(gate.centre, stl_gate.centre, "{what}");
        }
    }
}

#[test]
fn units_scale_obj_and_ply_like_stl() {
    let (stl_bytes, mm) = sample_via_stl("cap");
    let stl = read_stl(&stl_bytes[..], stl_bytes.len() as u64, Units::In).unwrap();
    let obj = read_obj(&obj(&mm.mesh)[..], Units::In).unwrap();
    let ply = read_ply(&ply(&mm.mesh, Ply::Little)[..], Units::In).unwrap();
    for part in [&obj, &ply] {
        assert_eq!(part.mesh.vertices, stl.mesh.vertices);
        assert_eq!(part.stats.units, Units::In);
        assert_eq!(part.warnings, stl.warnings);
        assert!(
            (part.stats.area_mm2 - mm.stats.area_mm2 * 25.4 * 25.4).abs()
                < 1e-6 * part.stats.area_mm2
        );
    }
}

#[test]
fn polygons_are_fanned_and_degenerate_facets_counted_like_stl() {
    // A unit cube as six quads (one written as a pentagon with a repeated corner).
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
        f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6 6\n";
    let part = read_obj(text.as_bytes(), Units::Mm).unwrap();
    assert_eq!(part.stats.facets_read, 13);
    assert_eq!(part.stats.collapsed_facets, 1);
    assert_eq!(part.stats.triangles, 12);
    assert_eq!(part.stats.vertices, 8);
    assert!(part.stats.is_closed());
    assert!((part.stats.area_mm2 - 6.0).abs() < 1e-12);
    assert!(
        part.warnings.iter().any(|w| w.contains("1 degenerate")),
        "{:?}",
        part.warnings
    );
}

fn place_of(e: LoadError) -> Place {
    match e {
        LoadError::Syntax { place, .. } => place,
        other => panic!("expected an error with a place, got {other:?}"),
    }
}

#[test]
fn malformed_files_name_the_place() {
    let (_, cube) = sample_via_stl("plate");
    let good = String::from_utf8(obj(&cube.mesh)).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    let first_face = lines.iter().position(|l| l.starts_with("f ")).unwrap();
    let n = cube.mesh.vertices.len();
    for bad in [
        "v 1 2 x".to_string(),
        format!("f 1 2 {}", n + 1),
        "f 0 1 2".to_string(),
        format!("f 1 2 -{}", n + 1),
        "f 1 2".to_string(),
    ] {
        let mut edited = lines.clone();
        edited[first_face + 3] = &bad;
        let err = read_obj(edited.join("\n").as_bytes(), Units::Mm).unwrap_err();
        assert!(
            err.to_string()
                .starts_with(&format!("line {}: ", first_face + 4)),
            "{bad}: {err}"
        );
    }
    // An empty OBJ is an empty file (as an empty STL or PLY); one without faces has
    // nothing to analyse.
    assert!(matches!(
        read_obj(&b""[..], Units::Mm),
        Err(LoadError::Empty)
    ));
    assert!(matches!(
        read_ply(&b""[..], Units::Mm),
        Err(LoadError::Empty)
    ));
    // Binary PLY cut inside the faces names a byte within the body.
    let bytes = ply(&cube.mesh, Ply::Big);
    let cut = bytes.len() - 30;
    match place_of(read_ply(&bytes[..cut], Units::Mm).unwrap_err()) {
        Place::Byte(b) => assert!(b as usize <= cut && b as usize > cut - 20, "{b} vs {cut}"),
        other => panic!("{other:?}"),
    }
}

// ---------------------------------------------------------------------------------------------
// Loading never panics

/// A small closed part in every format: a tetrahedron.
fn small_files() -> Vec<(bool, Vec<u8>)> {
    let mesh = Mesh {
        vertices: vec![
            [0.0, 0.0, 0.0].into(),
            [10.0, 0.0, 0.0].into(),
            [0.0, 10.0, 0.0].into(),
            [0.0, 0.0, 10.0].into(),
        ],
        triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    };
    vec![
        (true, obj(&mesh)),
        (false, ply(&mesh, Ply::Ascii)),
        (false, ply(&mesh, Ply::Little)),
        (false, ply(&mesh, Ply::Big)),
    ]
}

fn load(is_obj: bool, bytes: &[u8]) -> Result<LoadedMesh, LoadError> {
    if is_obj {
        read_obj(bytes, Units::Mm)
    } else {
        read_ply(bytes, Units::Mm)
    }
}

#[test]
fn every_prefix_loads_or_is_refused_without_panic() {
    for (is_obj, bytes) in small_files() {
        assert!(load(is_obj, &bytes).is_ok());
        for len in 0..bytes.len() {
            if let Err(e) = load(is_obj, &bytes[..len]) {
                assert!(!e.to_string().is_empty());
            }
        }
    }
}

#[test]
fn corrupted_files_load_or_are_refused_without_panic() {
    let files = small_files();
    let mut rng = SplitMix(0x0B7_91E);
    let mut refused = 0;
    for round in 0..4000 {
        let (is_obj, good) = &files[round % files.len()];
        let mut bytes = good.clone();
        for _ in 0..1 + rng.next() % 8 {
            let at = (rng.next() % bytes.len() as u64) as usize;
            bytes[at] = match rng.next() % 5 {
                0 => b' ',
                1 => b'\n',
                2 => b"0123456789.-+eE/"[(rng.next() % 16) as usize],
                3 => 0xFF,
                _ => rng.next() as u8,
            };
        }
        if let Err(e) = load(*is_obj, &bytes) {
            assert!(!e.to_string().is_empty());
            refused += 1;
        }
    }
    // The loop must exercise the error paths, not only files that still read.
    assert!(refused > 1000, "{refused} refused");
}
