//! Binary glTF 2.0 (GLB) of a [`Scene`]: the part coloured by the scene's field, a disc at
//! each gate, a marker at the centre of mass, the parting line and the qualifying nodes, for
//! any glTF viewer.
//!
//! # What the file holds
//!
//! One scene with one root node, `moldgate`, whose children are:
//!
//! | node | mesh | material |
//! |---|---|---|
//! | `part` | triangles with POSITION, NORMAL and COLOR_0 | white PBR (metallic 0, roughness 0.7), double-sided, times the vertex colours |
//! | `gate 1`, `gate 2`, … | a short cylinder of radius R (the gate radius, Eq. 8) and height R/2 standing on the surface along the gate normal | red |
//! | `your gate 1`, `your gate 2`, … | the gates the designer placed (`gate_at`): the same cylinder along the surface normal; the node's `extras` give the point, the normal and whether it qualifies | pink |
//! | `centre of mass` | an octahedron, half-diagonal max(R, 1 % of the part's diagonal) | cyan |
//! | `parting line` | LINES | white, unlit |
//! | `qualifying nodes` | POINTS at the surface points of the nodes that qualify | orange, unlit |
//! | `keep-out 1`, `keep-out 2`, … | the designer's keep-out regions: a box's 12 edges, a sphere's three great circles (LINES) | near-black, unlit |
//! | `gate suitability` | with the suitability map only: a square of the grid spacing facing +D at each scored node, lifted 2 % of the spacing off the surface, COLOR_0 by its score | unlit, times the vertex colours |
//!
//! Nodes with nothing to show (no gate, an empty parting line, no qualifying node) are left
//! out, and so are the materials nothing uses.
//!
//! # Units and axes
//!
//! The buffers hold the part's own coordinates in **millimetres**, exactly as loaded (the
//! `POSITION` bounds are the mesh's bounds). glTF's unit is the metre and its up axis +Y, so
//! the root node scales by 0.001 and turns the demolding direction D to +Y (the frame's u
//! to +X and w to -Z; for D = +Z this is the usual Z-up to Y-up turn). A viewer therefore
//! shows the part at its true size with the mould opening upwards. The asset's `extras` say
//! so and give D in the file's axes (`demolding_direction`), the centre of mass and the gates
//! in mm, and the field's name, unit and range.
//!
//! # Colours and normals
//!
//! The field is coloured by [`crate::colormap`] (the same map as the PNG pictures), normalised
//! to its own range, NaN grey; the sRGB colours are stored as linear floats as glTF requires.
//! Normals are smooth within a crease angle of 30 degrees and split across sharper edges: a
//! triangle's corner takes the angle-weighted mean of the normals of the triangles around its
//! vertex that are within 30 degrees of its own, so flat faces stay flat, curved faces look
//! round, and box edges stay sharp. A vertex is repeated once per distinct normal.
//!
//! The JSON is framed with `serde_json` rather than the `gltf-json` crate: the file needs a
//! dozen kinds of objects, all written here in one place, and `gltf-json` would add about 35 s
//! of build time for types we would only fill in.

use std::f64::consts::TAU;

use rayon::prelude::*;
use serde_json::{json, Value};

use crate::colormap::{self, Range};
use glam::{DMat3, DQuat};

use crate::math::{Aabb, DVec3};
use crate::mesh::Mesh;
use crate::scene::Scene;

/// Why a GLB cannot be made.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GlbError {
    /// The file would exceed the 4 GiB a GLB's 32-bit length can describe.
    #[error("the glTF file would be {bytes} bytes, over the 4 GiB limit of the GLB format")]
    TooLarge {
        /// Size it would have, in bytes.
        bytes: u64,
    },
}

/// Cosine of the crease angle (30 degrees): neighbouring faces closer than this are shaded as
/// one smooth surface.
const CREASE_COS: f64 = 0.866_025_403_784_438_6;

/// Sides of the gate cylinder.
const GATE_SIDES: usize = 32;

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const MODE_POINTS: u32 = 0;
const MODE_LINES: u32 = 1;
const MODE_TRIANGLES: u32 = 4;

/// The look of each kind of object: one material each, written only when used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Look {
    Part,
    Gate,
    Placed,
    Centre,
    Parting,
    Qualifying,
    Suitability,
    KeepOut,
}

impl Look {
    /// The glTF material: lit for surfaces, unlit (`KHR_materials_unlit`, with the same
    /// base colour as the fallback) for lines and points. Colours are sRGB, stored linear.
    fn material(self) -> Value {
        let (name, srgb, unlit) = match self {
            Look::Part => ("part (vertex colours)", [255, 255, 255], false),
            Look::Gate => ("gate", [220, 20, 40], false),
            Look::Placed => ("your gate", crate::render::PLACED_COLOUR, false),
            // Cyan: neither the answer's red, the designer's pink gates, the qualifying
            // nodes' orange, the parting line's white nor a colour of the colour map.
            Look::Centre => ("centre of mass", [0, 200, 255], false),
            Look::Parting => ("parting line", [255, 255, 255], true),
            Look::Qualifying => ("qualifying nodes", [255, 140, 0], true),
            Look::Suitability => ("gate suitability (vertex colours)", [255, 255, 255], true),
            Look::KeepOut => ("keep-out region", [25, 25, 30], true),
        };
        let [r, g, b] = srgb.map(colormap::srgb_to_linear);
        let mut m = json!({
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [r, g, b, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": if unlit { 1.0 } else { 0.7 },
            },
        });
        if unlit {
            m["extensions"] = json!({ "KHR_materials_unlit": {} });
        }
        // The part may be open or inconsistently wound: show both sides.
        if self == Look::Part {
            m["doubleSided"] = json!(true);
        }
        m
    }

    fn unlit(self) -> bool {
        matches!(
            self,
            Look::Parting | Look::Qualifying | Look::Suitability | Look::KeepOut
        )
    }
}

/// The GLB bytes of `scene`.
pub fn glb(scene: &Scene) -> Result<Vec<u8>, GlbError> {
    let mut doc = Document::default();
    let mut children = Vec::new();
    // The colours' span (and the largest value beyond it), for the part and the extras.
    let span = scene.field.colour_span();

    let mesh = scene.mesh;
    if !mesh.triangles.is_empty() {
        // The part refined to the field's cells when the field has them.
        let (surface, values) = scene.surface();
        let part = part_geometry(surface, values, span.map(|(s, _)| s), scene.frame.d);
        let m = doc.triangles("part", part, Look::Part);
        children.push(doc.node("part", m));
    }

    let bounds = mesh.bounds();
    let diagonal = if bounds.min.is_finite() && bounds.max.is_finite() {
        bounds.diagonal()
    } else {
        0.0
    };
    for (i, g) in scene.gates.iter().enumerate() {
        let ok = g.point.is_finite() && g.radius_mm.is_finite() && g.radius_mm > 0.0;
        if !ok {
            continue;
        }
        let axis = if g.normal.length_squared() > 0.0 && g.normal.is_finite() {
            g.normal.normalize()
        } else {
            scene.frame.d
        };
        let solid = cylinder(g.point, axis, g.radius_mm, 0.5 * g.radius_mm);
        let name = match g.body {
            Some(b) => format!("gate of {}", crate::flow::body_name(b)),
            None => format!("gate {}", i + 1),
        };
        let m = doc.triangles(&name, solid, Look::Gate);
        children.push(doc.node(&name, m));
    }

    placed_gate_nodes(&mut doc, scene, &mut children);

    let radius = scene
        .gates
        .first()
        .map(|g| g.radius_mm)
        .filter(|r| r.is_finite() && *r > 0.0)
        .unwrap_or(0.0);
    let size = radius.max(0.01 * diagonal);
    if scene.centre.is_finite() && size > 0.0 {
        let m = doc.triangles(
            "centre of mass",
            octahedron(scene.centre, size),
            Look::Centre,
        );
        children.push(doc.node("centre of mass", m));
    }

    let segments: Vec<[f32; 3]> = scene
        .parting
        .iter()
        .flat_map(|line| line.windows(2))
        .filter(|w| w[0].is_finite() && w[1].is_finite())
        .flat_map(|w| [f32s(w[0]), f32s(w[1])])
        .collect();
    if !segments.is_empty() {
        let m = doc.lines_or_points("parting line", segments, MODE_LINES, Look::Parting);
        children.push(doc.node("parting line", m));
    }

    let points: Vec<[f32; 3]> = scene
        .qualifying
        .iter()
        .filter(|p| p.is_finite())
        .map(|&p| f32s(p))
        .collect();
    if !points.is_empty() {
        let m = doc.lines_or_points("qualifying nodes", points, MODE_POINTS, Look::Qualifying);
        children.push(doc.node("qualifying nodes", m));
    }

    for (i, region) in scene.keep_out.iter().enumerate() {
        let name = format!("keep-out {}", i + 1);
        let m = doc.lines_or_points(&name, keep_out_lines(region), MODE_LINES, Look::KeepOut);
        children.push(doc.node(&name, m));
    }

    if let Some(g) = suitability_squares(scene) {
        let m = doc.triangles("gate suitability", g, Look::Suitability);
        children.push(doc.node("gate suitability", m));
    }

    let mut root = json!({
        "name": "moldgate",
        "rotation": rotation_to_y_up(scene),
        "scale": [0.001, 0.001, 0.001],
    });
    if !children.is_empty() {
        root["children"] = json!(children);
    }
    doc.nodes.push(root);
    let root_index = doc.nodes.len() - 1;
    doc.finish(scene, span, root_index)
}

/// The segments that outline a keep-out region: a box's 12 edges, or a sphere's three
/// great circles across the axes (48 segments each).
fn keep_out_lines(region: &crate::keepout::Region) -> Vec<[f32; 3]> {
    use crate::keepout::Region;
    match *region {
        Region::Box { min, max } => {
            let corner = Region::box_corners(min, max);
            // Corners that differ in one bit are joined by an edge.
            (0..8usize)
                .flat_map(|i| [1usize, 2, 4].map(move |bit| (i, i | bit)))
                .filter(|&(i, j)| i != j)
                .flat_map(|(i, j)| [f32s(corner[i]), f32s(corner[j])])
                .collect()
        }
        Region::Sphere { centre, radius } => {
            const SEGMENTS: usize = 48;
            let c = DVec3::from_array(centre);
            let axes = [
                (DVec3::X, DVec3::Y),
                (DVec3::Y, DVec3::Z),
                (DVec3::Z, DVec3::X),
            ];
            axes.iter()
                .flat_map(|&(a, b)| {
                    (0..SEGMENTS).flat_map(move |k| {
                        let at = |k: usize| {
                            let t = std::f64::consts::TAU * k as f64 / SEGMENTS as f64;
                            c + (a * t.cos() + b * t.sin()) * radius
                        };
                        [f32s(at(k)), f32s(at(k + 1))]
                    })
                })
                .collect()
        }
    }
}

/// A node per gate the designer placed, named `your gate N`: a cylinder like the answer's
/// gates, with the point, the normal and the verdict in the node's `extras`.
fn placed_gate_nodes(doc: &mut Document, scene: &Scene, children: &mut Vec<usize>) {
    for (i, p) in scene.placed.iter().enumerate() {
        let g = &p.marker;
        if !(g.point.is_finite() && g.radius_mm.is_finite() && g.radius_mm > 0.0) {
            continue;
        }
        let axis = if g.normal.length_squared() > 0.0 && g.normal.is_finite() {
            g.normal.normalize()
        } else {
            scene.frame.d
        };
        let solid = cylinder(g.point, axis, g.radius_mm, 0.5 * g.radius_mm);
        let name = format!("your gate {}", i + 1);
        let m = doc.triangles(&name, solid, Look::Placed);
        let node = doc.node(&name, m);
        doc.nodes[node]["extras"] = json!({
            "point_mm": finite3(g.point),
            "normal": finite3(axis),
            "radius_mm": finite(g.radius_mm),
            "qualifies": p.qualifies,
        });
        children.push(node);
    }
}

/// The suitability map as squares of the grid spacing facing +D, one per scored node, each
/// in its score's colour (the map's own range); `None` without a map or a scored node.
fn suitability_squares(scene: &Scene) -> Option<Geometry> {
    let field = scene.node_field.as_ref()?;
    let range = Range::of(&field.per_node)?;
    let f = scene.frame;
    let half = 0.5 * scene.grid_spacing_mm;
    let lift = f.d * (0.02 * scene.grid_spacing_mm);
    let mut g = Solid::default();
    for (&p, &v) in scene.qualifying.iter().zip(&field.per_node) {
        if !(v.is_finite() && p.is_finite()) {
            continue;
        }
        let rgb = colormap::colour(range.t(v)).map(colormap::srgb_to_linear);
        let base = g.positions.len() as u32;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            g.positions
                .push(f32s(p + lift + f.u * (a * half) + f.w * (b * half)));
            g.normals.push(f32s(f.d));
            g.colours.push(rgb);
        }
        // u x w = d: counter-clockwise seen from +D.
        g.indices
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    (!g.indices.is_empty()).then(|| g.geometry())
}

/// The root node's rotation as a quaternion `[x, y, z, w]`: the frame's (u, w, d) to glTF's
/// (+X, -Z, +Y). Both frames are right-handed (u x w = d, X x -Z = Y), so it is a rotation.
fn rotation_to_y_up(scene: &Scene) -> [f64; 4] {
    let f = scene.frame;
    let to = DMat3::from_cols(DVec3::X, DVec3::NEG_Z, DVec3::Y);
    let from = DMat3::from_cols(f.u, f.w, f.d);
    let q = DQuat::from_mat3(&(to * from.transpose())).normalize();
    [q.x, q.y, q.z, q.w]
}

fn f32s(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

/// Vertex and index arrays of a triangle mesh ready for glTF.
struct Geometry {
    positions: Pieces,
    normals: Pieces,
    /// Linear-light colours; empty for a mesh coloured by its material alone.
    colours: Pieces,
    indices: Vec<u32>,
}

/// A vertex array in pieces, written to the file one after the other: the part's runs of
/// vertices stay the vectors their threads made, not copied into one vector first.
#[derive(Debug, Default, PartialEq)]
struct Pieces(Vec<Vec<[f32; 3]>>);

impl Pieces {
    fn len(&self) -> usize {
        self.0.iter().map(Vec::len).sum()
    }

    fn is_empty(&self) -> bool {
        self.0.iter().all(Vec::is_empty)
    }

    fn iter(&self) -> impl Iterator<Item = &[f32; 3]> {
        self.0.iter().flatten()
    }
}

impl From<Vec<[f32; 3]>> for Pieces {
    fn from(one: Vec<[f32; 3]>) -> Pieces {
        Pieces(vec![one])
    }
}

/// The part with crease-split normals and field colours (see the module documentation).
///
/// Vertices are made vertex by vertex: the corners around a mesh vertex that get the same
/// normal share one glTF vertex, so the output is in mesh-vertex order and needs no hashing.
/// Runs of vertices are done in parallel and joined in order, so the result does not
/// depend on the number of threads.
fn part_geometry(
    mesh: &Mesh,
    field: &[f32],
    range: Option<[f32; 2]>,
    fallback_normal: DVec3,
) -> Geometry {
    let n_vertices = mesh.vertices.len();
    let n_triangles = mesh.triangles.len();
    // Each face's normal ([`Mesh::normal`]), and the angle of each of its corners (corner
    // 3t + k is corner k of triangle t), the weight of the face's normal in the vertex
    // normal, from one read of its corners. Each edge's unit vector is made once: corner
    // k's edges run from it to the next corner (edge k) and to the previous one (edge
    // k + 2 reversed, which is the same vector negated, bit for bit but for the sign of an
    // exact zero, which changes no angle: acos(-0) = acos(0)).
    let (normals, angles): (Vec<DVec3>, Vec<[f64; 3]>) = (0..n_triangles)
        .into_par_iter()
        .map(|t| {
            let p = mesh.corners(t);
            let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            let edge = [0, 1, 2].map(|k| (p[(k + 1) % 3] - p[k]).normalize_or_zero());
            let angles = [0, 1, 2].map(|k| {
                let (a, b) = (edge[k], -edge[(k + 2) % 3]);
                a.dot(b).clamp(-1.0, 1.0).acos()
            });
            (normal, angles)
        })
        .unzip();

    // The corners around each vertex: offsets, then corner numbers.
    let mut start = vec![0u32; n_vertices + 1];
    for tri in &mesh.triangles {
        for &v in tri {
            start[v as usize + 1] += 1;
        }
    }
    for i in 0..n_vertices {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut around = vec![0u32; 3 * n_triangles];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for (k, &v) in tri.iter().enumerate() {
            around[fill[v as usize] as usize] = (3 * t + k) as u32;
            fill[v as usize] += 1;
        }
    }
    drop(fill);

    let range = range.map(|[min, max]| Range { min, max });
    let weighted = |c: u32| normals[c as usize / 3] * angles[c as usize / 3][c as usize % 3];
    // One run of vertices: its glTF vertices, and the run-local vertex of each corner.
    let run = |vertices: std::ops::Range<usize>| {
        let mut g = Solid::default();
        let mut corners: Vec<(u32, u32)> = Vec::new();
        // The normals already given a glTF vertex of the current mesh vertex.
        let mut made: Vec<([f32; 3], u32)> = Vec::new();
        // The vertex given to each face normal met so far around the current mesh vertex.
        let mut by_face: Vec<(DVec3, u32)> = Vec::new();
        let mut faces: Vec<(DVec3, DVec3)> = Vec::new();
        let mut last_colour: Option<(f32, [f32; 3])> = None;
        for v in vertices {
            let ring = &around[start[v] as usize..start[v + 1] as usize];
            if ring.is_empty() {
                continue;
            }
            // Neighbouring vertices often have the same value (a face square to the
            // demolding direction has one height): the colour of the last value is kept.
            let value = field.get(v).copied().unwrap_or(f32::NAN);
            let colour = match last_colour {
                Some((x, c)) if x.to_bits() == value.to_bits() => c,
                _ => {
                    let c = match range {
                        Some(r) if value.is_finite() => colormap::colour(r.t(value)),
                        _ => colormap::NAN_GREY,
                    }
                    .map(colormap::srgb_to_linear);
                    last_colour = Some((value, c));
                    c
                }
            };
            // The normal and the angle-weighted normal of each face around the vertex.
            faces.clear();
            faces.extend(ring.iter().map(|&c| (normals[c as usize / 3], weighted(c))));
            made.clear();
            by_face.clear();
            for (&corner, &(own, _)) in ring.iter().zip(&faces) {
                // Corners of faces with the very same normal (a flat region) get the same
                // vertex without summing again.
                if let Some(&(_, i)) = by_face.iter().find(|(f, _)| *f == own) {
                    corners.push((corner, i));
                    continue;
                }
                let smooth: DVec3 = faces
                    .iter()
                    .filter(|(n, _)| n.dot(own) >= CREASE_COS)
                    .map(|&(_, w)| w)
                    .sum();
                // A triangle without area has no normal of its own: it takes its vertex's
                // mean, or the demolding direction where even that vanishes.
                let n = smooth
                    .try_normalize()
                    .or_else(|| faces.iter().map(|&(_, w)| w).sum::<DVec3>().try_normalize())
                    .unwrap_or(fallback_normal);
                let n = f32s(n);
                let index = match made.iter().find(|(m, _)| *m == n) {
                    Some(&(_, i)) => i,
                    None => {
                        let i = g.positions.len() as u32;
                        g.positions.push(f32s(mesh.vertices[v]));
                        g.normals.push(n);
                        g.colours.push(colour);
                        made.push((n, i));
                        i
                    }
                };
                by_face.push((own, index));
                corners.push((corner, index));
            }
        }
        (g, corners)
    };
    const RUN: usize = 16_384;
    let runs: Vec<_> = (0..n_vertices.div_ceil(RUN))
        .into_par_iter()
        .map(|r| run(r * RUN..((r + 1) * RUN).min(n_vertices)))
        .collect();
    // The per-face tables are no longer needed: free them before the output is assembled.
    drop((normals, angles, start, around));

    let mut out = Geometry {
        positions: Pieces::default(),
        normals: Pieces::default(),
        colours: Pieces::default(),
        indices: vec![0; 3 * n_triangles],
    };
    let mut offset = 0u32;
    for (g, corners) in runs {
        for (corner, local) in corners {
            out.indices[corner as usize] = offset + local;
        }
        offset += g.positions.len() as u32;
        out.positions.0.push(g.positions);
        out.normals.0.push(g.normals);
        out.colours.0.push(g.colours);
    }
    out
}

/// Vertex and index arrays collected one by one: flat-shaded triangles by
/// [`Solid::triangle`] (each wound counter-clockwise seen from the side its normal points to,
/// glTF's front face, without colours), or coloured vertices pushed directly (the part's
/// runs, the suitability squares), one colour with each vertex. One object uses one way.
#[derive(Default)]
struct Solid {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    colours: Vec<[f32; 3]>,
    indices: Vec<u32>,
}

impl Solid {
    /// Adds triangle (a, b, c) facing `outward`, with the vertex normals given.
    fn triangle(&mut self, corners: [DVec3; 3], normals: [DVec3; 3], outward: DVec3) {
        let [a, mut b, mut c] = corners;
        let [na, mut nb, mut nc] = normals;
        if (b - a).cross(c - a).dot(outward) < 0.0 {
            std::mem::swap(&mut b, &mut c);
            std::mem::swap(&mut nb, &mut nc);
        }
        for (p, n) in [(a, na), (b, nb), (c, nc)] {
            self.indices.push(self.positions.len() as u32);
            self.positions.push(f32s(p));
            self.normals.push(f32s(n));
        }
    }

    fn geometry(self) -> Geometry {
        Geometry {
            positions: self.positions.into(),
            normals: self.normals.into(),
            colours: self.colours.into(),
            indices: self.indices,
        }
    }
}

/// A cylinder of radius `r` from `base` to `base + height * axis` (`axis` unit): the gate
/// disc, standing on the surface so that it shows above it.
fn cylinder(base: DVec3, axis: DVec3, r: f64, height: f64) -> Geometry {
    let (e1, e2) = axis.any_orthonormal_pair();
    let top = base + axis * height;
    let ring = |i: usize| {
        let a = TAU * i as f64 / GATE_SIDES as f64;
        e1 * a.cos() + e2 * a.sin()
    };
    let mut s = Solid::default();
    for i in 0..GATE_SIDES {
        let (d0, d1) = (ring(i), ring(i + 1));
        s.triangle([top, top + d0 * r, top + d1 * r], [axis; 3], axis);
        s.triangle([base, base + d0 * r, base + d1 * r], [-axis; 3], -axis);
        let mid = (d0 + d1).normalize();
        s.triangle(
            [base + d0 * r, base + d1 * r, top + d1 * r],
            [d0, d1, d1],
            mid,
        );
        s.triangle(
            [base + d0 * r, top + d1 * r, top + d0 * r],
            [d0, d1, d0],
            mid,
        );
    }
    s.geometry()
}

/// A regular octahedron around `centre` with vertices `size` away along each axis.
fn octahedron(centre: DVec3, size: f64) -> Geometry {
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    let mut s = Solid::default();
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                let [x, y, z] = [axes[0] * sx, axes[1] * sy, axes[2] * sz];
                let n = (x + y + z).normalize();
                let corners = [x, y, z].map(|a| centre + a * size);
                s.triangle(corners, [n; 3], n);
            }
        }
    }
    s.geometry()
}

/// The data of one buffer view, kept until the file is written.
enum Block {
    Floats(Pieces),
    Indices(Vec<u32>),
}

impl Block {
    /// Its bytes, little-endian, after the end of `out`.
    fn write(&self, out: &mut Vec<u8>) {
        match self {
            Block::Floats(pieces) => {
                for piece in &pieces.0 {
                    put_words(out, piece.as_flattened(), |x| x.to_le_bytes());
                }
            }
            Block::Indices(indices) => put_words(out, indices, |x| x.to_le_bytes()),
        }
    }
}

/// Appends the 4-byte words of `data` to `out`, in order, a word at a time into space made
/// for all of them at once.
fn put_words<T: Copy>(out: &mut Vec<u8>, data: &[T], bytes: impl Fn(T) -> [u8; 4]) {
    let start = out.len();
    out.resize(start + 4 * data.len(), 0);
    for (word, &x) in out[start..].chunks_exact_mut(4).zip(data) {
        word.copy_from_slice(&bytes(x));
    }
}

/// The JSON arrays of the file under construction, and the data of its binary chunk, which
/// is copied once, into the file, when the file is written.
#[derive(Default)]
struct Document {
    blocks: Vec<Block>,
    /// The binary chunk's length so far, bytes.
    bin_len: usize,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
    /// The materials used, in material order.
    looks: Vec<Look>,
}

impl Document {
    /// Adds `block` (4-byte words, so every view stays 4-byte aligned) as a buffer view of
    /// `words` words and returns its index.
    fn view(&mut self, block: Block, words: usize, target: u32) -> usize {
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": self.bin_len,
            "byteLength": 4 * words,
            "target": target,
        }));
        self.bin_len += 4 * words;
        self.blocks.push(block);
        self.views.len() - 1
    }

    /// A VEC3 float accessor; `bounds` adds the min and max the spec requires of POSITION.
    fn vec3(&mut self, data: Pieces, bounds: bool) -> usize {
        let count = data.len();
        let mut a = json!({
            "componentType": FLOAT,
            "count": count,
            "type": "VEC3",
        });
        if bounds {
            // Taken from the f32 values themselves: the validator compares them exactly.
            let mut min = [f32::INFINITY; 3];
            let mut max = [f32::NEG_INFINITY; 3];
            for p in data.iter() {
                for i in 0..3 {
                    min[i] = min[i].min(p[i]);
                    max[i] = max[i].max(p[i]);
                }
            }
            a["min"] = json!(min);
            a["max"] = json!(max);
        }
        a["bufferView"] = json!(self.view(Block::Floats(data), 3 * count, ARRAY_BUFFER));
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// A SCALAR unsigned-int index accessor.
    fn indices(&mut self, data: Vec<u32>) -> usize {
        let count = data.len();
        let view = self.view(Block::Indices(data), count, ELEMENT_ARRAY_BUFFER);
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": UNSIGNED_INT,
            "count": count,
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }

    /// A mesh of indexed triangles; returns the mesh index.
    fn triangles(&mut self, name: &str, g: Geometry, look: Look) -> usize {
        let material = self.material(look);
        let mut attributes = json!({
            "POSITION": self.vec3(g.positions, true),
            "NORMAL": self.vec3(g.normals, false),
        });
        if !g.colours.is_empty() {
            attributes["COLOR_0"] = json!(self.vec3(g.colours, false));
        }
        let indices = self.indices(g.indices);
        self.mesh(
            name,
            json!({
                "attributes": attributes,
                "indices": indices,
                "material": material,
                "mode": MODE_TRIANGLES,
            }),
        )
    }

    /// A mesh of unindexed lines (pairs of points) or points.
    fn lines_or_points(&mut self, name: &str, p: Vec<[f32; 3]>, mode: u32, look: Look) -> usize {
        let material = self.material(look);
        let position = self.vec3(p.into(), true);
        self.mesh(
            name,
            json!({
                "attributes": { "POSITION": position },
                "material": material,
                "mode": mode,
            }),
        )
    }

    /// The index of the material of `look`, added on first use.
    fn material(&mut self, look: Look) -> usize {
        match self.looks.iter().position(|&l| l == look) {
            Some(i) => i,
            None => {
                self.looks.push(look);
                self.looks.len() - 1
            }
        }
    }

    fn mesh(&mut self, name: &str, primitive: Value) -> usize {
        self.meshes
            .push(json!({ "name": name, "primitives": [primitive] }));
        self.meshes.len() - 1
    }

    /// A node showing mesh `mesh`; returns the node index.
    fn node(&mut self, name: &str, mesh: usize) -> usize {
        self.nodes.push(json!({ "name": name, "mesh": mesh }));
        self.nodes.len() - 1
    }

    /// The JSON document and the GLB framing around it and the binary chunk; `span` is the
    /// field's colour span ([`Scene`]'s `field.colour_span()`).
    fn finish(
        self,
        scene: &Scene,
        span: Option<([f32; 2], Option<f32>)>,
        root: usize,
    ) -> Result<Vec<u8>, GlbError> {
        let bin_len = self.bin_len;
        let range = span.map(|([min, max], _)| Range { min, max });
        let beyond = span.and_then(|(_, beyond)| beyond);
        let bounds = scene.mesh.bounds();
        let gates: Vec<Value> = scene
            .gates
            .iter()
            .map(|g| {
                json!({
                    "point_mm": finite3(g.point),
                    "normal": finite3(g.normal),
                    "radius_mm": finite(g.radius_mm),
                })
            })
            .collect();
        let mut document = json!({
            "asset": {
                "version": "2.0",
                "generator": concat!("moldgate ", env!("CARGO_PKG_VERSION")),
                "extras": {
                    "title": scene.title,
                    "subtitle": scene.subtitle,
                    "units": "millimetres in the buffers; the root node scales by 0.001 to metres",
                    "up": "the root node turns the demolding direction to +Y (u to +X, w to -Z)",
                    "demolding_direction": finite3(scene.frame.d),
                    "frame_u": finite3(scene.frame.u),
                    "frame_w": finite3(scene.frame.w),
                    "centre_of_mass_mm": finite3(scene.centre),
                    "gates": gates,
                    "placed_gates": scene.placed.iter().map(|p| json!({
                        "point_mm": finite3(p.marker.point),
                        "normal": finite3(p.marker.normal),
                        "radius_mm": finite(p.marker.radius_mm),
                        "qualifies": p.qualifies,
                    })).collect::<Vec<_>>(),
                    "bounds_mm": bounds_json(bounds),
                    "field": {
                        "name": scene.field.name,
                        "unit": scene.field.unit,
                        "min": range.map(|r| r.min),
                        "max": range.map(|r| r.max),
                        "largest": beyond,
                        "colour_map": "viridis, low to high; grey where unknown; with `largest`, the colours stop at `max`, the 99th percentile of the cells, and the last 1 % (up to `largest`) take the top colour",
                    },
                },
            },
            "scene": 0,
            "scenes": [{ "name": scene.title, "nodes": [root] }],
            "nodes": self.nodes,
            "accessors": self.accessors,
            "bufferViews": self.views,
        });
        if let Some(f) = &scene.node_field {
            let r = Range::of(&f.per_node);
            document["asset"]["extras"]["suitability"] = json!({
                "name": f.name,
                "unit": f.unit,
                "min": r.map(|r| r.min),
                "max": r.map(|r| r.max),
                "colour_map": "viridis, low (a better gate) to high, on the `gate suitability` squares",
            });
        }
        // glTF forbids empty arrays: each is written only when it has something.
        if !self.meshes.is_empty() {
            document["meshes"] = json!(self.meshes);
            let materials: Vec<Value> = self.looks.iter().map(|l| l.material()).collect();
            document["materials"] = json!(materials);
        }
        if self.looks.iter().any(|l| l.unlit()) {
            document["extensionsUsed"] = json!(["KHR_materials_unlit"]);
        }
        if bin_len > 0 {
            document["buffers"] = json!([{ "byteLength": bin_len }]);
        } else {
            let o = document.as_object_mut().expect("an object");
            o.remove("accessors");
            o.remove("bufferViews");
        }
        let mut text = serde_json::to_vec(&document).expect("JSON of plain values");
        while text.len() % 4 != 0 {
            text.push(b' ');
        }
        let total = 12 + 8 + text.len() as u64 + if bin_len == 0 { 0 } else { 8 + bin_len as u64 };
        let length = u32::try_from(total).map_err(|_| GlbError::TooLarge { bytes: total })?;
        let mut out = Vec::with_capacity(total as usize);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&length.to_le_bytes());
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&text);
        if bin_len > 0 {
            out.extend_from_slice(&(bin_len as u32).to_le_bytes());
            out.extend_from_slice(b"BIN\0");
            for block in &self.blocks {
                block.write(&mut out);
            }
        }
        debug_assert_eq!(out.len() as u64, total);
        Ok(out)
    }
}

/// A number for the JSON extras; JSON has no NaN, so an unknown value is null.
fn finite(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

fn finite3(p: DVec3) -> Value {
    json!([finite(p.x), finite(p.y), finite(p.z)])
}

fn bounds_json(b: Aabb) -> Value {
    json!({ "min": finite3(b.min), "max": finite3(b.max) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_takes_d_up() {
        use crate::frame::{Direction, Frame};
        for d in ["+z", "-z", "+x", "-y", "1,2,3"] {
            let frame = Frame::new(d.parse::<Direction>().unwrap());
            let [x, y, z, w] = {
                let mesh = Mesh::default();
                let scene = Scene {
                    mesh: &mesh,
                    topology: None,
                    frame,
                    field: crate::scene::Field {
                        name: String::new(),
                        unit: String::new(),
                        per_vertex: vec![],
                        cells: None,
                        span: None,
                    },
                    display: None,
                    gates: vec![],
                    placed: vec![],
                    centre: DVec3::ZERO,
                    parting: vec![],
                    qualifying: vec![],
                    node_field: None,
                    title: String::new(),
                    subtitle: String::new(),
                    grid_spacing_mm: 1.0,
                    keep_out: Vec::new(),
                };
                rotation_to_y_up(&scene)
            };
            let q = DQuat::from_xyzw(x, y, z, w);
            assert!((q.length() - 1.0).abs() < 1e-12);
            assert!((q * frame.d - DVec3::Y).length() < 1e-12, "{d}");
            assert!((q * frame.u - DVec3::X).length() < 1e-12, "{d}");
            assert!((q * frame.w - DVec3::NEG_Z).length() < 1e-12, "{d}");
        }
    }

    #[test]
    fn markers_face_outwards() {
        // Every triangle of the closed markers is wound counter-clockwise seen from outside:
        // its right-hand normal points away from the marker's centre.
        let centre = DVec3::new(1.0, 2.0, 3.0);
        let axis = DVec3::new(1.0, 1.0, 0.0).normalize();
        let cases = [
            (octahedron(centre, 2.0), centre, 8),
            (
                cylinder(centre, axis, 1.5, 0.75),
                centre + axis * 0.375,
                4 * GATE_SIDES,
            ),
        ];
        for (g, middle, triangles) in cases {
            assert_eq!(g.indices.len(), 3 * triangles);
            let positions: Vec<[f32; 3]> = g.positions.iter().copied().collect();
            let p = |i: u32| {
                let [x, y, z] = positions[i as usize];
                DVec3::new(x as f64, y as f64, z as f64)
            };
            for t in g.indices.chunks(3) {
                let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
                let n = (b - a).cross(c - a);
                assert!(n.dot((a + b + c) / 3.0 - middle) > 0.0);
            }
        }
    }

    #[test]
    fn part_geometry_is_the_same_on_any_number_of_threads() {
        // A wavy height field of 180 x 180 vertices: more than one run of vertices, smooth
        // normals almost everywhere.
        let n = 180u32;
        let vertices = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f64, (i / n) as f64);
                DVec3::new(x, y, 3.0 * (x / 9.0).sin() * (y / 13.0).cos())
            })
            .collect();
        let mut triangles = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let i = y * n + x;
                triangles.push([i, i + 1, i + n + 1]);
                triangles.push([i, i + n + 1, i + n]);
            }
        }
        let mesh = Mesh {
            vertices,
            triangles,
        };
        let field: Vec<f32> = mesh.vertices.iter().map(|p| p.z as f32).collect();
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                part_geometry(
                    &mesh,
                    &field,
                    Range::of(&field).map(|r| [r.min, r.max]),
                    DVec3::Z,
                )
            })
        };
        let (one, three) = (on(1), on(3));
        assert_eq!(one.positions, three.positions);
        assert_eq!(one.normals, three.normals);
        assert_eq!(one.colours, three.colours);
        assert_eq!(one.indices, three.indices);
        // Smooth: one glTF vertex per mesh vertex, every corner on its own vertex, the
        // runs' pieces in order.
        assert!(one.positions.0.len() > 1, "several runs");
        assert_eq!(one.positions.len(), mesh.vertices.len());
        let positions: Vec<[f32; 3]> = one.positions.iter().copied().collect();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for (k, &v) in tri.iter().enumerate() {
                let i = one.indices[3 * t + k] as usize;
                assert_eq!(positions[i], f32s(mesh.vertices[v as usize]));
            }
        }
    }

    #[test]
    fn blocks_write_their_pieces_in_order_as_little_endian_words() {
        let pieces = Pieces(vec![
            vec![[1.0, -2.5, 3.25]],
            vec![],
            vec![[f32::MIN_POSITIVE, 0.0, -0.0], [1e30, 7.0, 8.0]],
        ]);
        let want: Vec<u8> = pieces
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let mut out = vec![9u8];
        Block::Floats(pieces).write(&mut out);
        assert_eq!(out[0], 9);
        assert_eq!(&out[1..], &want[..]);
        let mut out = Vec::new();
        Block::Indices(vec![1, 0x0102_0304, u32::MAX]).write(&mut out);
        assert_eq!(out, [1, 0, 0, 0, 4, 3, 2, 1, 255, 255, 255, 255]);
    }
}
