//! The gate-suitability map against brute force (a march from every qualifying node), for
//! docs/suitability.md: `suitability_gap [PART.stl DEMOLD [UNITS]]...`, or no arguments for
//! the samples; `SPACING=mm` and `CELL=mm` set the grid and the cells. Prints, per part, the
//! nodes, the marches of the map against the brute
//! force's, how many scores are exact, the relative gap (truth - score) / truth (max and
//! median over the nodes), the certified gap (upper - score) / score, and whether every
//! bound holds to the tolerance.
use std::time::Instant;

use moldgate::flow::{self, Bodies, FlowOptions, Objective, Source, Voxels};
use moldgate::mesh::units::Units;
use moldgate::StudyOptions;
use rayon::prelude::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut parts: Vec<(String, moldgate::LoadedMesh, String)> = Vec::new();
    if args.is_empty() {
        for s in moldgate::samples::SAMPLES {
            let mesh = moldgate::samples::sample(s.name).unwrap();
            parts.push((
                s.name.to_string(),
                moldgate::mesh::from_generated(mesh),
                "+z".into(),
            ));
        }
    }
    let mut i = 0;
    while i + 1 < args.len() {
        let path = &args[i];
        let demold = args[i + 1].clone();
        let units: Units = args
            .get(i + 2)
            .filter(|u| !u.contains('.') && !u.starts_with(['+', '-']))
            .map_or("mm", |s| s.as_str())
            .parse()
            .unwrap_or(Units::Mm);
        i += if args.get(i + 2).is_some_and(|u| u.parse::<Units>().is_ok()) {
            3
        } else {
            2
        };
        let file = std::fs::File::open(path).unwrap();
        let len = file.metadata().unwrap().len();
        let part = moldgate::mesh::read_stl(std::io::BufReader::new(file), len, units).unwrap();
        let name = path.rsplit('/').next().unwrap().to_string();
        parts.push((name, part, demold));
    }
    println!(
        "| part | objective | nodes (cells) | map marches | brute marches | exact | gap max % | gap median % | certified max % | certified median % | bounds hold | best vs brute best (mm) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, part, demold) in &parts {
        for objective in ["length"] {
            let mut json = serde_json::json!({
                "demold": demold, "suitability": true, "objective": objective
            });
            // SPACING and CELL (mm) coarsen the grid and the cells, so the brute force
            // stays affordable.
            for (var, key) in [("SPACING", "spacing"), ("CELL", "cell")] {
                if let Some(x) = std::env::var(var).ok().and_then(|s| s.parse::<f64>().ok()) {
                    json[key] = x.into();
                }
            }
            let options: StudyOptions = serde_json::from_value(json).unwrap();
            let Ok(study) = moldgate::study(part, &options) else {
                println!("| {name} | {objective} | no study | | | | | | | | | |");
                continue;
            };
            let Some(fill) = study.fill() else {
                println!("| {name} | {objective} | no fill | | | | | | | | | |");
                continue;
            };
            let map = fill.suitability.as_ref().unwrap();
            // The same cells as the study's.
            let bodies = Bodies::of(&part.mesh);
            let voxels = Voxels::bounded(
                &part.mesh,
                fill.cell_mm,
                &bodies.of_triangle,
                &FlowOptions::default(),
            )
            .unwrap();
            assert_eq!(voxels.len(), fill.cells);
            let cell_of: Vec<u32> = map
                .nodes
                .iter()
                .map(|n| {
                    voxels
                        .cell_near(moldgate::math::DVec3::from_array(n.point))
                        .unwrap()
                })
                .collect();
            let mut unique = cell_of.clone();
            unique.sort_unstable();
            unique.dedup();
            let t = Instant::now();
            let truth: Vec<f64> = unique
                .par_iter()
                .map(|&c| {
                    let s = Source {
                        point: voxels.centre(c),
                        cell: c,
                    };
                    flow::argmax(&flow::march(&voxels, &[s], None).t).1
                })
                .collect();
            let brute_s = t.elapsed().as_secs_f64();
            let tol = map.tolerance;
            let mut gaps = Vec::new();
            let mut certified = Vec::new();
            let mut hold = true;
            for (n, &c) in map.nodes.iter().zip(&cell_of) {
                let e = truth[unique.binary_search(&c).unwrap()];
                gaps.push(100.0 * (e - n.score) / e);
                if let Some(u) = n.upper {
                    certified.push(100.0 * (u - n.score) / n.score.max(1e-12));
                    hold &= u >= e - tol;
                }
                hold &= n.score <= e + tol;
            }
            let stats = |v: &mut Vec<f64>| {
                v.sort_by(f64::total_cmp);
                (
                    v.last().copied().unwrap_or(0.0),
                    v.get(v.len() / 2).copied().unwrap_or(0.0),
                )
            };
            let (gmax, gmed) = stats(&mut gaps);
            let (cmax, cmed) = stats(&mut certified);
            let brute_best = truth.iter().copied().fold(f64::INFINITY, f64::min);
            let best = map.best.map_or(f64::NAN, |b| {
                truth[unique.binary_search(&cell_of[b]).unwrap()]
            });
            let _ = Objective::Length;
            println!(
                "| {name} | {objective} | {} ({}) | {} | {} ({brute_s:.1} s) | {} | {gmax:.2} | {gmed:.2} | {cmax:.1} | {cmed:.1} | {} | {:+.3} (tol {tol:.3}) |",
                map.nodes.len(),
                unique.len(),
                map.runs,
                unique.len(),
                map.exact,
                if hold { "yes" } else { "NO" },
                best - brute_best,
            );
        }
    }
}
