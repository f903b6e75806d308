//! Hostile and odd input: every cost a file or an option controls is bounded and checked
//! before the work, every number an analysis gives is finite or the part is refused with the
//! reason, and messages quote the input short and escaped. Each test builds the smallest
//! input that shows its point.

use std::io::Cursor;

use moldgate::error::{LoadError, Place};
use moldgate::gate::{Spacing, MAX_CIRCLE_POINTS};
use moldgate::math::DVec3;
use moldgate::mesh::{
    from_generated, read_obj, read_ply, read_stl, LoadedMesh, Mesh, Units, MAX_POLYGON_CORNERS,
};
use moldgate::study::{study, StudyError, StudyOptions};
use moldgate::{locate, LocateOptions, OptionsError};

use crate::common::SplitMix;

fn stl(bytes: &[u8]) -> Result<LoadedMesh, LoadError> {
    read_stl(Cursor::new(bytes), bytes.len() as u64, Units::Mm)
}

fn obj(text: &[u8]) -> Result<LoadedMesh, LoadError> {
    read_obj(Cursor::new(text), Units::Mm)
}

/// A binary STL of the given facets.
fn binary_stl(facets: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut out = vec![b' '; 80];
    out.extend((facets.len() as u32).to_le_bytes());
    for f in facets {
        out.extend([0u8; 12]);
        for c in f.iter().flatten() {
            out.extend(c.to_le_bytes());
        }
        out.extend([0u8; 2]);
    }
    out
}

/// The four facets of a tetrahedron with corner `o` and legs `s`.
fn tetrahedron(o: [f32; 3], s: f32) -> Vec<[[f32; 3]; 3]> {
    let [x, y, z] = o;
    let (a, b, c, d) = ([x, y, z], [x + s, y, z], [x, y + s, z], [x, y, z + s]);
    vec![[a, c, b], [a, b, d], [a, d, c], [b, c, d]]
}

const TETRA_ASCII: &str = "solid t\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 10 0\n\
vertex 10 0 0\nendloop\nendfacet\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 10 0 0\n\
vertex 0 0 10\nendloop\nendfacet\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 0 10\n\
vertex 0 10 0\nendloop\nendfacet\nfacet normal 0 0 0\nouter loop\nvertex 10 0 0\nvertex 0 10 0\n\
vertex 0 0 10\nendloop\nendfacet\nendsolid t\n";

fn message_is_one_short_clean_line(e: &impl std::fmt::Display) {
    let m = e.to_string();
    assert!(m.len() < 400, "{} bytes: {m}", m.len());
    assert!(!m.chars().any(|c| c.is_control()), "{m:?}");
}

// 1. Overlapping triangles -------------------------------------------------------------------

#[test]
fn overlapping_triangles_are_refused_before_the_rays() {
    // 300 random triangles over 30 corners of a 100 mm cube: each ray crosses about a
    // hundred of them. At 0.06 mm that is over 1e9 ray-triangle tests.
    let mut rng = SplitMix(7);
    let mut coord = || (rng.next() >> 11) as f64 / (1u64 << 53) as f64 * 100.0;
    let vertices: Vec<DVec3> = (0..30)
        .map(|_| DVec3::new(coord(), coord(), coord()))
        .collect();
    let mut rng = SplitMix(8);
    let mut triangles = Vec::new();
    while triangles.len() < 300 {
        let t = [0, 1, 2].map(|_| (rng.next() % 30) as u32);
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            triangles.push(t);
        }
    }
    let part = from_generated(Mesh {
        vertices,
        triangles,
    });
    let options = |h: f64| LocateOptions {
        spacing: Spacing::Mm(h),
        ..LocateOptions::default()
    };
    let err = locate(&part, &options(0.06)).unwrap_err();
    let OptionsError::OverlappingSurface {
        depth, ray_tests, ..
    } = err
    else {
        panic!("expected OverlappingSurface, got {err:?}");
    };
    assert!(depth > 20.0 && ray_tests > 1e9, "{depth} {ray_tests}");
    message_is_one_short_clean_line(&err);
    // The same triangles on a coarse grid are within the budget.
    assert!(locate(&part, &options(2.0)).is_ok());
}

/// `n` random triangles across a 100 mm cube, each of its own three corners.
fn random_soup(n: usize, seed: u64) -> Mesh {
    let mut rng = SplitMix(seed);
    let mut coord = || (rng.next() >> 11) as f64 / (1u64 << 53) as f64 * 100.0;
    let vertices: Vec<DVec3> = (0..3 * n)
        .map(|_| DVec3::new(coord(), coord(), coord()))
        .collect();
    let triangles = (0..n as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    Mesh {
        vertices,
        triangles,
    }
}

#[test]
fn walls_of_a_tangled_surface_are_refused_before_they_are_measured() {
    use moldgate::raycast::Bvh;
    use moldgate::thickness::{check_work, TANGLED_AREA_COST, WALL_WORK_BUDGET};
    // The trees of a moulded part's surface cost tens, whatever its size.
    let cover = moldgate::samples::sample("cover").unwrap();
    assert!(Bvh::new(&cover).area_cost() < 50.0);
    assert!(check_work(&Bvh::new(&cover), 100_000_000).is_ok());
    // 40,000 random triangles: refused (their walls took 36 s on two threads).
    let soup = random_soup(40_000, 11);
    let tree = Bvh::new(&soup);
    let cost = tree.area_cost();
    assert!(cost > TANGLED_AREA_COST, "{cost}");
    let err = check_work(&tree, soup.triangles.len()).unwrap_err();
    let OptionsError::TangledSurface { work, budget, .. } = err else {
        panic!("expected TangledSurface, got {err:?}");
    };
    assert!(work > budget && budget == WALL_WORK_BUDGET);
    message_is_one_short_clean_line(&err);
    // 5,000 of them take a fraction of a second: measured.
    let small = random_soup(5_000, 12);
    assert!(check_work(&Bvh::new(&small), small.triangles.len()).is_ok());
    // A study asked for the wall map refuses before the work, as the part's fault.
    let part = from_generated(soup);
    let o: StudyOptions = serde_json::from_str(
        r#"{ "wall_thickness": true, "spacing": 10, "thickness_rule": "ignore" }"#,
    )
    .unwrap();
    let t = std::time::Instant::now();
    let Err(e) = study(&part, &o) else {
        panic!("the walls of a tangled surface were measured");
    };
    assert!(
        matches!(e, StudyError::Locate(OptionsError::TangledSurface { .. })),
        "{e}"
    );
    assert!(t.elapsed().as_secs_f64() < 10.0, "{:?}", t.elapsed());
}

#[test]
fn duplicate_triangles_are_dropped_at_weld_time() {
    let mut text = b"v 0 0 0\nv 50 0 0\nv 0 50 0\nv 50 50 10\n".to_vec();
    for _ in 0..1000 {
        text.extend(b"f 1 2 3\nf 2 4 3\nf 3 2 1\n");
    }
    let part = obj(&text).unwrap();
    assert_eq!(part.stats.facets_read, 3000);
    assert_eq!(part.stats.triangles, 2);
    assert_eq!(part.stats.duplicate_triangles, 2998);
    assert_eq!(part.mesh.triangles, vec![[0, 1, 2], [1, 3, 2]]);
    assert!(part
        .warnings
        .iter()
        .any(|w| w.contains("2998 triangles repeat")));
    // A file of two copies of one triangle has no non-manifold edge, and is caught too.
    let twice = obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3\n").unwrap();
    assert_eq!(twice.stats.duplicate_triangles, 1);
}

// 2. One enormous polygon, line or token -----------------------------------------------------

#[test]
fn enormous_polygon_is_refused_naming_its_line() {
    let n = MAX_POLYGON_CORNERS + 1;
    let mut text = String::new();
    for i in 0..n {
        let a = i as f64 / n as f64 * std::f64::consts::TAU;
        text += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    let corners: Vec<String> = (1..=n).map(|i| i.to_string()).collect();
    text += &format!("f {}\n", corners.join(" "));
    let err = obj(text.as_bytes()).unwrap_err();
    assert!(
        matches!(&err, LoadError::Syntax { place: Place::Line(l), message }
            if *l == n as u64 + 1 && message.contains("limit of a polygon")),
        "{err}"
    );
    // A PLY face declaring more corners is refused before they are read.
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n0 1 0\n25000000 0 1 2\n"
        .to_string();
    let err = read_ply(Cursor::new(ply), Units::Mm).unwrap_err();
    assert!(
        matches!(&err, LoadError::Syntax { place: Place::Line(13), message }
            if message.contains("limit of a polygon")),
        "{err}"
    );
    // An ASCII STL facet too.
    let mut facet = String::from("solid s\nfacet normal 0 0 0\nouter loop\n");
    for _ in 0..n {
        facet += "vertex 0 0 0\n";
    }
    let err = stl(facet.as_bytes()).unwrap_err();
    assert!(err.to_string().contains("limit of a polygon"), "{err}");
}

#[test]
fn enormous_line_is_refused_naming_it_and_quoted_short() {
    // An ASCII STL on one line of more than a mebibyte.
    let mut one_line = b"solid s ".to_vec();
    one_line.extend(
        TETRA_ASCII
            .replace('\n', " ")
            .as_bytes()
            .iter()
            .cycle()
            .take(2 << 20),
    );
    let err = stl(&one_line).unwrap_err();
    assert!(
        matches!(
            &err,
            LoadError::Syntax {
                place: Place::Line(1),
                ..
            }
        ),
        "{err}"
    );
    message_is_one_short_clean_line(&err);
    // A token of 500 kB on a line within the limit is quoted in a few dozen characters.
    let mut token = b"v 0 0 0\nv 1 ".to_vec();
    token.extend(std::iter::repeat_n(b'7', 500_000));
    token.extend(b"x 0\n");
    let err = obj(&token).unwrap_err();
    assert!(
        matches!(
            &err,
            LoadError::Syntax {
                place: Place::Line(2),
                ..
            }
        ),
        "{err}"
    );
    message_is_one_short_clean_line(&err);
}

// 3. Options that size memory ----------------------------------------------------------------

#[test]
fn options_that_size_memory_are_checked_against_their_budget() {
    assert_eq!(LocateOptions::default().validate(), Ok(()));
    let too_many_points = LocateOptions {
        circle_points: 1_000_000,
        ..LocateOptions::default()
    };
    assert!(matches!(
        too_many_points.validate(),
        Err(OptionsError::AboveLimit { limit, .. }) if limit == MAX_CIRCLE_POINTS as u64
    ));
    // The rays' memory is counted on the part's own grid, once it is laid: the largest
    // node limit with the most circle points is valid ...
    let most = LocateOptions {
        max_nodes: moldgate::gate::MAX_NODES_LIMIT,
        circle_points: MAX_CIRCLE_POINTS,
        ..LocateOptions::default()
    };
    assert_eq!(most.validate(), Ok(()));
    let plate = from_generated(moldgate::samples::sample("plate").expect("a plate sample"));
    // ... a small grid with them is studied ...
    let small = LocateOptions {
        circle_points: 64,
        ..most.clone()
    };
    assert!(locate(&plate, &small).is_ok());
    // ... and a fine one is refused before its rays, with what fits.
    let fine = LocateOptions {
        spacing: moldgate::gate::quadrature::Spacing::Mm(0.05),
        ..most.clone()
    };
    let t = std::time::Instant::now();
    let err = locate(&plate, &fine).unwrap_err();
    println!("refused in {:.3} s", t.elapsed().as_secs_f64());
    let OptionsError::RayMemory {
        nodes,
        bytes,
        budget,
        points_within,
        nodes_within,
        ..
    } = err
    else {
        panic!("expected RayMemory, got {err:?}");
    };
    assert!(bytes > budget, "{err}");
    assert_eq!(err.field(), Some("circle_points"));
    // What it says fits does.
    let fits = |nodes: u64, points: u64| (24 + 8 * points) * nodes * 4 <= budget;
    assert!(fits(nodes, points_within) && !fits(nodes, points_within + 1));
    assert!(fits(nodes_within, MAX_CIRCLE_POINTS as u64));
    assert!(!fits(nodes_within + 1, MAX_CIRCLE_POINTS as u64));
    // locate checks them too, before any work.
    let part = from_generated(moldgate::samples::sample("plate").expect("a plate sample"));
    assert!(locate(&part, &too_many_points).is_err());
}

#[test]
fn a_study_checks_the_same_budgets_when_its_options_are_validated() {
    let refused = |json: &str| {
        let o: StudyOptions = serde_json::from_str(json).unwrap();
        o.validate().unwrap_err()
    };
    assert!(matches!(
        refused(r#"{ "circle_points": 1000 }"#),
        StudyError::Locate(OptionsError::AboveLimit { limit, .. }) if limit == MAX_CIRCLE_POINTS as u64
    ));
    // The rays' memory depends on the part's grid: not refused with the options alone.
    let o: StudyOptions = serde_json::from_str(r#"{ "max_nodes": 20000000 }"#).unwrap();
    assert!(o.validate().is_ok());
    // One node limit: the study's is the gate location's.
    assert_eq!(
        moldgate::study::MAX_NODES_LIMIT,
        moldgate::gate::MAX_NODES_LIMIT
    );
    // A part too large for the automatic spacing is refused at the locate stage.
    let part = stl(&binary_stl(&tetrahedron([0.0; 3], 2e8))).unwrap();
    let Err(err) = study(&part, &StudyOptions::default()) else {
        panic!("a part 2e8 mm across was studied");
    };
    assert!(
        matches!(err, StudyError::Locate(OptionsError::PartTooLarge { .. })),
        "{err:?}"
    );
}

// 4. Numbers that are not numbers ------------------------------------------------------------

#[test]
fn coordinates_beyond_the_limit_are_refused_at_load_with_their_place() {
    let mut far = tetrahedron([0.0; 3], 10.0);
    far[2][1][1] = 2e9;
    let err = stl(&binary_stl(&far)).unwrap_err();
    // Facet 2, corner 1, y: 84 + 2 x 50 + 12 + 12 + 4.
    assert!(
        matches!(
            err,
            LoadError::OutOfRange {
                place: Place::Byte(212),
                ..
            }
        ),
        "{err:?}"
    );
    message_is_one_short_clean_line(&err);
    let ascii = TETRA_ASCII.replacen("vertex 0 10 0", "vertex 0 1e154 0", 1);
    assert!(matches!(
        stl(ascii.as_bytes()).unwrap_err(),
        LoadError::OutOfRange {
            place: Place::Line(5),
            ..
        }
    ));
    assert!(matches!(
        obj(b"v 0 0 0\nv 3.5e41 0 0\n").unwrap_err(),
        LoadError::OutOfRange {
            place: Place::Line(2),
            ..
        }
    ));
    // The limit is in millimetres: 2e6 is accepted in mm and refused in metres.
    let bytes = binary_stl(&tetrahedron([0.0; 3], 2e6));
    assert!(stl(&bytes).is_ok());
    let in_metres = read_stl(Cursor::new(&bytes), bytes.len() as u64, Units::M);
    assert!(matches!(in_metres, Err(LoadError::OutOfRange { .. })));
}

#[test]
fn every_number_of_an_analysis_is_finite_for_a_part_far_from_the_origin() {
    // A 64 mm tetrahedron 1e8 mm from the origin (f32 steps of 8 mm there): the centre is
    // taken about the box centre, so nothing cancels to zero or NaN.
    let part = stl(&binary_stl(&tetrahedron([1e8, -1e8, 1e8], 64.0))).unwrap();
    assert!(part.stats.area_mm2.is_finite() && part.stats.area_mm2 > 0.0);
    let options = LocateOptions {
        gate_radius_mm: 1.0,
        thickness_rule: moldgate::gate::ThicknessRule::Ignore,
        ..LocateOptions::default()
    };
    let a = locate(&part, &options).unwrap();
    assert!(a.centre.is_finite() && a.centres.surface.is_finite());
    // Eq. 5 on the four faces: three right triangles of area s^2/2 and one of sqrt(3) s^2/2.
    let (s, r3) = (64.0, 3f64.sqrt());
    let along = |face_sum: f64| face_sum / (3.0 + r3);
    let expected = DVec3::new(1e8, -1e8, 1e8) + DVec3::splat(along(s / 3.0 * (2.0 + r3)));
    assert!(
        (a.centres.surface - expected).length() < 1.0,
        "{}",
        a.centres.surface
    );
    let g = a.grid_gate.expect("a gate on the slanted face");
    assert!(g.distance_3d.is_finite() && g.distance_2d.is_finite() && g.point.is_finite());
}

// 5. A grid too large for the part -----------------------------------------------------------

#[test]
fn grid_too_large_for_the_automatic_spacing_blames_the_part() {
    // 2e8 mm across, read with the gate-sized automatic spacing.
    let part = stl(&binary_stl(&tetrahedron([0.0; 3], 2e8))).unwrap();
    let err = locate(&part, &LocateOptions::default()).unwrap_err();
    let OptionsError::PartTooLarge { min_spacing_mm, .. } = err else {
        panic!("expected PartTooLarge, got {err:?}");
    };
    assert!(min_spacing_mm.is_finite());
    let m = err.to_string();
    assert!(m.contains("--units") && !m.contains("inf"), "{m}");
    // An explicit spacing that is too fine stays the option's fault.
    let fine = LocateOptions {
        spacing: Spacing::Mm(1.0),
        ..LocateOptions::default()
    };
    assert!(matches!(
        locate(&part, &fine),
        Err(OptionsError::GridTooLarge { .. })
    ));
}

// 6. Messages --------------------------------------------------------------------------------

#[test]
fn messages_quote_input_escaped() {
    for bad in [
        &b"v 0 0 0\n\x1b[2J\x1b[31mgotcha 1\n"[..],
        b"v 0 0 \x1b]0;title\x07\n",
        b"v 0 0 0\nf 1 \xff\xfe\x9b 2\n",
    ] {
        let err = obj(bad).unwrap_err();
        message_is_one_short_clean_line(&err);
    }
    let mut stl_text = TETRA_ASCII.replacen("outer loop", "outer \x1b[2Jloop", 1);
    let err = stl(stl_text.as_bytes()).unwrap_err();
    message_is_one_short_clean_line(&err);
    stl_text = TETRA_ASCII.replacen("endloop", &"\u{85}".repeat(300), 1);
    message_is_one_short_clean_line(&stl(stl_text.as_bytes()).unwrap_err());
}

// 7. Byte-order marks, control characters, CR line ends --------------------------------------

#[test]
fn byte_order_mark_before_solid_is_read() {
    let text = format!("\u{feff}{TETRA_ASCII}");
    let part = stl(text.as_bytes()).unwrap();
    assert_eq!(part.stats.triangles, 4);
}

#[test]
fn control_character_early_in_ascii_stl_is_named() {
    // A stray control character in the solid's name: read, the name is skipped.
    let text = TETRA_ASCII.replacen("solid t", "solid t\x01\x02", 1);
    assert_eq!(stl(text.as_bytes()).unwrap().stats.triangles, 4);
    // In a keyword: an ASCII error at its line, not a binary STL of 540 million triangles.
    let text = TETRA_ASCII.replacen("outer loop", "outer\x00loop", 1);
    let err = stl(text.as_bytes()).unwrap_err();
    assert!(
        matches!(
            &err,
            LoadError::Syntax {
                place: Place::Line(3),
                ..
            }
        ),
        "{err}"
    );
    message_is_one_short_clean_line(&err);
}

#[test]
fn cr_only_line_endings_are_read() {
    let text = TETRA_ASCII.replace('\n', "\r");
    let part = stl(text.as_bytes()).unwrap();
    assert_eq!(part.stats.triangles, 4);
    assert!(part.warnings.is_empty(), "{:?}", part.warnings);
    let bad = TETRA_ASCII
        .replacen("vertex 0 0 10", "vertex 0 0 x", 1)
        .replace('\n', "\r");
    assert!(matches!(
        stl(bad.as_bytes()).unwrap_err(),
        LoadError::Syntax {
            place: Place::Line(13),
            ..
        }
    ));
    let obj_cr = obj(b"v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r").unwrap();
    assert_eq!(obj_cr.stats.triangles, 1);
}

// 8. Files that are not meshes ---------------------------------------------------------------

#[test]
fn files_that_are_not_meshes_are_named_by_their_first_bytes() {
    let pad = |head: &[u8]| {
        let mut b = head.to_vec();
        b.extend(std::iter::repeat_n(0x41u8, 300));
        b.extend([0u8, 1, 2, 3, 0xff]);
        b
    };
    let iges = format!("{:<72}S{:>7}\n", "an IGES model", 1);
    for (bytes, name) in [
        (pad(b"ISO-10303-21;\nHEADER;\n"), "STEP"),
        (
            pad(b"PK\x03\x04\x14\x00\x00\x00\x08\x00[Content_Types].xml"),
            "3MF",
        ),
        (pad(b"PK\x03\x04\x14\x00\x00\x00\x08\x00model.stl"), "ZIP"),
        (pad(b"\x1f\x8b\x08\x00"), "gzip"),
        (pad(b"%PDF-1.4\n"), "PDF"),
        (pad(b"\x89PNG\r\n\x1a\n"), "PNG"),
        (pad(iges.as_bytes()), "IGES"),
        (
            b"just a note about the part\n".repeat(10),
            "not an ASCII STL",
        ),
    ] {
        let err = stl(&bytes).unwrap_err();
        assert!(
            matches!(&err, LoadError::NotAMesh { what, .. } if what.contains(name)),
            "{name}: {err}"
        );
        message_is_one_short_clean_line(&err);
    }
    // Given to the OBJ and PLY readers too.
    assert!(matches!(
        obj(&pad(b"PK\x03\x04")).unwrap_err(),
        LoadError::NotAMesh { .. }
    ));
    assert!(matches!(
        read_ply(Cursor::new(pad(b"\x1f\x8b\x08\x00")), Units::Mm).unwrap_err(),
        LoadError::NotAMesh { .. }
    ));
}

// 9. Units -----------------------------------------------------------------------------------

#[test]
fn inch_sized_part_read_as_mm_is_warned() {
    // A 5 x 2.5 x 1.4 "mm" block, the size of a part drawn in inches.
    let part = stl(&binary_stl(&tetrahedron([0.0; 3], 4.0))).unwrap();
    assert!(
        part.warnings
            .iter()
            .any(|w| w
                .contains("if the file is in centimetres or inches, set its units to cm or in")),
        "{:?}",
        part.warnings
    );
    // The shared inch part, when present.
    let dir = std::env::var_os("MOLDGATE_PARTS").map_or_else(
        || std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/parts"),
        std::path::PathBuf::from,
    );
    let path = dir.join("trimesh_featuretype_inches.STL");
    let Ok(bytes) = std::fs::read(&path) else {
        eprintln!("skipped the shared inch part: {} is absent", path.display());
        return;
    };
    let part = stl(&bytes).unwrap();
    assert!(part.warnings.iter().any(|w| w.contains("--units")));
    let as_inches = read_stl(Cursor::new(&bytes), bytes.len() as u64, Units::In).unwrap();
    assert!(!as_inches.warnings.iter().any(|w| w.contains("--units")));
}

/// The search for the largest gate radius that fits runs the rays up to ten times; a study
/// stopped (its time limit) does not run them, nor the gate's own rays: a token set before
/// the rays gives no analysis at all, at once.
#[test]
fn a_stopped_locate_does_not_search_the_radius_that_fits() {
    // The plate is 3 mm thick: a 4 mm gate has no wall thick enough under it.
    let part = from_generated(moldgate::samples::sample("plate").unwrap());
    let options = LocateOptions {
        gate_radius_mm: 4.0,
        ..LocateOptions::default()
    };
    let searched = locate(&part, &options).unwrap();
    assert!(searched.grid_gate.is_none());
    let fit = searched.radius_fit.as_ref().expect("searched");
    assert!(fit.radius_mm.is_some_and(|r| r < 3.0), "{fit:?}");
    let cancel = moldgate::cancel::Cancel::new();
    cancel.cancel();
    let stopped = moldgate::gate::locate_until(&part, &options, Some(&cancel));
    assert_eq!(stopped.unwrap_err(), OptionsError::Stopped);
    assert!(!searched.warnings.iter().any(|w| w.contains("was not run")));
}

/// The gate's rays stop within a block of triangles once a study's token is set: a study of
/// 2.8 million nodes over the cover sample, whose rays take most of its time, stopped a
/// fifth into it says it stopped in the locate stage, with no gate (the rays ran to their
/// end before, and the study stopped after them, with the method's gate). It prints how
/// long each took.
#[test]
fn the_gate_s_rays_stop_when_the_study_is_stopped() {
    let part = from_generated(moldgate::samples::sample("cover").unwrap());
    let size = part.mesh.bounds().diagonal();
    let options = StudyOptions {
        spacing: Some(size / 2500.0),
        max_nodes: 4_000_000,
        ..StudyOptions::default()
    };
    let settings = options.validate().unwrap();
    let whole = std::time::Instant::now();
    let done = study(&part, &options).unwrap();
    let whole = whole.elapsed();
    let nodes = done.analysis().grid.len();
    assert!(nodes > 2_000_000, "{nodes}");
    let cancel = moldgate::cancel::Cancel::new();
    let hooks = moldgate::study::Hooks {
        cancel: Some(&cancel),
        ..Default::default()
    };
    let stopped = std::thread::scope(|s| {
        s.spawn(|| {
            std::thread::sleep(whole / 5);
            cancel.cancel();
        });
        let t = std::time::Instant::now();
        let r = moldgate::study::study_with(&part, &settings, &hooks);
        (r, t.elapsed())
    });
    println!("whole study {whole:?}, stopped one {:?}", stopped.1);
    match stopped.0 {
        Err(StudyError::Cancelled { stage, located }) => {
            assert_eq!(stage, moldgate::study::Stage::Locate);
            assert!(located.is_none());
        }
        other => panic!("{:?}", other.map(|s| s.analysis().gate().is_ok())),
    }
}

/// An element count of more digits than any number the reader keeps is said to be too
/// large, not to be no whole number; a count that is no number still is.
#[test]
fn a_ply_count_past_every_limit_is_too_large() {
    let header = |count: &str| {
        format!("ply\nformat ascii 1.0\nelement vertex {count}\nproperty float x\nend_header\n")
    };
    let err = read_ply(Cursor::new(header("99999999999999999999999")), Units::Mm)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("element count '99999999999999999999999' is too large (more than 2^64)"),
        "{err}"
    );
    let err = read_ply(Cursor::new(header("12x")), Units::Mm)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("element count '12x' is not a whole number"),
        "{err}"
    );
}

/// A number too large for a 64-bit float (a hundred thousand digits, or 1e400) reads as
/// infinity: the message names its line and says so, rather than "inf" alone; a NaN is
/// named as such.
#[test]
fn a_number_too_large_to_represent_is_named_at_its_line() {
    let facet = |z: &str| {
        format!(
            "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 {z}\nendloop\nendfacet\nendsolid x\n"
        )
    };
    for z in ["9".repeat(100_000), "1e400".into(), "-1e400".into()] {
        let e = stl(facet(&z).as_bytes()).unwrap_err().to_string();
        assert!(
            e.starts_with("line 6: triangle 0 has a non-finite coordinate (")
                && e.ends_with("inf: infinite, or a number too large to represent)"),
            "{e}"
        );
    }
    let e = stl(facet("nan").as_bytes()).unwrap_err().to_string();
    assert_eq!(e, "line 6: triangle 0 has a non-finite coordinate (NaN)");
}

/// A part where no node qualifies suggests the parting line's gate (`--aesthetic`) only when
/// there is one: keep-out regions over the whole part cover its parting line too.
#[test]
fn no_gate_suggests_the_parting_line_only_when_it_has_a_gate() {
    let part = from_generated(moldgate::samples::sample("plate").unwrap());
    let reason = |options: LocateOptions| {
        let a = locate(&part, &options).unwrap();
        (
            a.aesthetic_gate.is_some(),
            a.gate().unwrap_err().to_string(),
        )
    };
    // Too large a gate for the 3 mm plate: the line has a gate.
    let (line, why) = reason(LocateOptions {
        gate_radius_mm: 4.0,
        thickness_fallback: moldgate::gate::ThicknessFallback::Report,
        ..LocateOptions::default()
    });
    assert!(line);
    assert!(why.ends_with(", or --aesthetic)"), "{why}");
    // Everything kept out, the line too.
    let (line, why) = reason(LocateOptions {
        keep_out: vec!["box:-1000,-1000,-1000,1000,1000,1000".parse().unwrap()],
        ..LocateOptions::default()
    });
    assert!(!line);
    assert!(
        why.ends_with("(try smaller keep-out regions or no cosmetic side, a smaller gate radius or spacing or another demolding direction)"),
        "{why}"
    );
}

/// A gate radius taken from the search for the largest that fits brings its flatness
/// tolerance with it (a tenth of the radius, unless one was given): the report said the
/// tolerance of the radius refused.
#[test]
fn the_fitted_radius_brings_its_flatness_tolerance() {
    let part = from_generated(moldgate::samples::sample("plate").unwrap());
    let fitted = |flat_tolerance_mm| {
        let a = locate(
            &part,
            &LocateOptions {
                gate_radius_mm: 4.0,
                thickness_fallback: moldgate::gate::ThicknessFallback::LargestFitting,
                flat_tolerance_mm,
                ..LocateOptions::default()
            },
        )
        .unwrap();
        assert!(a.radius_fit.as_ref().is_some_and(|f| f.accepted));
        (a.options.gate_radius_mm, a.flat_tolerance_mm)
    };
    let (r, tolerance) = fitted(None);
    assert!(r < 3.0, "{r}");
    assert_eq!(tolerance, 0.1 * r);
    // A tolerance given stays.
    assert_eq!(fitted(Some(0.05)).1, 0.05);
}
