//! The bodies of the fuzz targets (`fuzz_targets/`), one function each: arbitrary bytes in,
//! an error or a result out, never a panic. The same functions replay the seeds and any kept
//! corpus in the library's tests (`crates/moldgate/tests/it/fuzz_regressions.rs`, through a
//! `#[path]` module), so what the fuzzer runs and what the tests replay cannot drift apart.

use moldgate::flow::{self, FillOptions, FlowOptions, Objective, Strategy, Walls};
use moldgate::math::DVec3;
use moldgate::mesh::Units;
use moldgate::raycast::Bvh;
use moldgate::report::{Input, RadiusSource, Report};
use moldgate::{locate, Direction, LocateOptions, Material};

/// The STL reader, with the true length and with a length that disagrees with the bytes (a
/// file that changed while read).
pub fn read_stl(data: &[u8]) {
    let _ = moldgate::mesh::read_stl(data, data.len() as u64, Units::Mm);
    let _ = moldgate::mesh::read_stl(data, (data.len() as u64).wrapping_add(50), Units::Mm);
}

/// The OBJ reader.
pub fn read_obj(data: &[u8]) {
    let _ = moldgate::mesh::read_obj(data, Units::Mm);
}

/// The PLY reader.
pub fn read_ply(data: &[u8]) {
    let _ = moldgate::mesh::read_ply(data, Units::Mm);
}

/// Demolding directions the second byte picks from: the axes both ways and two obliques.
const DIRECTIONS: [[f64; 3]; 8] = [
    [0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0],
    [1.0, 0.0, 0.0],
    [-1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, -1.0, 0.0],
    [1.0, 1.0, 1.0],
    [0.3, -0.2, 0.9],
];

/// A whole analysis of a small part: the first byte picks the reader and the next three the
/// options; `locate` with a small grid, the fill analysis with a small voxel grid, then the
/// report as JSON.
pub fn analyse(data: &[u8]) {
    let [kind, dir, circle, fill, file @ ..] = data else {
        return;
    };
    let loaded = match kind % 3 {
        0 => moldgate::mesh::read_stl(file, file.len() as u64, Units::Mm),
        1 => moldgate::mesh::read_obj(file, Units::Mm),
        _ => moldgate::mesh::read_ply(file, Units::Mm),
    };
    let Ok(part) = loaded else { return };
    let Ok(direction) = Direction::new(DVec3::from_array(DIRECTIONS[usize::from(dir % 8)])) else {
        return;
    };
    let material = Material::builtin("ABS").expect("ABS is built in");
    let options = LocateOptions {
        direction,
        gate_radius_mm: material.gate_radius_mm(),
        circle_points: usize::from(circle % 20),
        max_nodes: 2_000,
        ..LocateOptions::default()
    };
    let Ok(analysis) = locate(&part, &options) else {
        return;
    };
    let mut report = Report::new(
        Input {
            path: None,
            sample: Some("fuzz".into()),
            bytes: file.len() as u64,
        },
        &part.stats,
        &part.warnings,
        &material,
        RadiusSource::Material,
        &analysis,
        0.0,
    );
    if analysis.gate().is_ok() {
        let fill_options = FillOptions {
            flow: FlowOptions {
                cell_mm: None,
                max_cells: 20_000.0,
                ..FlowOptions::default()
            },
            strategy: if fill & 1 == 0 {
                Strategy::Paper
            } else {
                Strategy::Balanced
            },
            objective: if fill & 2 == 0 {
                Objective::Length
            } else {
                Objective::Resistance
            },
            gates: 1 + usize::from((fill >> 2) % 3),
            colour_by: Default::default(),
            placed: Vec::new(),
            suitability: false,
        };
        let bvh = Bvh::new(&part.mesh);
        let walls = if fill & 32 == 0 {
            Walls::Measure(&bvh)
        } else {
            Walls::Estimate
        };
        if let Ok(f) = flow::analyse(&part.mesh, &analysis, &material, walls, &fill_options) {
            report = report.with_fill(f, analysis.centre);
        }
    }
    let _ = serde_json::to_string(&report).expect("a report always encodes");
}
