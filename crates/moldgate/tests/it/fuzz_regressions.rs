//! Inputs the fuzz targets (`fuzz/`) found to hang or exhaust memory, each reduced to the
//! smallest case and named after what broke. Each runs on a thread with a deadline, so a
//! regression fails instead of hanging the test run.

use std::sync::mpsc;
use std::time::Duration;

use moldgate::flow::voxel::Voxels;
use moldgate::math::DVec3;
use moldgate::mesh::{read_ply, Units};
use moldgate::Mesh;

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
