//! Writes the seed corpus of the fuzz targets (`fuzz/`): small parts made in code, each as
//! binary and ASCII STL, OBJ and PLY (ASCII, binary little- and big-endian), plus variants
//! that take the readers' less common paths (quads, negative indices, CRLF, two `solid`
//! blocks, an open mesh, a truncated file, a NaN).
//!
//! `cargo run -p moldgate --example fuzz_seeds -- FOLDER` writes `FOLDER/read_stl/`,
//! `FOLDER/read_obj/`, `FOLDER/read_ply/` and `FOLDER/analyse/` (the same files behind the
//! four option bytes of that target, the first of which picks the reader).

use std::fmt::Write as _;
use std::path::PathBuf;

use moldgate::samples::BoxUnion;
use moldgate::Mesh;

/// The parts: a cube, a tetrahedron, an L-shaped block, a plate with a hole through it.
fn parts() -> Vec<(&'static str, Mesh)> {
    let cube = {
        let mut b = BoxUnion::default();
        b.add([0.0, 0.0, 0.0], [10.0, 10.0, 10.0]);
        b.mesh()
    };
    let tetra = Mesh {
        vertices: [
            [0.0, 0.0, 0.0],
            [20.0, 0.0, 0.0],
            [0.0, 20.0, 0.0],
            [0.0, 0.0, 20.0],
        ]
        .map(moldgate::math::DVec3::from_array)
        .to_vec(),
        triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    };
    let ell = {
        let mut b = BoxUnion::default();
        b.add([0.0, 0.0, 0.0], [30.0, 10.0, 4.0]);
        b.add([0.0, 0.0, 0.0], [8.0, 10.0, 20.0]);
        b.mesh()
    };
    let plate = {
        let mut b = BoxUnion::default();
        b.add([0.0, 0.0, 0.0], [40.0, 30.0, 3.0]);
        b.subtract([15.0, 10.0, 0.0], [25.0, 20.0, 3.0]);
        b.mesh()
    };
    vec![
        ("cube", cube),
        ("tetra", tetra),
        ("ell", ell),
        ("plate", plate),
    ]
}

fn binary_stl(mesh: &Mesh) -> Vec<u8> {
    let mut out = Vec::new();
    mesh.write_stl(&mut out).expect("writing to memory");
    out
}

fn ascii_stl(mesh: &Mesh, name: &str, eol: &str) -> Vec<u8> {
    let mut s = format!("solid {name}{eol}");
    for t in 0..mesh.triangles.len() {
        let n = mesh.normal(t);
        let _ = write!(
            s,
            "  facet normal {} {} {}{eol}    outer loop{eol}",
            n.x, n.y, n.z
        );
        for p in mesh.corners(t) {
            let _ = write!(s, "      vertex {} {} {}{eol}", p.x, p.y, p.z);
        }
        let _ = write!(s, "    endloop{eol}  endfacet{eol}");
    }
    let _ = write!(s, "endsolid {name}{eol}");
    s.into_bytes()
}

/// OBJ with triangles; `relative` writes negative indices, `forms` cycles through the four
/// corner forms (`v`, `v/t`, `v/t/n`, `v//n`).
fn obj(mesh: &Mesh, relative: bool, forms: bool) -> Vec<u8> {
    let n = mesh.vertices.len() as i64;
    let mut s = String::from("# moldgate seed\no part\n");
    for v in &mesh.vertices {
        let _ = writeln!(s, "v {} {} {}", v.x, v.y, v.z);
    }
    s.push_str("vt 0 0\nvn 0 0 1\ng all\nusemtl grey\ns off\n");
    for (t, tri) in mesh.triangles.iter().enumerate() {
        s.push('f');
        for (k, &v) in tri.iter().enumerate() {
            let i = if relative {
                i64::from(v) - n
            } else {
                i64::from(v) + 1
            };
            let _ = match if forms { (t + k) % 4 } else { 0 } {
                0 => write!(s, " {i}"),
                1 => write!(s, " {i}/1"),
                2 => write!(s, " {i}/1/1"),
                _ => write!(s, " {i}//1"),
            };
        }
        s.push('\n');
    }
    s.into_bytes()
}

/// OBJ of a cube written as six quads (fanned by the reader).
fn obj_quads() -> Vec<u8> {
    b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n"
        .to_vec()
}

#[derive(Clone, Copy)]
enum Ply {
    Ascii,
    Little,
    Big,
}

/// PLY with an extra vertex property, an extra face property and an extra element.
fn ply(mesh: &Mesh, encoding: Ply) -> Vec<u8> {
    let (format, coord, count) = match encoding {
        Ply::Ascii => ("ascii", "float", "uchar"),
        Ply::Little => ("binary_little_endian", "float", "uchar"),
        Ply::Big => ("binary_big_endian", "double", "ushort"),
    };
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment moldgate seed\nelement vertex {}\n\
         property {coord} x\nproperty {coord} y\nproperty {coord} z\nproperty uchar quality\n\
         element face {}\nproperty list {count} int vertex_indices\nproperty short flags\n\
         element material 1\nproperty list uchar float rgb\nend_header\n",
        mesh.vertices.len(),
        mesh.triangles.len()
    )
    .into_bytes();
    match encoding {
        Ply::Ascii => {
            let mut s = String::new();
            for v in &mesh.vertices {
                let _ = writeln!(s, "{} {} {} 7", v.x, v.y, v.z);
            }
            for [a, b, c] in &mesh.triangles {
                let _ = writeln!(s, "3 {a} {b} {c} -2");
            }
            s.push_str("3 0.5 0.5 0.5\n");
            out.extend_from_slice(s.as_bytes());
        }
        Ply::Little => {
            for v in &mesh.vertices {
                for c in v.to_array() {
                    out.extend_from_slice(&(c as f32).to_le_bytes());
                }
                out.push(7);
            }
            for tri in &mesh.triangles {
                out.push(3);
                for &i in tri {
                    out.extend_from_slice(&(i as i32).to_le_bytes());
                }
                out.extend_from_slice(&(-2i16).to_le_bytes());
            }
            out.push(3);
            for c in [0.5f32; 3] {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        Ply::Big => {
            for v in &mesh.vertices {
                for c in v.to_array() {
                    out.extend_from_slice(&c.to_be_bytes());
                }
                out.push(7);
            }
            for tri in &mesh.triangles {
                out.extend_from_slice(&3u16.to_be_bytes());
                for &i in tri {
                    out.extend_from_slice(&(i as i32).to_be_bytes());
                }
                out.extend_from_slice(&(-2i16).to_be_bytes());
            }
            out.push(3);
            for c in [0.5f64; 3] {
                out.extend_from_slice(&(c as f32).to_be_bytes());
            }
        }
    }
    out
}

/// The mesh without its last triangle (open edges).
fn open(mesh: &Mesh) -> Mesh {
    let mut m = mesh.clone();
    m.triangles.pop();
    m
}

/// The seeds, as (target, file name, bytes): each file under its reader's target, and again
/// under `analyse` behind that target's four option bytes. The library's tests replay these
/// through the targets (`tests/it/fuzz_regressions.rs`).
pub fn seeds() -> Vec<(&'static str, String, Vec<u8>)> {
    let mut stl: Vec<(String, Vec<u8>)> = Vec::new();
    let mut obj_files: Vec<(String, Vec<u8>)> = Vec::new();
    let mut ply_files: Vec<(String, Vec<u8>)> = Vec::new();
    for (name, mesh) in parts() {
        let bin = binary_stl(&mesh);
        stl.push((format!("{name}-binary.stl"), bin.clone()));
        stl.push((format!("{name}-ascii.stl"), ascii_stl(&mesh, name, "\n")));
        obj_files.push((format!("{name}.obj"), obj(&mesh, false, false)));
        obj_files.push((format!("{name}-forms.obj"), obj(&mesh, true, true)));
        ply_files.push((format!("{name}-ascii.ply"), ply(&mesh, Ply::Ascii)));
        ply_files.push((format!("{name}-le.ply"), ply(&mesh, Ply::Little)));
        ply_files.push((format!("{name}-be.ply"), ply(&mesh, Ply::Big)));
        if name == "cube" {
            stl.push((format!("{name}-crlf.stl"), ascii_stl(&mesh, name, "\r\n")));
            let mut two = ascii_stl(&mesh, "a", "\n");
            two.extend(ascii_stl(&open(&mesh), "b", "\n"));
            stl.push((format!("{name}-two-solids.stl"), two));
            stl.push((format!("{name}-open.stl"), binary_stl(&open(&mesh))));
            stl.push((
                format!("{name}-truncated.stl"),
                bin[..bin.len() - 20].to_vec(),
            ));
            let mut zero_count = bin.clone();
            zero_count[80..84].copy_from_slice(&0u32.to_le_bytes());
            stl.push((format!("{name}-zero-count.stl"), zero_count));
            let mut nan = bin.clone();
            nan[84 + 12..84 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
            stl.push((format!("{name}-nan.stl"), nan));
            obj_files.push(("cube-quads.obj".into(), obj_quads()));
            obj_files.push((format!("{name}-open.obj"), obj(&open(&mesh), false, true)));
            let mut le = ply(&mesh, Ply::Little);
            le.truncate(le.len() - 7);
            ply_files.push((format!("{name}-truncated-le.ply"), le));
        }
    }
    let mut seeds = Vec::new();
    for (target, kind, files) in [
        ("read_stl", 0, &stl),
        ("read_obj", 1, &obj_files),
        ("read_ply", 2, &ply_files),
    ] {
        for (name, bytes) in files {
            seeds.push((target, name.clone(), bytes.clone()));
        }
        for (i, (name, bytes)) in files.iter().enumerate() {
            // The reader, a direction, 16 circle points, and a fill variant per file.
            let mut data = vec![kind, i as u8, 16, (i * 7) as u8];
            data.extend_from_slice(bytes);
            seeds.push(("analyse", name.clone(), data));
        }
    }
    seeds
}

fn main() -> std::io::Result<()> {
    let root: PathBuf = std::env::args_os()
        .nth(1)
        .map(Into::into)
        .unwrap_or_else(|| "fuzz/seeds".into());
    let seeds = seeds();
    for (target, name, bytes) in &seeds {
        let dir = root.join(target);
        std::fs::create_dir_all(&dir)?;
        std::fs::write(dir.join(name), bytes)?;
    }
    eprintln!("wrote {} seeds in {}", seeds.len(), root.display());
    Ok(())
}
