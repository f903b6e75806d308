//! Sample parts made by moldgate's own code, in millimetres: closed, outward-facing,
//! single-body meshes whose geometry is known exactly, for first runs, tests and benchmarks.
//!
//! Three builders make them:
//! - [`BoxUnion`]: unions and differences of axis-aligned boxes, meshed as the boundary of
//!   the cells of the grid formed by all box planes (no T-junctions, so always watertight);
//! - a lathe that turns an (r, z) profile about the z axis (the round cap);
//! - an extruder for a rectangle with a round hole (the plate).

use rustc_hash::FxHashMap;

use crate::math::DVec3;
use crate::mesh::Mesh;

/// A sample part's name and what it is.
#[derive(Debug, Clone, Copy)]
pub struct SampleInfo {
    /// The name used on the command line.
    pub name: &'static str,
    /// One line saying what the part is, with its sizes.
    pub description: &'static str,
}

/// Every sample part.
pub const SAMPLES: &[SampleInfo] = &[
    SampleInfo {
        name: "plate",
        description: "flat plate 100 x 60 x 3 mm with a 16 mm hole centred at (20, 0)",
    },
    SampleInfo {
        name: "cover",
        description:
            "open box 120 x 80 x 30 mm, walls 2 mm, open to -z, two ribs and four hollow bosses",
    },
    SampleInfo {
        name: "cap",
        description: "round cap, radius 20 mm, height 15 mm, wall 1.6 mm, open to -z",
    },
    SampleInfo {
        name: "tray",
        description: "tray 80 x 60 x 20 mm with a 70 x 50 x 16 mm pocket open to +z",
    },
    SampleInfo {
        name: "bracket",
        description: "L-bracket: base 60 x 40 x 5 mm and upright 5 x 40 x 50 mm",
    },
];

/// The sample part called `name`, or `None` for an unknown name.
pub fn sample(name: &str) -> Option<Mesh> {
    match name {
        "plate" => Some(plate_with_hole(
            [-50.0, 50.0],
            [-30.0, 30.0],
            3.0,
            [20.0, 0.0],
            8.0,
            64,
        )),
        "cover" => Some(cover()),
        "cap" => Some(lathe(
            &[
                (0.0, 15.0),
                (20.0, 15.0),
                (20.0, 0.0),
                (18.4, 0.0),
                (18.4, 13.4),
                (0.0, 13.4),
            ],
            96,
        )),
        "tray" => {
            let mut part = BoxUnion::default();
            part.add([-40.0, -30.0, 0.0], [40.0, 30.0, 20.0]);
            part.subtract([-35.0, -25.0, 4.0], [35.0, 25.0, 20.0]);
            Some(part.mesh())
        }
        "bracket" => {
            let mut part = BoxUnion::default();
            part.add([0.0, 0.0, 0.0], [60.0, 40.0, 5.0]);
            part.add([0.0, 0.0, 0.0], [5.0, 40.0, 50.0]);
            Some(part.mesh())
        }
        _ => None,
    }
}

fn cover() -> Mesh {
    let mut part = BoxUnion::default();
    part.add([-60.0, -40.0, 0.0], [60.0, 40.0, 30.0]);
    part.subtract([-58.0, -38.0, 0.0], [58.0, 38.0, 28.0]);
    // Ribs under the top, 2 mm thick and 10 mm deep, crossing at the centre.
    part.add([-58.0, -1.0, 18.0], [58.0, 1.0, 28.0]);
    part.add([-1.0, -38.0, 18.0], [1.0, 38.0, 28.0]);
    // Four square bosses, 8 mm across, 20 mm deep, with 3 mm blind holes from below.
    for (x, y) in [(-40.0, -20.0), (40.0, -20.0), (-40.0, 20.0), (40.0, 20.0)] {
        part.add([x - 4.0, y - 4.0, 8.0], [x + 4.0, y + 4.0, 28.0]);
        part.subtract([x - 1.5, y - 1.5, 8.0], [x + 1.5, y + 1.5, 26.0]);
    }
    part.mesh()
}

/// A solid made by adding and subtracting axis-aligned boxes, in order.
#[derive(Debug, Default, Clone)]
pub struct BoxUnion {
    steps: Vec<(bool, [f64; 3], [f64; 3])>,
}

impl BoxUnion {
    /// Adds the box from `min` to `max` to the solid.
    pub fn add(&mut self, min: [f64; 3], max: [f64; 3]) {
        self.steps.push((true, min, max));
    }

    /// Removes the box from `min` to `max` from the solid.
    pub fn subtract(&mut self, min: [f64; 3], max: [f64; 3]) {
        self.steps.push((false, min, max));
    }

    /// Meshes the boundary of the solid: every face between a filled and an empty cell of
    /// the grid of box planes, as two triangles facing the empty cell.
    pub fn mesh(&self) -> Mesh {
        let planes: [Vec<f64>; 3] = std::array::from_fn(|axis| {
            let mut p: Vec<f64> = self
                .steps
                .iter()
                .flat_map(|(_, lo, hi)| [lo[axis], hi[axis]])
                .collect();
            p.sort_by(f64::total_cmp);
            p.dedup();
            p
        });
        let cells = [
            planes[0].len() - 1,
            planes[1].len() - 1,
            planes[2].len() - 1,
        ];
        let filled = |i: isize, j: isize, k: isize| -> bool {
            let idx = [i, j, k];
            if (0..3).any(|a| idx[a] < 0 || idx[a] >= cells[a] as isize) {
                return false;
            }
            let centre: [f64; 3] = std::array::from_fn(|a| {
                0.5 * (planes[a][idx[a] as usize] + planes[a][idx[a] as usize + 1])
            });
            let mut inside = false;
            for (add, lo, hi) in &self.steps {
                if (0..3).all(|a| lo[a] < centre[a] && centre[a] < hi[a]) {
                    inside = *add;
                }
            }
            inside
        };
        let mut builder = MeshBuilder::default();
        let corner = |g: [usize; 3]| DVec3::new(planes[0][g[0]], planes[1][g[1]], planes[2][g[2]]);
        for i in 0..cells[0] {
            for j in 0..cells[1] {
                for k in 0..cells[2] {
                    let (ii, jj, kk) = (i as isize, j as isize, k as isize);
                    if !filled(ii, jj, kk) {
                        continue;
                    }
                    // For each of the six neighbours, a face when it is empty. The quad's
                    // corners are listed counter-clockwise seen from outside.
                    let faces: [([isize; 3], [[usize; 3]; 4]); 6] = [
                        (
                            [-1, 0, 0],
                            [[i, j, k], [i, j, k + 1], [i, j + 1, k + 1], [i, j + 1, k]],
                        ),
                        (
                            [1, 0, 0],
                            [
                                [i + 1, j, k],
                                [i + 1, j + 1, k],
                                [i + 1, j + 1, k + 1],
                                [i + 1, j, k + 1],
                            ],
                        ),
                        (
                            [0, -1, 0],
                            [[i, j, k], [i + 1, j, k], [i + 1, j, k + 1], [i, j, k + 1]],
                        ),
                        (
                            [0, 1, 0],
                            [
                                [i, j + 1, k],
                                [i, j + 1, k + 1],
                                [i + 1, j + 1, k + 1],
                                [i + 1, j + 1, k],
                            ],
                        ),
                        (
                            [0, 0, -1],
                            [[i, j, k], [i, j + 1, k], [i + 1, j + 1, k], [i + 1, j, k]],
                        ),
                        (
                            [0, 0, 1],
                            [
                                [i, j, k + 1],
                                [i + 1, j, k + 1],
                                [i + 1, j + 1, k + 1],
                                [i, j + 1, k + 1],
                            ],
                        ),
                    ];
                    for (d, quad) in faces {
                        if !filled(ii + d[0], jj + d[1], kk + d[2]) {
                            builder.quad(quad.map(corner));
                        }
                    }
                }
            }
        }
        builder.mesh
    }
}

/// Turns the closed (r, z) profile about the z axis in `segments` steps. The profile is
/// listed so that the solid lies to its left going from point to point in the (r, z) plane
/// seen with r to the right and z up (clockwise around the section); points with r = 0 lie
/// on the axis.
fn lathe(profile: &[(f64, f64)], segments: usize) -> Mesh {
    let mut builder = MeshBuilder::default();
    let at = |(r, z): (f64, f64), s: usize| {
        let a = std::f64::consts::TAU * (s % segments) as f64 / segments as f64;
        DVec3::new(r * a.cos(), r * a.sin(), z)
    };
    for e in 0..profile.len() {
        let p = profile[e];
        let q = profile[(e + 1) % profile.len()];
        if p.0 == 0.0 && q.0 == 0.0 {
            continue; // along the axis: no surface
        }
        for s in 0..segments {
            let quad = [at(p, s), at(q, s), at(q, s + 1), at(p, s + 1)];
            builder.quad(quad);
        }
    }
    builder.mesh
}

/// Extrudes the rectangle `x` × `y` with a round hole (centre, radius) from z = 0 to
/// `thickness`. The region between hole and rectangle is star-shaped about the hole centre,
/// so it is meshed as a strip between the hole polygon and the rectangle, both sampled at
/// the same angles (the circle's `segments` and the rectangle's four corners).
fn plate_with_hole(
    x: [f64; 2],
    y: [f64; 2],
    thickness: f64,
    centre: [f64; 2],
    radius: f64,
    segments: usize,
) -> Mesh {
    let (cx, cy) = (centre[0], centre[1]);
    let mut angles: Vec<f64> = (0..segments)
        .map(|s| std::f64::consts::TAU * s as f64 / segments as f64)
        .collect();
    for (px, py) in [(x[0], y[0]), (x[1], y[0]), (x[1], y[1]), (x[0], y[1])] {
        angles.push((py - cy).atan2(px - cx).rem_euclid(std::f64::consts::TAU));
    }
    angles.sort_by(f64::total_cmp);
    angles.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    let ring: Vec<([f64; 2], [f64; 2])> = angles
        .iter()
        .map(|&a| {
            let (dx, dy) = (a.cos(), a.sin());
            // Distance along the ray to the first rectangle side it crosses.
            let tx = if dx > 1e-15 {
                (x[1] - cx) / dx
            } else if dx < -1e-15 {
                (x[0] - cx) / dx
            } else {
                f64::INFINITY
            };
            let ty = if dy > 1e-15 {
                (y[1] - cy) / dy
            } else if dy < -1e-15 {
                (y[0] - cy) / dy
            } else {
                f64::INFINITY
            };
            let t = tx.min(ty);
            let mut outer = [cx + t * dx, cy + t * dy];
            // Snap to the rectangle so the sides are exactly planar.
            outer[0] = outer[0].clamp(x[0], x[1]);
            outer[1] = outer[1].clamp(y[0], y[1]);
            if tx <= ty {
                outer[0] = if dx > 0.0 { x[1] } else { x[0] };
            } else {
                outer[1] = if dy > 0.0 { y[1] } else { y[0] };
            }
            ([cx + radius * dx, cy + radius * dy], outer)
        })
        .collect();
    let mut builder = MeshBuilder::default();
    let p = |xy: [f64; 2], z: f64| DVec3::new(xy[0], xy[1], z);
    let n = ring.len();
    for s in 0..n {
        let (hole_a, rim_a) = ring[s];
        let (hole_b, rim_b) = ring[(s + 1) % n];
        // Top (+z), bottom (-z), outer side, hole side; angles increase counter-clockwise.
        builder.quad([
            p(hole_a, thickness),
            p(rim_a, thickness),
            p(rim_b, thickness),
            p(hole_b, thickness),
        ]);
        builder.quad([p(hole_a, 0.0), p(hole_b, 0.0), p(rim_b, 0.0), p(rim_a, 0.0)]);
        builder.quad([
            p(rim_a, 0.0),
            p(rim_b, 0.0),
            p(rim_b, thickness),
            p(rim_a, thickness),
        ]);
        builder.quad([
            p(hole_a, 0.0),
            p(hole_a, thickness),
            p(hole_b, thickness),
            p(hole_b, 0.0),
        ]);
    }
    builder.mesh
}

/// Collects quads and triangles, sharing vertices at identical positions and dropping
/// triangles that collapse (a quad with a corner on the lathe axis).
#[derive(Default)]
struct MeshBuilder {
    mesh: Mesh,
    index: FxHashMap<[u64; 3], u32>,
}

impl MeshBuilder {
    fn vertex(&mut self, p: DVec3) -> u32 {
        // +0.0 and -0.0 are the same point.
        let key = [p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f64::to_bits);
        let next = self.mesh.vertices.len() as u32;
        *self.index.entry(key).or_insert_with(|| {
            self.mesh.vertices.push(p);
            next
        })
    }

    fn triangle(&mut self, corners: [DVec3; 3]) {
        let [a, b, c] = corners.map(|p| self.vertex(p));
        if a != b && b != c && a != c {
            self.mesh.triangles.push([a, b, c]);
        }
    }

    /// A planar quad, corners counter-clockwise seen from the side it faces.
    fn quad(&mut self, q: [DVec3; 4]) {
        self.triangle([q[0], q[1], q[2]]);
        self.triangle([q[0], q[2], q[3]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::centre::Centres;
    use crate::mesh::Topology;

    /// Every directed edge appears once and its reverse once: closed and consistently
    /// oriented.
    fn assert_closed_and_oriented(name: &str, mesh: &Mesh) {
        let mut directed = FxHashMap::default();
        for tri in &mesh.triangles {
            for k in 0..3 {
                *directed.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &count) in &directed {
            assert_eq!(count, 1, "{name}: edge {a}->{b} used {count} times");
            assert_eq!(
                directed.get(&(b, a)),
                Some(&1),
                "{name}: edge {a}->{b} has no twin"
            );
        }
        let topology = Topology::new(mesh);
        assert_eq!(topology.open_edges, 0, "{name}");
        assert_eq!(topology.non_manifold_edges, 0, "{name}");
        assert_eq!(topology.bodies, 1, "{name}");
    }

    #[test]
    fn every_sample_is_a_closed_outward_single_body() {
        for info in SAMPLES {
            let mesh = sample(info.name).unwrap();
            assert_closed_and_oriented(info.name, &mesh);
            assert!(
                Centres::of(&mesh).volume_mm3 > 0.0,
                "{}: normals point inwards",
                info.name
            );
        }
        assert!(sample("nope").is_none());
    }

    #[test]
    fn volumes_match_closed_forms() {
        let volume = |name| Centres::of(&sample(name).unwrap()).volume_mm3;
        let tray = 80.0 * 60.0 * 20.0 - 70.0 * 50.0 * 16.0;
        assert!((volume("tray") - tray).abs() < 1e-6);
        let bracket = 60.0 * 40.0 * 5.0 + 5.0 * 40.0 * 45.0;
        assert!((volume("bracket") - bracket).abs() < 1e-6);
        let shell = 120.0 * 80.0 * 30.0 - 116.0 * 76.0 * 28.0;
        let ribs = 116.0 * 2.0 * 10.0 + 2.0 * 76.0 * 10.0 - 2.0 * 2.0 * 10.0;
        let bosses = 4.0 * (8.0 * 8.0 * 20.0 - 3.0 * 3.0 * 18.0);
        assert!((volume("cover") - (shell + ribs + bosses)).abs() < 1e-6);
        // The hole is a polygon inscribed in the circle with at least the 64 regular corners
        // (area (n/2) r^2 sin(2 pi / n)), so its area lies between that and pi r^2.
        let regular = 32.0 * 64.0 * (std::f64::consts::TAU / 64.0).sin();
        let circle = std::f64::consts::PI * 64.0;
        let plate = volume("plate");
        assert!(plate <= (6000.0 - regular) * 3.0 + 1e-6, "{plate}");
        assert!(plate >= (6000.0 - circle) * 3.0 - 1e-6, "{plate}");
        let ring = |r: f64| 48.0 * r * r * (std::f64::consts::TAU / 96.0).sin();
        let cap = ring(20.0) * 15.0 - ring(18.4) * 13.4;
        assert!((volume("cap") - cap).abs() < 1e-6);
    }

    #[test]
    fn bounds_are_as_described() {
        let b = sample("cover").unwrap().bounds();
        assert_eq!(b.min.to_array(), [-60.0, -40.0, 0.0]);
        assert_eq!(b.max.to_array(), [60.0, 40.0, 30.0]);
        let b = sample("plate").unwrap().bounds();
        assert_eq!(b.min.to_array(), [-50.0, -30.0, 0.0]);
        assert_eq!(b.max.to_array(), [50.0, 30.0, 3.0]);
    }
}
