//! The parting line, the automatic demolding direction and the largest fitting gate radius
//! on the built-in samples and on the shared real parts.
//!
//! The parts are looked for at `$MOLDGATE_PARTS`, else at `<workspace>/../shared/data/parts`;
//! a test whose parts are missing says so and passes without checking anything. Run with
//! `--nocapture` for the per-part tables.

use crate::common::outline;

use std::fs::File;
use std::io::BufReader;
use std::path::PathBuf;

use moldgate::gate::{ThicknessFallback, ThicknessRule};
use moldgate::mesh::{self, LoadedMesh, Units};
use moldgate::raycast::{Bvh, Sampling};
use moldgate::undercut::auto_direction_with;
use moldgate::{locate, Direction, Frame, LocateOptions, Material};

/// The shared parts with their natural demolding direction (`SOURCES.md`).
const PARTS: [(&str, &str); 18] = [
    ("comma2_injection_molded_mount.stl", "+x"),
    ("comma_ram_connector_cap.stl", "-z"),
    ("deskhop_case_bottom.stl", "+z"),
    ("esp32s3box_bottom_housing_352k.stl", "+y"),
    ("esp32s3box_top_housing.stl", "-y"),
    ("framework_desktop_blank_tile.stl", "-z"),
    ("framework_desktop_top_cover_121k.stl", "-x"),
    ("framework_expansion_card_shell.stl", "+y"),
    ("prusa_heatbed_cable_cover_clip_ascii.stl", "+z"),
    ("prusa_lcd_knob.stl", "+z"),
    ("prusa_psu_cover_mk3_ascii.stl", "+z"),
    ("prusa_raspberry_cover_ascii_open.stl", "+z"),
    ("sc64_shell_back.stl", "-z"),
    ("screwcap_oralb_75ml_ascii.stl", "+z"),
    ("trimesh_ADIS16480_meters_ascii.STL", "+y"),
    ("trimesh_featuretype_inches.STL", "+z"),
    ("watchy_yatari_bottom.stl", "-z"),
    ("watchy_yatari_top.stl", "+z"),
];

fn parts_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("MOLDGATE_PARTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/parts")
        });
    dir.is_dir().then_some(dir)
}

fn skip(test: &str) {
    let why = "the shared parts are absent (set MOLDGATE_PARTS)";
    eprintln!("{test}: skipped: {why}");
    println!("{test}: skipped: {why}");
}

fn load(file: &str) -> LoadedMesh {
    let path = parts_dir().unwrap().join(file);
    let units = if file.contains("meters") {
        Units::M
    } else if file.contains("inches") {
        Units::In
    } else {
        Units::Mm
    };
    let f = File::open(&path).unwrap();
    let len = f.metadata().unwrap().len();
    mesh::read_stl(BufReader::new(f), len, units).unwrap()
}

fn dir(s: &str) -> Direction {
    s.parse().unwrap()
}

/// Parting length against the outline perimeter: (length, perimeter, loops closed).
fn parting_vs_outline(part: &LoadedMesh, d: Direction, cells: usize) -> (f64, f64, bool) {
    let a = locate(
        part,
        &LocateOptions {
            direction: d,
            parting: moldgate::gate::PartingRule::Outline,
            ..LocateOptions::default()
        },
    )
    .unwrap();
    let perimeter = outline::outline_perimeter(&part.mesh, &Frame::new(d), cells);
    (a.parting.length_mm, perimeter, a.parting.closed)
}

#[test]
fn parting_line_is_the_outline_on_the_samples() {
    for (name, d) in [
        ("cover", "+z"),
        ("cover", "-z"),
        ("plate", "+z"),
        ("tray", "-z"),
        ("cap", "+z"),
        ("bracket", "+z"),
    ] {
        let part = mesh::from_generated(moldgate::samples::sample(name).unwrap());
        let (length, perimeter, closed) = parting_vs_outline(&part, dir(d), 600);
        println!("{name} {d}: parting {length:.2} mm, outline {perimeter:.2} mm, closed {closed}");
        assert!(closed, "{name} {d}");
        assert!(
            (length - perimeter).abs() < 0.005 * perimeter,
            "{name} {d}: {length} vs {perimeter}"
        );
    }
}

/// Parts whose parting line is not yet within 5 % of their outline's perimeter, with the
/// ratio measured when they were listed (docs/parting-line.md): where the outline steps along
/// D through walls whose own edges do not separate the two sides, the bridges between the
/// chain ends either close the loop short of the outline (the knob, 0.56: its rim circle is
/// closed across the three tabs) or join chains that also run along features seen edge-on
/// (the others, 1.08 to 2.3, and then often left open).
const NOT_THE_RIM: &[&str] = &[
    "esp32s3box_top_housing.stl",         // 1.99, open
    "esp32s3box_bottom_housing_352k.stl", // 2.31, open
    "watchy_yatari_bottom.stl",           // 1.08, closed
    "watchy_yatari_top.stl",              // 1.09, closed
    "framework_expansion_card_shell.stl", // 1.46, open
    "sc64_shell_back.stl",                // 1.59, open
    "prusa_psu_cover_mk3_ascii.stl",      // 1.11, box open, lid closed
    "prusa_lcd_knob.stl",                 // 0.56, closed
    "comma_ram_connector_cap.stl",        // 1.76, open
    "comma2_injection_molded_mount.stl",  // 1.98, open
];

#[test]
fn parting_line_is_the_outline_on_the_shared_parts() {
    let test = "parting_line_is_the_outline_on_the_shared_parts";
    if parts_dir().is_none() {
        return skip(test);
    }
    let mut failures = Vec::new();
    for (file, d) in PARTS {
        let part = load(file);
        let (length, perimeter, closed) = parting_vs_outline(&part, dir(d), 1500);
        let ratio = length / perimeter;
        println!("{file} {d}: parting {length:.1} mm, outline {perimeter:.1} mm, ratio {ratio:.3}, closed {closed}");
        if !NOT_THE_RIM.contains(&file) && (ratio - 1.0).abs() > 0.05 {
            failures.push(format!(
                "{file}: parting {length:.1} vs outline {perimeter:.1}"
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn aesthetic_gate_lands_on_the_rim_of_the_knob() {
    let test = "aesthetic_gate_lands_on_the_rim_of_the_knob";
    if parts_dir().is_none() {
        return skip(test);
    }
    let part = load("prusa_lcd_knob.stl");
    let options = LocateOptions {
        direction: dir("+z"),
        mode: moldgate::GateMode::Aesthetic,
        // The outline rule (the default is still the longest loop, see parting.rs).
        parting: moldgate::gate::PartingRule::Outline,
        ..LocateOptions::default()
    };
    let a = locate(&part, &options).unwrap();
    let g = a.gate().unwrap().point();
    // On the outline: a point just outside it in the plane has no part beneath it.
    let frame = a.frame;
    let q = frame.project(g);
    let c = frame.project(a.centre);
    let out = q + (q - c).normalize() * 0.05;
    let bvh = Bvh::new(&part.mesh);
    let hit = |p: moldgate::math::DVec2| {
        let origin = frame.point(p, 1e3);
        bvh.any_hit(&moldgate::raycast::Ray::new(origin, -frame.d))
    };
    assert!(
        hit(q - (q - c).normalize() * 0.05),
        "inside the outline the part is there"
    );
    assert!(!hit(out), "just outside the gate there is no part: {g:?}");
}

#[test]
fn flat_tile_opens_along_its_thickness() {
    let test = "flat_tile_opens_along_its_thickness";
    if parts_dir().is_none() {
        return skip(test);
    }
    let part = load("framework_desktop_blank_tile.stl");
    let auto = auto_direction_with(&part.mesh, &Bvh::new(&part.mesh), Sampling::Centroid).unwrap();
    assert_eq!(auto.candidate().direction, [0.0, 0.0, -1.0], "{auto:#?}");
}

#[test]
fn demold_auto_is_bit_identical_on_1_2_3_and_8_threads() {
    let test = "demold_auto_is_bit_identical_on_1_2_3_and_8_threads";
    if parts_dir().is_none() {
        return skip(test);
    }
    let part = load("prusa_lcd_knob.stl");
    let bvh = Bvh::new(&part.mesh);
    let runs: Vec<Vec<u64>> = [1, 2, 3, 8]
        .iter()
        .map(|&n| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            let auto = pool.install(|| auto_direction_with(&part.mesh, &bvh, Sampling::Centroid));
            auto.unwrap()
                .tried
                .iter()
                .flat_map(|c| [c.undercut.area_mm2.to_bits(), c.undercut.share.to_bits()])
                .collect()
        })
        .collect();
    for r in &runs {
        assert_eq!(r, &runs[0]);
    }
}

#[test]
fn abs_gate_that_the_thickness_rule_refuses_gets_the_largest_fitting_radius() {
    let test = "abs_gate_that_the_thickness_rule_refuses_gets_the_largest_fitting_radius";
    if parts_dir().is_none() {
        return skip(test);
    }
    // The raspberry cover is a 1 mm vented plate: ABS's 1.915 mm gate has no wall under it.
    let part = load("prusa_raspberry_cover_ascii_open.stl");
    let r = Material::builtin("ABS").unwrap().gate_radius_mm();
    let options = LocateOptions {
        direction: dir("+z"),
        gate_radius_mm: r,
        ..LocateOptions::default()
    };
    let a = locate(&part, &options).unwrap();
    assert!(a.grid_gate.is_none());
    let fit = a.radius_fit.clone().unwrap();
    let r_fit = fit.radius_mm.expect("a smaller gate fits");
    let gate = fit.gate.unwrap();
    println!(
        "R {r:.3} refused; fits {r_fit:.4} mm at {:?}, wall {:?}, {} probes",
        gate.point, gate.disc_thickness_mm, fit.probes
    );
    assert!(r_fit < r && fit.probes <= 1 + moldgate::gate::FIT_STEPS);
    // The rule holds at the radius found: the wall under the disc is thicker than it.
    assert!(gate.disc_thickness_mm.is_none_or(|t| t > r_fit), "{gate:?}");
    // And a radius a search step above it does not fit (the bisection's bracket).
    let step = (r - fit.floor_mm) / (1u32 << moldgate::gate::FIT_STEPS) as f64;
    let above = locate(
        &part,
        &LocateOptions {
            gate_radius_mm: r_fit + step,
            spacing: moldgate::gate::Spacing::Mm(a.grid.spacing),
            ..options.clone()
        },
    )
    .unwrap();
    assert!(above.grid_gate.is_none() && above.radius_fit.is_some());
    let reason = a.gate().unwrap_err().to_string();
    assert!(reason.contains("walls thicker than 1.915 mm"), "{reason}");
    assert!(reason.contains(&format!("{r_fit:.3} mm")), "{reason}");
    // Accepting it makes that gate the answer, and the refusal is still said.
    let taken = locate(
        &part,
        &LocateOptions {
            thickness_fallback: ThicknessFallback::LargestFitting,
            ..options.clone()
        },
    )
    .unwrap();
    assert_eq!(taken.gate().unwrap().point(), gate.point);
    assert!(taken.radius_fit.unwrap().accepted);
    assert!(
        taken.warnings.iter().any(|w| w.contains("1.915 mm")),
        "{:?}",
        taken.warnings
    );
    // With the rule off there is no search.
    let off = locate(
        &part,
        &LocateOptions {
            thickness_rule: ThicknessRule::Ignore,
            ..options
        },
    )
    .unwrap();
    assert!(off.radius_fit.is_none());
}
