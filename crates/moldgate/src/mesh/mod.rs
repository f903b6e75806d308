//! Triangle meshes: the [`Mesh`] type, loading from files, welding and topology.
//!
//! Loading never panics: a file that cannot be read is a [`LoadError`] with a place (line,
//! byte offset or triangle). Defects that do not stop the work (degenerate facets, open edges,
//! several bodies) are counted in [`MeshStats`] beside the mesh.

pub mod arrays;
pub mod obj;
mod orient;
pub mod ply;
pub mod sniff;
pub mod stl;
pub mod text;
pub mod topology;
pub mod units;
mod weld32;

/// The largest coordinate accepted, in millimetres once converted from the file's units:
/// a kilometre of part is far beyond any mould, and below this the squares and sums of the
/// analysis (areas, moments, distances) stay finite and precise. A file with a coordinate
/// beyond it is refused at load with the coordinate's place.
pub const MAX_COORDINATE_MM: f64 = 1e9;

/// The most corners a polygon (an OBJ or PLY face, an ASCII STL facet) may have before it
/// is fanned into triangles: real meshes use triangles and quads, CAD exports rarely more
/// than a few dozen, and a fan of millions of triangles over one polygon is not a surface.
pub const MAX_POLYGON_CORNERS: usize = 4096;

use std::io::BufRead;

use rayon::prelude::*;
use serde::Serialize;

use crate::centre::{self, Centres, Moments};
use crate::error::{LoadError, Place};
use crate::math::{Aabb, DVec3};
pub use arrays::{from_arrays, vertex_map};
pub use topology::Topology;
pub use units::Units;

/// An indexed triangle mesh in millimetres, with identical vertices welded.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// Vertex positions in millimetres.
    pub vertices: Vec<DVec3>,
    /// Triangles as indices into `vertices`; no triangle repeats a vertex.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The three corners of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.vertices[a as usize],
            self.vertices[b as usize],
            self.vertices[c as usize],
        ]
    }

    /// The unit normal of triangle `t` (right-hand rule on its corner order), or zero when
    /// the triangle has no area.
    pub fn normal(&self, t: usize) -> DVec3 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// The box around every vertex.
    pub fn bounds(&self) -> Aabb {
        Aabb::of_points(&self.vertices)
    }

    /// The same surface with every triangle split into four at its edge midpoints (shared
    /// midpoints are one vertex), for scaling measurements.
    pub fn subdivided(&self) -> Mesh {
        let mut vertices = self.vertices.clone();
        let mut midpoints = rustc_hash::FxHashMap::default();
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<DVec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                vertices.push((vertices[a as usize] + vertices[b as usize]) * 0.5);
                (vertices.len() - 1) as u32
            })
        };
        let mut triangles = Vec::with_capacity(4 * self.triangles.len());
        for &[a, b, c] in &self.triangles {
            let ab = midpoint(a, b, &mut vertices);
            let bc = midpoint(b, c, &mut vertices);
            let ca = midpoint(c, a, &mut vertices);
            triangles.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        Mesh {
            vertices,
            triangles,
        }
    }

    /// Multiplies every coordinate by `factor` (a unit conversion).
    pub fn scale(&mut self, factor: f64) {
        if factor != 1.0 {
            for v in &mut self.vertices {
                *v *= factor;
            }
        }
    }

    /// Writes the mesh as a binary STL (in millimetres) to `out`.
    pub fn write_stl(&self, out: &mut impl std::io::Write) -> std::io::Result<()> {
        stl::write_binary(self, out)
    }
}

/// The file format a mesh came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// Binary STL.
    StlBinary,
    /// ASCII STL.
    StlAscii,
    /// Wavefront OBJ.
    Obj,
    /// ASCII PLY.
    PlyAscii,
    /// Binary little-endian PLY.
    PlyBinaryLittleEndian,
    /// Binary big-endian PLY.
    PlyBinaryBigEndian,
    /// Made by moldgate's own code (a sample part).
    Generated,
    /// Vertex and triangle arrays handed over by a program ([`from_arrays`]): numpy arrays,
    /// a trimesh mesh, a STEP file tessellated by the Python package.
    Arrays,
}

/// What loading found in a file, beside the mesh itself.
#[derive(Debug, Clone, Serialize)]
pub struct MeshStats {
    /// The file format.
    pub format: Format,
    /// The unit the file was read in.
    pub units: Units,
    /// Facets in the file (for OBJ and PLY, triangles after fanning the polygons).
    pub facets_read: u64,
    /// Solids (`solid ... endsolid` blocks) in an ASCII STL; 1 otherwise.
    pub solids: u64,
    /// Facet corners before welding (3 per facet).
    pub corners_read: u64,
    /// Vertices after welding identical positions.
    pub vertices: u64,
    /// Triangles kept (facets less the collapsed ones).
    pub triangles: u64,
    /// Facets dropped because two corners welded to the same vertex.
    pub collapsed_facets: u64,
    /// Triangles dropped because an earlier triangle has the same three vertices (in any
    /// order): a repeated facet adds no surface, and stacks of them multiply the cost of
    /// the rays.
    pub duplicate_triangles: u64,
    /// Triangles turned round at load: wound against their neighbours, or in a connected
    /// set that faced inwards (`mesh/orient.rs`).
    pub reoriented_triangles: u64,
    /// Kept triangles with zero area (three distinct but collinear corners).
    pub zero_area_triangles: u64,
    /// Edges used by one triangle only (0 on a closed mesh).
    pub open_edges: u64,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: u64,
    /// Connected bodies (triangles linked through shared vertices).
    pub bodies: u64,
    /// Surface area in mm^2.
    pub area_mm2: f64,
    /// Bounding box in mm.
    pub bounds_min: [f64; 3],
    /// Bounding box in mm.
    pub bounds_max: [f64; 3],
    /// Whether the part's size in mm suggests the file is in other units than it was read
    /// in (its box's diagonal outside [`units::SMALL_PART_MM`] to [`units::LARGE_PART_MM`]).
    pub size_suggests_other_units: bool,
}

impl MeshStats {
    /// True when every edge has exactly two triangles.
    pub fn is_closed(&self) -> bool {
        self.open_edges == 0 && self.non_manifold_edges == 0
    }
}

/// A mesh read from a file, with what was found on the way.
#[derive(Debug, Clone)]
pub struct LoadedMesh {
    /// The welded mesh in millimetres.
    pub mesh: Mesh,
    /// Counts of what was read and of defects.
    pub stats: MeshStats,
    /// Non-fatal problems, one sentence each.
    pub warnings: Vec<String>,
    /// The mesh's topology (edges and bodies), built once at load.
    pub topology: Topology,
    /// Both centres of mass ([`Centres::of`] the mesh), summed at load in the pass that
    /// measures the area.
    pub centres: Centres,
}

/// The most memory the analysis of a mesh takes per triangle, bytes: the measured peak of
/// `locate` is 54 to 75 bytes a triangle (the welding and topology tables with the mesh,
/// from 352k to 10 M triangles), rounded up. The readers of polygon formats count their
/// triangles against it as they read ([`check_triangle_memory`]): a PLY or OBJ face of 255
/// corners makes 253 triangles from as little as 256 bytes, so the file's size alone does
/// not bound them.
pub const BYTES_PER_TRIANGLE: u64 = 100;

/// How many triangles a reader adds between two checks of [`check_triangle_memory`].
pub(crate) const TRIANGLES_PER_MEMORY_CHECK: usize = 1 << 20;

/// Refuses to go on reading at `place` when `triangles` (read so far) may take more memory
/// to analyse than this process may use ([`crate::files::memory_limit`], when the system
/// says): [`BYTES_PER_TRIANGLE`] each.
pub(crate) fn check_triangle_memory(triangles: usize, place: Place) -> Result<(), LoadError> {
    let need = (triangles as u64).saturating_mul(BYTES_PER_TRIANGLE);
    match crate::files::memory_limit() {
        Some(limit) if need > limit => Err(LoadError::TooMuchMemory {
            place,
            triangles: triangles as u64,
            need,
            limit,
        }),
        _ => Ok(()),
    }
}

/// Reads an STL (binary or ASCII) of `len` bytes from `reader`, converting it to millimetres.
///
/// Binary is recognised by its size (84 + 50 n bytes for the n triangles its header declares)
/// before the word `solid` is looked at, since many binary files start with it.
pub fn read_stl(reader: impl BufRead, len: u64, units: Units) -> Result<LoadedMesh, LoadError> {
    let raw = stl::read(reader, len, units)?;
    finish(raw, units)
}

/// Reads an STL of `len` bytes from a source that `open` can open more than once, such as
/// a file: large binary files are then read and welded on several threads. The result is
/// the same as [`read_stl`]'s.
pub fn read_stl_reopen<R, F>(open: F, len: u64, units: Units) -> Result<LoadedMesh, LoadError>
where
    R: BufRead + std::io::Seek,
    F: Fn() -> std::io::Result<R> + Sync,
{
    let raw = stl::read_reopen(open, len, units)?;
    finish(raw, units)
}

/// Reads a Wavefront OBJ from `reader`, converting it to millimetres. Polygons are fanned
/// into triangles, and the triangles are welded like an STL's facets, so the same part saved
/// as STL and OBJ loads to the same mesh and stats (format aside).
pub fn read_obj(reader: impl BufRead, units: Units) -> Result<LoadedMesh, LoadError> {
    finish(obj::read(reader, units)?, units)
}

/// Reads a PLY (ASCII or binary, format 1.0) from `reader`, converting it to millimetres.
/// Polygons are fanned into triangles, and the triangles are welded like an STL's facets.
pub fn read_ply(reader: impl BufRead, units: Units) -> Result<LoadedMesh, LoadError> {
    finish(ply::read(reader, units)?, units)
}

/// Builds a [`LoadedMesh`] from generated geometry in millimetres.
pub fn from_generated(mesh: Mesh) -> LoadedMesh {
    let facets = mesh.triangles.len() as u64;
    let raw = RawMesh {
        format: Format::Generated,
        solids: 1,
        facets_read: facets,
        corners_read: 3 * facets,
        collapsed_facets: 0,
        mesh,
        warnings: Vec::new(),
    };
    finish(raw, Units::Mm).expect("generated meshes have area")
}

/// A welded mesh as a reader produced it, before unit conversion and topology.
#[derive(Debug)]
pub struct RawMesh {
    /// Format read.
    pub format: Format,
    /// Solid blocks.
    pub solids: u64,
    /// Facets in the file.
    pub facets_read: u64,
    /// Corners before welding.
    pub corners_read: u64,
    /// Facets dropped by welding.
    pub collapsed_facets: u64,
    /// The welded mesh in file units.
    pub mesh: Mesh,
    /// Reader warnings.
    pub warnings: Vec<String>,
}

fn finish(raw: RawMesh, units: Units) -> Result<LoadedMesh, LoadError> {
    let RawMesh {
        format,
        solids,
        facets_read,
        corners_read,
        collapsed_facets,
        mut mesh,
        mut warnings,
    } = raw;
    mesh.scale(units.mm_per_unit());
    // The topology and the pass over the triangles that sums the area and the centres need
    // nothing of each other: they run side by side, and one fills the time the other's
    // sequential steps leave a thread idle.
    let (mut topology, mut sums) = rayon::join(|| Topology::new(&mesh), || Sums::of(&mesh));
    // A repeated triangle makes its edges non-manifold, so a mesh without such edges has
    // none (but for a mesh of two copies of one triangle): only then are they looked for.
    let duplicate_triangles = if topology.non_manifold_edges > 0 || mesh.triangles.len() <= 2 {
        drop_duplicates(&mut mesh.triangles)
    } else {
        0
    };
    if duplicate_triangles > 0 {
        topology = Topology::new(&mesh);
        sums = Sums::of(&mesh);
        warnings.push(format!(
            "{duplicate_triangles} triangles repeat an earlier triangle's three vertices and were dropped"
        ));
    }
    // Facets wound against their neighbours, or a set of them facing inwards, are turned
    // round before anything reads which side a facet faces.
    let (reoriented_triangles, all_turned) =
        orient::outward(&mut mesh, &topology, sums.centres.volume_mm3);
    if reoriented_triangles > 0 {
        topology = Topology::new(&mesh);
        sums = Sums::of(&mesh);
        warnings.push(if all_turned {
            format!(
                "every facet was wound inwards (the normals pointed into the solid, so the volume came out negative) and all {reoriented_triangles} were turned round"
            )
        } else {
            let (facets, were, their) = if reoriented_triangles == 1 {
                ("facet", "was", "its")
            } else {
                ("facets", "were", "their")
            };
            format!(
                "{reoriented_triangles} {facets} {were} wound against {their} neighbours or faced into the solid and {were} turned round (the volume, the parting line and the walls read which side a facet faces)"
            )
        });
    }
    let Sums {
        bounds,
        area,
        zero_area,
        centres,
    } = sums;
    if area <= 0.0 {
        return Err(LoadError::NoArea {
            facets: facets_read,
        });
    }
    if collapsed_facets > 0 {
        warnings.push(format!(
            "{collapsed_facets} degenerate facets (two corners at the same point) were dropped"
        ));
    }
    if zero_area > 0 {
        warnings.push(format!(
            "{zero_area} triangles have zero area (collinear corners)"
        ));
    }
    if topology.open_edges > 0 {
        warnings.push(format!(
            "the mesh is open: {} edges belong to one triangle only; thickness is unknown where rays do not leave the solid",
            topology.open_edges
        ));
    }
    if topology.non_manifold_edges > 0 {
        warnings.push(format!(
            "{} edges are shared by more than two triangles",
            topology.non_manifold_edges
        ));
    }
    if topology.bodies > 1 {
        warnings.push(format!(
            "the file holds {} separate bodies",
            topology.bodies
        ));
    }
    if let Some(w) = units::size_warning(bounds.diagonal(), units) {
        warnings.push(w);
    }
    let stats = MeshStats {
        format,
        units,
        facets_read,
        solids,
        corners_read,
        vertices: mesh.vertices.len() as u64,
        triangles: mesh.triangles.len() as u64,
        collapsed_facets,
        duplicate_triangles,
        reoriented_triangles,
        zero_area_triangles: zero_area,
        open_edges: topology.open_edges,
        non_manifold_edges: topology.non_manifold_edges,
        bodies: topology.bodies,
        area_mm2: area,
        bounds_min: bounds.min.to_array(),
        bounds_max: bounds.max.to_array(),
        size_suggests_other_units: units::size_is_suspicious(bounds.diagonal()),
    };
    Ok(LoadedMesh {
        mesh,
        stats,
        warnings,
        topology,
        centres,
    })
}

/// What one pass over the triangles measures at load: the box, the area, the triangles of
/// zero area, and the centres of mass.
struct Sums {
    bounds: Aabb,
    area: f64,
    zero_area: u64,
    centres: Centres,
}

impl Sums {
    fn of(mesh: &Mesh) -> Sums {
        // Areas are taken relative to the box centre, as the centre of mass takes them, so
        // that a part far from the origin does not get a non-zero area from cancellation
        // here and a zero one there (the readers keep every coordinate within
        // MAX_COORDINATE_MM, so the products stay finite).
        let bounds = mesh.bounds();
        let origin = bounds.centre();
        // Summed in fixed blocks, in parallel, and the blocks' sums in order: the same area
        // whatever the number of threads. The same pass sums the moments of the centres of
        // mass, in the runs of `Centres::of` (two a block), so that `locate` need not go
        // over the triangles again for them.
        const BLOCK: usize = 2 * centre::RUN;
        let blocks: Vec<(f64, u64, [Option<Moments>; 2])> = mesh
            .triangles
            .par_chunks(BLOCK)
            .enumerate()
            .map(|(b, block)| {
                let (mut area, mut zero_area) = (0.0, 0u64);
                let mut runs = [None; 2];
                for (r, run) in block.chunks(centre::RUN).enumerate() {
                    let mut moments = Moments::default();
                    let first = b * BLOCK + r * centre::RUN;
                    for t in first..first + run.len() {
                        let [a, b, c] = mesh.corners(t).map(|p| p - origin);
                        let cross = (b - a).cross(c - a);
                        let a2 = cross.length();
                        zero_area += u64::from(a2 == 0.0);
                        area += 0.5 * a2;
                        moments.add([a, b, c], cross);
                    }
                    runs[r] = Some(moments);
                }
                (area, zero_area, runs)
            })
            .collect();
        let runs: Vec<Moments> = blocks.iter().flat_map(|b| b.2).flatten().collect();
        Sums {
            bounds,
            area: blocks.iter().map(|b| b.0).sum(),
            zero_area: blocks.iter().map(|b| b.1).sum(),
            centres: Centres::from_runs(&bounds, &runs),
        }
    }
}

/// Drops every triangle whose three vertices (in any order) are an earlier triangle's,
/// keeping the order of the others; returns how many were dropped.
fn drop_duplicates(triangles: &mut Vec<[u32; 3]>) -> u64 {
    let key = |t: &[u32; 3]| {
        let mut k = *t;
        k.sort_unstable();
        k
    };
    let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
    order.par_sort_unstable_by_key(|&i| (key(&triangles[i as usize]), i));
    let mut dropped = vec![false; triangles.len()];
    let mut count = 0;
    for pair in order.windows(2) {
        if key(&triangles[pair[0] as usize]) == key(&triangles[pair[1] as usize]) {
            dropped[pair[1] as usize] = true;
            count += 1;
        }
    }
    if count > 0 {
        let mut i = 0;
        triangles.retain(|_| {
            i += 1;
            !dropped[i - 1]
        });
    }
    count
}

/// Welds identical corner positions into shared vertices as facets arrive.
///
/// Positions are compared by their exact bit patterns (with -0.0 and every coordinate
/// nearer zero than [`NOISE_OF_ZERO`] read as 0.0): STL writers repeat a shared corner's
/// coordinates exactly, and any tolerance would merge real detail; only the rounding noise
/// of a CAD exporter's rotations at zero (a corner written as 0 in one facet and -2.7e-16
/// in the next) is not a position of its own.
/// The index is an open-addressing table of vertex numbers (4 bytes a slot, at most half
/// full) that compares against the vertex list itself, so it costs a fraction of a map that
/// stores the keys. The bits of a slot above the vertex number (those the table's size
/// leaves free) hold bits of the position's hash: a probe reads the vertex a slot names only
/// when they match, so a new vertex rarely costs more than the one read of its empty slot.
#[derive(Debug)]
pub struct Welder {
    slots: Vec<u32>,
    /// A small direct-mapped cache of recently welded positions: neighbouring facets of a
    /// file share corners, and a hit here skips the probe of the large table.
    recent: Vec<([u64; 3], u32)>,
    mesh: Mesh,
    collapsed: u64,
}

const RECENT: usize = 4096;

const EMPTY: u32 = u32::MAX;

/// Coordinates of a smaller magnitude than this (2^-40, about 9.1e-13, in the file's
/// units) are read as 0 when corners are welded: a picometre in metres, far below any
/// detail of a moulded part in any unit, and where the rounding of an exporter's rotations
/// leaves corners that are at zero (cos 90 degrees is 6.1e-17 in doubles).
pub const NOISE_OF_ZERO: f64 = 1.0 / (1u64 << 40) as f64;

/// A coordinate as welding reads it: 0.0 for -0.0 and for a value nearer zero than
/// [`NOISE_OF_ZERO`], else itself.
#[inline(always)]
fn weld_coordinate(x: f64) -> f64 {
    if x.abs() < NOISE_OF_ZERO {
        0.0
    } else {
        x
    }
}

/// A position as welding reads it ([`weld_coordinate`] of each coordinate).
#[inline(always)]
pub(crate) fn weld_position(p: DVec3) -> DVec3 {
    p.map(weld_coordinate)
}

/// Bit patterns of a position as welding reads it.
#[inline]
fn position_bits(p: DVec3) -> [u64; 3] {
    let p = weld_position(p);
    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
}

#[inline]
fn hash_of(bits: [u64; 3]) -> u64 {
    let h = bits[0].wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(23)
        ^ bits[1].wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ bits[2].wrapping_mul(0x1656_67B1_9E37_79F9).rotate_left(41);
    (h ^ (h >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9)
}

/// The bits of a table slot above the vertex numbers of a table of `mask + 1` slots, taken
/// from the hash's low half (its high half picks the slot).
#[inline]
fn tag_of(hash: u64, mask: usize) -> u32 {
    hash as u32 & !(mask as u32)
}

impl Welder {
    /// A welder expecting about `triangles` facets.
    pub fn with_capacity(triangles: usize) -> Welder {
        Welder::for_run(triangles, triangles)
    }

    /// A welder for a run of about `triangles` facets whose triangle list has room for
    /// `room` (the whole file's, for the run that [`Welder::join`] extends).
    pub fn for_run(triangles: usize, room: usize) -> Welder {
        // A closed mesh has about half as many vertices as triangles; a sixteenth more keeps
        // slightly open or fragmented meshes from reallocating. The table starts at most
        // half full (it grows at half): with the hash bits in the slots, a longer probe reads
        // neighbouring slots and no vertices, and the smaller table stays in the processor's
        // cache (1 MiB a run of the 352k part).
        let vertices = |t: usize| t / 2 + t / 16 + 16;
        Welder {
            slots: vec![EMPTY; (2 * vertices(triangles)).next_power_of_two()],
            recent: vec![([u64::MAX; 3], EMPTY); RECENT],
            mesh: Mesh {
                vertices: Vec::with_capacity(vertices(room.max(triangles))),
                triangles: Vec::with_capacity(room.max(triangles)),
            },
            collapsed: 0,
        }
    }

    /// The vertex at `p`, if welded here; the table is only read.
    fn find(&self, p: DVec3) -> Option<u32> {
        let bits = position_bits(p);
        self.probe(bits, hash_of(bits)).ok()
    }

    #[inline(always)]
    fn vertex(&mut self, p: DVec3) -> u32 {
        if 2 * (self.mesh.vertices.len() + 1) > self.slots.len() {
            self.grow();
        }
        let bits = position_bits(p);
        let hash = hash_of(bits);
        let cached = hash as usize % RECENT;
        if self.recent[cached].0 == bits {
            return self.recent[cached].1;
        }
        let v = match self.probe(bits, hash) {
            Ok(v) => v,
            Err((slot, tag)) => {
                let next = self.mesh.vertices.len() as u32;
                self.slots[slot] = tag | next;
                self.mesh.vertices.push(weld_position(p));
                next
            }
        };
        self.recent[cached] = (bits, v);
        v
    }

    /// The vertex with these position bits, or the empty slot where it belongs and the
    /// slot's value for vertex 0 (the hash bits to add the vertex number to).
    #[inline(always)]
    fn probe(&self, bits: [u64; 3], hash: u64) -> Result<u32, (usize, u32)> {
        let mask = self.slots.len() - 1;
        let tag = tag_of(hash, mask);
        let mut slot = (hash >> 32) as usize & mask;
        loop {
            let s = self.slots[slot];
            if s == EMPTY {
                return Err((slot, tag));
            }
            // Vertex numbers stay below half the table's size, so `s & mask` is the
            // number and an occupied slot is never EMPTY.
            if s & !(mask as u32) == tag {
                let v = s & mask as u32;
                if position_bits(self.mesh.vertices[v as usize]) == bits {
                    return Ok(v);
                }
            }
            slot = (slot + 1) & mask;
        }
    }

    fn grow(&mut self) {
        let size = (2 * self.slots.len()).max(64);
        self.slots = vec![EMPTY; size];
        let mask = size - 1;
        for (v, &p) in self.mesh.vertices.iter().enumerate() {
            let hash = hash_of(position_bits(p));
            let mut slot = (hash >> 32) as usize & mask;
            while self.slots[slot] != EMPTY {
                slot = (slot + 1) & mask;
            }
            self.slots[slot] = tag_of(hash, mask) | v as u32;
        }
    }

    /// Adds one facet; a facet whose corners weld to fewer than three vertices is dropped
    /// and counted.
    pub fn push(&mut self, corners: [DVec3; 3]) {
        let a = self.vertex(corners[0]);
        let b = self.vertex(corners[1]);
        let c = self.vertex(corners[2]);
        if a == b || b == c || a == c {
            self.collapsed += 1;
        } else {
            self.mesh.triangles.push([a, b, c]);
        }
    }

    /// Joins welders that welded consecutive runs of one file, in file order, into the mesh
    /// one welder would have made of the whole file: vertices numbered by first appearance,
    /// triangles in order. Also returns the number of dropped facets.
    ///
    /// Each later run's vertices are looked up in the tables of the runs before it, in
    /// parallel (the tables are only read); the earliest run that holds a vertex numbers it.
    /// Only the numbering of each run's new vertices is sequential: a count.
    pub fn join(runs: Vec<Welder>) -> (Mesh, u64) {
        let mut runs = runs.into_iter();
        let Some(mut whole) = runs.next() else {
            return (Mesh::default(), 0);
        };
        let later: Vec<Welder> = runs.collect();
        // found[i][l]: (earlier run << 32 | its vertex) for vertex l of run i + 1, or NEW.
        let found: Vec<Vec<u64>> = later
            .par_iter()
            .enumerate()
            .map(|(i, run)| {
                run.mesh
                    .vertices
                    .par_iter()
                    .map(|&p| {
                        std::iter::once(&whole)
                            .chain(&later[..i])
                            .enumerate()
                            .find_map(|(j, earlier)| {
                                earlier.find(p).map(|v| (j as u64) << 32 | u64::from(v))
                            })
                            .unwrap_or(NEW)
                    })
                    .collect()
            })
            .collect();
        let number = join_numbers(whole.mesh.vertices.len() as u32, &found);
        for ((run, found), number) in later.iter().zip(&found).zip(&number) {
            whole.mesh.vertices.extend(
                run.mesh
                    .vertices
                    .iter()
                    .zip(found)
                    .filter(|(_, &f)| f == NEW)
                    .map(|(&p, _)| p),
            );
            whole.mesh.triangles.par_extend(
                run.mesh
                    .triangles
                    .par_iter()
                    .map(|tri| tri.map(|v| number[v as usize])),
            );
            whole.collapsed += run.collapsed;
        }
        whole.finish()
    }

    /// The welded mesh and the number of dropped facets.
    pub fn finish(self) -> (Mesh, u64) {
        (self.mesh, self.collapsed)
    }
}

/// A later run's vertex in the join of welded runs (`found[i][l]`, for vertex l of run i + 1)
/// that no earlier run holds; otherwise `earlier run << 32 | its vertex there`.
pub(super) const NEW: u64 = u64::MAX;

/// number[i][l]: the number of vertex l of run i + 1 in the whole mesh, the first run's
/// vertices being 0..first and the new ones numbered on from there in order. A vertex found
/// in an earlier run is new there, so that run has numbered it already.
pub(super) fn join_numbers(first: u32, found: &[Vec<u64>]) -> Vec<Vec<u32>> {
    let mut next = first;
    let mut number: Vec<Vec<u32>> = Vec::with_capacity(found.len());
    for found in found {
        let numbered = found
            .iter()
            .map(|&f| match f {
                NEW => {
                    next += 1;
                    next - 1
                }
                _ => match (f >> 32) as usize {
                    0 => f as u32,
                    j => number[j - 1][f as u32 as usize],
                },
            })
            .collect();
        number.push(numbered);
    }
    number
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positions on a small lattice (many repeats), with -0.0 beside 0.0, values in the
    /// noise at zero and 2^-40 itself beside them, and neighbours one bit apart, from a
    /// seeded generator.
    fn corners(n: usize, seed: u64) -> Vec<DVec3> {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) as u32
        };
        (0..n)
            .map(|_| {
                let mut c = [0.0f64; 3];
                for x in &mut c {
                    let r = next();
                    *x = match r % 8 {
                        0 => 0.0,
                        1 => -0.0,
                        2 => f64::from_bits(1.0f64.to_bits() + u64::from(r % 3)),
                        3 => {
                            [-2.731_848e-16, 6.1e-17, 1e-300, -NOISE_OF_ZERO][(r / 8 % 4) as usize]
                        }
                        _ => f64::from(r % 11) * 0.5 - 2.0,
                    };
                }
                DVec3::from_array(c)
            })
            .collect()
    }

    /// The vertices and triangle corners welding must give: positions numbered by first
    /// appearance, compared by bits with -0.0 read as 0.0.
    fn brute_force(corners: &[DVec3]) -> (Vec<[u64; 3]>, Vec<u32>) {
        let mut seen: Vec<[u64; 3]> = Vec::new();
        let numbers = corners
            .iter()
            .map(|&p| {
                let bits = position_bits(p);
                match seen.iter().position(|&s| s == bits) {
                    Some(v) => v as u32,
                    None => {
                        seen.push(bits);
                        (seen.len() - 1) as u32
                    }
                }
            })
            .collect();
        (seen, numbers)
    }

    #[test]
    fn welding_with_hash_bits_in_the_slots_matches_brute_force_through_every_growth() {
        for seed in 0..4 {
            let all = corners(3 * 4000, seed);
            let (expected_vertices, expected) = brute_force(&all);
            // A welder sized for one facet grows many times, and each growth changes how
            // many hash bits a slot holds.
            let mut welder = Welder::with_capacity(1);
            let mut kept = Vec::new();
            for (f, facet) in all.chunks_exact(3).enumerate() {
                welder.push([facet[0], facet[1], facet[2]]);
                let e = &expected[3 * f..3 * f + 3];
                if e[0] != e[1] && e[1] != e[2] && e[0] != e[2] {
                    kept.push([e[0], e[1], e[2]]);
                }
            }
            let (mesh, collapsed) = welder.finish();
            let bits: Vec<[u64; 3]> = mesh.vertices.iter().map(|&p| position_bits(p)).collect();
            assert_eq!(bits, expected_vertices, "seed {seed}");
            assert_eq!(mesh.triangles, kept, "seed {seed}");
            assert_eq!(collapsed as usize, all.len() / 3 - kept.len());
        }
    }

    #[test]
    fn a_corner_in_the_noise_at_zero_is_the_corner_at_zero() {
        // The second facet repeats two corners of the first as an exporter's rotation
        // writes them; its third corner is 2^-40 from a corner, a position of its own.
        let noise = -2.731_848e-16;
        let mut welder = Welder::with_capacity(2);
        welder.push([DVec3::ZERO, DVec3::X, DVec3::Y]);
        welder.push([
            DVec3::new(noise, -0.0, 6.1e-17),
            DVec3::new(noise, 1.0, 0.0),
            DVec3::new(1.0, 0.0, NOISE_OF_ZERO),
        ]);
        let (mesh, collapsed) = welder.finish();
        assert_eq!(collapsed, 0);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(mesh.vertices[3], DVec3::new(1.0, 0.0, NOISE_OF_ZERO));
        // Stored as zero, not as the noise of the corner that came first.
        let mut welder = Welder::with_capacity(1);
        welder.push([DVec3::new(noise, 0.0, 0.0), DVec3::X, DVec3::Y]);
        let (mesh, _) = welder.finish();
        assert_eq!(mesh.vertices[0].x.to_bits(), 0);
    }

    /// The centres summed at load, in the pass that measures the area, are those of
    /// `Centres::of` to the bit: on the samples, and on a subdivided one long enough for
    /// several blocks of the pass and an odd number of runs.
    #[test]
    fn centres_summed_at_load_are_those_of_the_mesh() {
        let mut meshes: Vec<Mesh> = crate::samples::SAMPLES
            .iter()
            .map(|s| crate::samples::sample(s.name).unwrap())
            .collect();
        let mut big = crate::samples::sample("cap").unwrap();
        while big.triangles.len() <= 5 * crate::centre::RUN {
            big = big.subdivided();
        }
        big.triangles.truncate(5 * crate::centre::RUN + 77);
        meshes.push(big);
        for mesh in meshes {
            let loaded = from_generated(mesh);
            let expected = Centres::of(&loaded.mesh);
            let bits = |c: &Centres| {
                (
                    c.surface.to_array().map(f64::to_bits),
                    c.area_mm2.to_bits(),
                    c.volume.map(|v| v.to_array().map(f64::to_bits)),
                    c.volume_mm3.to_bits(),
                )
            };
            assert_eq!(bits(&loaded.centres), bits(&expected));
        }
    }

    #[test]
    fn joined_runs_weld_as_one_welder() {
        let all = corners(3 * 6000, 7);
        let mut one = Welder::with_capacity(6000);
        for facet in all.chunks_exact(3) {
            one.push([facet[0], facet[1], facet[2]]);
        }
        let (whole, whole_collapsed) = one.finish();
        let runs: Vec<Welder> = all
            .chunks(3 * 1500)
            .map(|run| {
                let mut w = Welder::for_run(run.len() / 3, 6000);
                for facet in run.chunks_exact(3) {
                    w.push([facet[0], facet[1], facet[2]]);
                }
                w
            })
            .collect();
        let (joined, joined_collapsed) = Welder::join(runs);
        assert_eq!(joined.vertices, whole.vertices);
        assert_eq!(joined.triangles, whole.triangles);
        assert_eq!(joined_collapsed, whole_collapsed);
    }
}
