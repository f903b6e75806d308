//! Inputs the fuzz targets (`fuzz/`) found to hang or exhaust memory, each reduced to the
//! smallest case and named after what broke; and the replay of the fuzz targets' seeds, of
//! seeded mutants of them and of any corpus a campaign kept, through the targets' own code
//! (`fuzz/src/lib.rs`). Each runs on a thread with a deadline, so a regression fails instead
//! of hanging the test run.

use std::sync::mpsc;
use std::time::Duration;

use moldgate::flow::voxel::Voxels;
use moldgate::math::DVec3;
use moldgate::mesh::{read_ply, Units};
use moldgate::Mesh;

use crate::common::SplitMix;

/// The fuzz targets' bodies: the functions `fuzz/fuzz_targets/*.rs` hand to libFuzzer.
#[path = "../../../../fuzz/src/lib.rs"]
mod targets;

/// The seed corpus that `scripts/fuzz.sh` starts libFuzzer from.
#[allow(dead_code)]
#[path = "../../examples/fuzz_seeds.rs"]
mod fuzz_seeds;

fn within<T: Send + 'static>(seconds: u64, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(seconds))
        .unwrap_or_else(|_| panic!("still running after {seconds} s"))
}

/// `read_ply`: a binary element with no property and a count of 10^15 takes no bytes, and
/// the reader counted through every instance of it (found by `read_ply`).
#[test]
fn binary_ply_element_without_properties_and_a_huge_count_ends_at_once() {
    let file = b"ply\nformat binary_big_endian 1.0\nelement ex 333333333333333\n\
element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let mut bytes = file.to_vec();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            bytes.extend_from_slice(&c.to_be_bytes());
        }
    }
    bytes.push(3);
    for i in [0i32, 1, 2] {
        bytes.extend_from_slice(&i.to_be_bytes());
    }
    let part = within(10, move || read_ply(&bytes[..], Units::Mm)).unwrap();
    assert_eq!(part.mesh.triangles.len(), 1);
}

/// `Voxels::new`: a long sliver (1000 mm by 1 µm) at a cell of 0.05 mm was sampled on a
/// lattice of n^2 / 2 = 8 * 10^8 points for its 20 000 cells, many GB of marks (found by
/// `analyse` on a mutated STL whose cells the limit kept small).
#[test]
fn voxels_of_a_long_sliver_are_sampled_in_rows_not_a_lattice() {
    let mesh = Mesh {
        vertices: vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1000.0, 0.0, 0.0),
            DVec3::new(500.0, 0.001, 0.0),
        ],
        triangles: vec![[0, 1, 2]],
    };
    let voxels = within(20, move || Voxels::new(&mesh, 0.05));
    // Every cell along the sliver is a surface cell.
    let surface = voxels.surface.iter().filter(|&&s| s).count();
    assert!(
        (20_000..=20_002).contains(&surface),
        "{surface} surface cells along 1000 mm at 0.05 mm"
    );
}

/// libFuzzer's limit per input in `scripts/fuzz.sh` (`-timeout=20`).
const INPUT_SECONDS: u64 = 20;

/// The target named `target` (a folder name under `fuzz/corpus/`).
fn target(name: &str) -> fn(&[u8]) {
    match name {
        "read_stl" => targets::read_stl,
        "read_obj" => targets::read_obj,
        "read_ply" => targets::read_ply,
        "analyse" => targets::analyse,
        _ => unreachable!("no fuzz target {name}"),
    }
}

/// Runs `target` on `data` on a thread: a panic or an input still running after libFuzzer's
/// limit fails, naming the input.
fn replay(target_name: &'static str, what: &str, data: Vec<u8>) {
    let run = target(target_name);
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        run(&data);
        let _ = tx.send(());
    });
    match rx.recv_timeout(Duration::from_secs(INPUT_SECONDS)) {
        Ok(()) => {}
        Err(mpsc::RecvTimeoutError::Disconnected) => panic!("{target_name} panicked on {what}"),
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("{target_name} still running after {INPUT_SECONDS} s on {what}")
        }
    }
}

/// Every seed through its target: the known inputs that the fuzz smoke run started from,
/// replayed without libFuzzer (74 inputs, each of the four targets).
#[test]
fn every_seed_runs_through_its_fuzz_target() {
    let seeds = fuzz_seeds::seeds();
    for name in ["read_stl", "read_obj", "read_ply", "analyse"] {
        let count = seeds.iter().filter(|(t, _, _)| *t == name).count();
        assert!(count >= 10, "{count} seeds for {name}");
    }
    for (target_name, file, bytes) in seeds {
        replay(target_name, &format!("seed {file}"), bytes);
    }
}

/// Seeded mutants of every seed (bytes overwritten, a run cut out, a run repeated, the end
/// cut off) through its target: 64 of each reader seed, 4 of each `analyse` seed. A failure
/// names the seed and the mutant's number, and replays with the same numbers.
#[test]
fn mutants_of_the_seeds_never_panic_a_fuzz_target() {
    let mut rng = SplitMix(0x6d6f_6c64_6761_7465);
    let mut runs = 0;
    for (target_name, file, bytes) in fuzz_seeds::seeds() {
        let (mutants, head) = if target_name == "analyse" {
            (4, 4)
        } else {
            (64, 0)
        };
        for m in 0..mutants {
            let mut data = bytes.clone();
            for _ in 0..1 + rng.next() % 4 {
                let len = data.len() - head;
                if len == 0 {
                    break;
                }
                let at = head + (rng.next() as usize) % len;
                let run = 1 + (rng.next() as usize) % 16.min(data.len() - at);
                match rng.next() % 4 {
                    0 => data[at] = rng.next() as u8,
                    1 => drop(data.drain(at..at + run)),
                    2 => {
                        let copy = data[at..at + run].to_vec();
                        data.splice(at..at, copy);
                    }
                    _ => data.truncate(at),
                }
            }
            replay(target_name, &format!("mutant {m} of seed {file}"), data);
            runs += 1;
        }
    }
    eprintln!("{runs} mutants replayed");
}

/// What a campaign kept (`fuzz/corpus/TARGET`, and the crashes in `fuzz/artifacts/TARGET`),
/// through its target, where `scripts/fuzz.sh` has run on this machine; neither folder is
/// committed, so elsewhere this says so and checks nothing.
#[test]
fn a_kept_fuzz_corpus_replays_without_a_panic() {
    let fuzz = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    let mut replayed = 0;
    for name in ["read_stl", "read_obj", "read_ply", "analyse"] {
        for folder in ["corpus", "artifacts"] {
            let Ok(entries) = std::fs::read_dir(fuzz.join(folder).join(name)) else {
                continue;
            };
            let mut paths: Vec<_> = entries.filter_map(|e| e.ok()).map(|e| e.path()).collect();
            paths.sort();
            for path in paths {
                let file = path.file_name().unwrap_or_default().to_string_lossy();
                // Slow inputs and memory limits depend on the fuzzing build; crashes do not.
                if folder == "artifacts" && !file.starts_with("crash-") {
                    continue;
                }
                let Ok(bytes) = std::fs::read(&path) else {
                    continue;
                };
                replay(name, &path.display().to_string(), bytes);
                replayed += 1;
            }
        }
    }
    if replayed == 0 {
        eprintln!("no kept fuzz corpus in fuzz/corpus or fuzz/artifacts: nothing replayed");
    } else {
        eprintln!("{replayed} kept fuzz inputs replayed");
    }
}
