//! Times the fill analysis stages on one part: `flow_time PART.stl DEMOLD [UNITS] [CELL_MM]`.
use std::time::Instant;

use moldgate::flow::{self, Domain};
use moldgate::{locate, LocateOptions, Material};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 3 {
        eprintln!("usage: flow_time PART.stl DEMOLD [UNITS] [CELL_MM]");
        std::process::exit(2);
    }
    let units = args.get(3).map_or("mm", |s| s.as_str()).parse().unwrap();
    let file = std::fs::File::open(&args[1]).unwrap();
    let len = file.metadata().unwrap().len();
    let part = moldgate::mesh::read_stl(std::io::BufReader::new(file), len, units).unwrap();
    let options = LocateOptions {
        direction: args[2].parse().unwrap(),
        ..LocateOptions::default()
    };
    let analysis = locate(&part, &options).unwrap();
    let pp = Material::builtin("PP").unwrap();
    let c = moldgate::Centres::of(&part.mesh);
    let nominal = if c.volume_mm3 > 0.0 {
        2.0 * c.volume_mm3 / c.area_mm2
    } else {
        1.0
    };
    let h = args.get(4).map_or_else(
        || {
            flow::cell_size(&part.mesh, nominal, &flow::FlowOptions::default())
                .expect("a cell size within the limits")
                .0
        },
        |s| s.parse().unwrap(),
    );
    let t = Instant::now();
    let domain = Domain::new(&part.mesh, h, None, nominal, &pp);
    println!(
        "h {h:.3} mm, nominal wall {nominal:.3}, dims {:?}, solid cells {}, bodies {}: voxels {:.1} ms",
        domain.voxels.dims,
        domain.voxels.len(),
        domain.bodies,
        t.elapsed().as_secs_f64() * 1e3
    );
    let gate = analysis.gate().unwrap().point();
    let t = Instant::now();
    let src = domain.source(gate).unwrap();
    let f = flow::march(&domain.voxels, &[src], None);
    println!(
        "one march {:.1} ms, L_max {:.2}",
        t.elapsed().as_secs_f64() * 1e3,
        flow::argmax(&f.t).1
    );
    let t = Instant::now();
    let (fill, _) = flow::fill_from(&domain, gate, &pp).unwrap();
    println!(
        "fill_from {:.1} ms: {:?}",
        t.elapsed().as_secs_f64() * 1e3,
        fill
    );
}
