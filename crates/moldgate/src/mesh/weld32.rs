//! Welding the corners of a binary STL on their `f32` bits.
//!
//! A binary STL stores single-precision corners. Widening an `f32` to `f64` is exact and
//! keeps distinct values distinct, so welding on the 12 bytes of the file's own bits (with
//! -0.0 read as 0.0) gives the same vertices, in the same order, as [`super::Welder`]
//! welding the widened positions on their 24 bytes; the vertices are widened once, at the
//! end. Half the key also means half the table: each slot holds the position's bits beside
//! its vertex number (16 bytes), so a probe reads one place in memory, not a slot and then
//! the vertex it names. A corner's position is looked up far more often than a vertex is
//! made (a vertex of a closed mesh has about six triangles), so that one read is most of
//! the cost of loading a large file.

use rayon::prelude::*;

use super::{join_numbers, Mesh, NEW};
use crate::math::DVec3;

/// The bits of a corner's three coordinates, -0.0 made 0.0.
pub(super) type Key = [u32; 3];

/// One place of the table: a position's bits and its vertex number plus one (0 when the
/// place is free, so that a new table is memory the system hands over already zeroed).
type Slot = [u32; 4];

/// An entry of the recent-position cache: a key and its vertex number.
#[derive(Debug, Clone, Copy)]
struct Recent {
    key: Key,
    vertex: u32,
}

/// An empty cache entry. Its key is a NaN's bits, which the readers refuse before welding,
/// so it never matches a corner.
const UNUSED: Recent = Recent {
    key: [u32::MAX; 3],
    vertex: u32::MAX,
};

/// Entries of the direct-mapped cache of recent positions (64 KiB).
const RECENT: usize = 4096;

/// The welding key of a coordinate (finite: NaN is refused before welding).
#[inline(always)]
pub(super) fn key_bits(v: f32) -> u32 {
    (v + 0.0).to_bits()
}

#[inline(always)]
fn hash_of(key: Key) -> u64 {
    let xy = u64::from(key[0]) | u64::from(key[1]) << 32;
    let h = xy.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ u64::from(key[2]).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    (h ^ (h >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9)
}

/// Welds binary STL facets, given as the bits of their corners, into shared vertices.
///
/// An open-addressing table (linear probing, at most three quarters full) of slots that
/// hold the key itself; vertices are numbered by first appearance, as [`super::Welder`]
/// numbers them, and runs of consecutive facets welded apart are joined by
/// [`Welder32::join`] into the mesh one welder would have made.
#[derive(Debug)]
pub struct Welder32 {
    slots: Vec<Slot>,
    /// log2 of the table's size: the slot of a key is the top `bits` of its hash.
    bits: u32,
    /// A small direct-mapped cache of recently welded positions: neighbouring facets of a
    /// file share corners, and a hit here skips the probe of the large table.
    recent: Vec<Recent>,
    /// The welded vertices (widened) and triangles.
    mesh: Mesh,
    collapsed: u64,
}

impl Welder32 {
    /// A welder for a run of about `triangles` facets whose triangle list has room for
    /// `room` (the whole file's, for the run that [`Welder32::join`] extends).
    pub fn for_run(triangles: usize, room: usize) -> Welder32 {
        // A closed mesh has about half as many vertices as triangles; a thirty-second more
        // for the run's own border and slightly open meshes. At most three quarters full:
        // a run of the 352k part has 2^17 slots (2 MiB) for its 88,000 vertices.
        let vertices = triangles / 2 + triangles / 32 + 16;
        let bits = (vertices * 4 / 3)
            .next_power_of_two()
            .trailing_zeros()
            .max(6);
        Welder32 {
            slots: vec![[0; 4]; 1 << bits],
            bits,
            recent: vec![UNUSED; RECENT],
            mesh: Mesh {
                vertices: Vec::with_capacity({
                    let t = room.max(triangles);
                    t / 2 + t / 16 + 16
                }),
                triangles: Vec::with_capacity(room.max(triangles)),
            },
            collapsed: 0,
        }
    }

    #[inline(always)]
    fn home(&self, hash: u64) -> usize {
        (hash >> (64 - self.bits)) as usize
    }

    /// The vertex with this key, if welded here; the table is only read.
    fn find(&self, key: Key) -> Option<u32> {
        let mask = self.slots.len() - 1;
        let mut at = self.home(hash_of(key));
        loop {
            let [x, y, z, v] = self.slots[at];
            if v == 0 {
                return None;
            }
            if [x, y, z] == key {
                return Some(v - 1);
            }
            at = (at + 1) & mask;
        }
    }

    #[inline(always)]
    fn vertex(&mut self, key: Key) -> u32 {
        let hash = hash_of(key);
        // The hash's middle bits: the top ones pick the slot, the low ones mix less.
        let cached = (hash >> 20) as usize % RECENT;
        if self.recent[cached].key == key {
            return self.recent[cached].vertex;
        }
        let mask = self.slots.len() - 1;
        let mut at = self.home(hash);
        let v = loop {
            let [x, y, z, v] = self.slots[at];
            if v == 0 {
                let next = self.mesh.vertices.len() as u32;
                self.slots[at] = [key[0], key[1], key[2], next + 1];
                self.mesh.vertices.push(widen(key));
                if 4 * self.mesh.vertices.len() > 3 * self.slots.len() {
                    self.grow();
                }
                break next;
            }
            if [x, y, z] == key {
                break v - 1;
            }
            at = (at + 1) & mask;
        };
        self.recent[cached] = Recent { key, vertex: v };
        v
    }

    fn grow(&mut self) {
        self.bits += 1;
        let old = std::mem::replace(&mut self.slots, vec![[0; 4]; 1 << self.bits]);
        let mask = self.slots.len() - 1;
        for slot in old.into_iter().filter(|s| s[3] != 0) {
            let mut at = self.home(hash_of([slot[0], slot[1], slot[2]]));
            while self.slots[at][3] != 0 {
                at = (at + 1) & mask;
            }
            self.slots[at] = slot;
        }
    }

    /// Adds one facet by its corners' keys; a facet whose corners weld to fewer than three
    /// vertices is dropped and counted.
    #[inline]
    pub fn push(&mut self, corners: [Key; 3]) {
        let a = self.vertex(corners[0]);
        let b = self.vertex(corners[1]);
        let c = self.vertex(corners[2]);
        if a == b || b == c || a == c {
            self.collapsed += 1;
        } else {
            self.mesh.triangles.push([a, b, c]);
        }
    }

    /// The welded mesh and the number of dropped facets.
    pub fn finish(self) -> (Mesh, u64) {
        (self.mesh, self.collapsed)
    }

    /// Joins welders that welded consecutive runs of one file, in file order, into the mesh
    /// one welder would have made of the whole file: vertices numbered by first appearance,
    /// triangles in order. Also returns the number of dropped facets.
    ///
    /// Each later run's vertices are looked up in the tables of the runs before it, in
    /// parallel (the tables are only read); the earliest run that holds a vertex numbers it.
    /// Only the numbering of each run's new vertices is sequential: a count.
    pub fn join(runs: Vec<Welder32>) -> (Mesh, u64) {
        let mut runs = runs.into_iter();
        let Some(mut whole) = runs.next() else {
            return (Mesh::default(), 0);
        };
        let mut later: Vec<Welder32> = runs.collect();
        // Only the earlier runs' tables are searched: the last run's goes back now, and
        // every cache, so that the join holds no more than the welding did.
        if let Some(last) = later.last_mut() {
            last.slots = Vec::new();
        }
        for run in std::iter::once(&mut whole).chain(&mut later) {
            run.recent = Vec::new();
        }
        // found[i][l]: (earlier run << 32 | its vertex) for vertex l of run i + 1, or NEW.
        let found: Vec<Vec<u64>> = later
            .par_iter()
            .enumerate()
            .map(|(i, run)| {
                run.mesh
                    .vertices
                    .par_iter()
                    .map(|&p| {
                        let key = narrow(p);
                        std::iter::once(&whole)
                            .chain(&later[..i])
                            .enumerate()
                            .find_map(|(j, earlier)| {
                                earlier.find(key).map(|v| (j as u64) << 32 | u64::from(v))
                            })
                            .unwrap_or(NEW)
                    })
                    .collect()
            })
            .collect();
        // The tables are done with: their memory goes back before the mesh grows.
        for run in std::iter::once(&mut whole).chain(&mut later) {
            run.slots = Vec::new();
        }
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
}

/// The key of a welded vertex: its coordinates came from `f32`, so narrowing them back is
/// exact.
#[inline]
fn narrow(p: DVec3) -> Key {
    p.to_array().map(|x| (x as f32).to_bits())
}

/// The position of a key in `f64` (exact).
#[inline]
fn widen(key: Key) -> DVec3 {
    DVec3::new(
        f64::from(f32::from_bits(key[0])),
        f64::from(f32::from_bits(key[1])),
        f64::from(f32::from_bits(key[2])),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Welder;

    /// Corners on a small lattice (many repeats), with -0.0 beside 0.0 and neighbours one
    /// bit apart, from a seeded generator.
    fn corners(n: usize, seed: u64) -> Vec<[f32; 3]> {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) as u32
        };
        (0..n)
            .map(|_| {
                std::array::from_fn(|_| {
                    let r = next();
                    match r % 8 {
                        0 => 0.0,
                        1 => -0.0,
                        2 => f32::from_bits(1.0f32.to_bits() + r % 3),
                        _ => (r % 11) as f32 * 0.5 - 2.0,
                    }
                })
            })
            .collect()
    }

    fn key(c: [f32; 3]) -> Key {
        c.map(key_bits)
    }

    fn wide(c: [f32; 3]) -> DVec3 {
        DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)
    }

    /// The f64 welder, which the binary reader used before: the reference.
    fn welded_in_f64(all: &[[f32; 3]]) -> (Mesh, u64) {
        let mut welder = Welder::with_capacity(1);
        for f in all.chunks_exact(3) {
            welder.push([wide(f[0]), wide(f[1]), wide(f[2])]);
        }
        welder.finish()
    }

    fn same(a: &Mesh, b: &Mesh) -> bool {
        let bits = |m: &Mesh| -> Vec<[u64; 3]> {
            m.vertices
                .iter()
                .map(|v| v.to_array().map(f64::to_bits))
                .collect()
        };
        bits(a) == bits(b) && a.triangles == b.triangles
    }

    #[test]
    fn welding_on_f32_bits_matches_the_f64_welder_through_every_growth() {
        for seed in 0..4 {
            let all = corners(3 * 5000, seed);
            let (expected, expected_collapsed) = welded_in_f64(&all);
            // Sized for one facet: the table grows many times.
            let mut welder = Welder32::for_run(1, 1);
            for f in all.chunks_exact(3) {
                welder.push([key(f[0]), key(f[1]), key(f[2])]);
            }
            let (mesh, collapsed) = welder.finish();
            assert!(same(&mesh, &expected), "seed {seed}");
            assert_eq!(collapsed, expected_collapsed, "seed {seed}");
            assert!(mesh.vertices.iter().all(|v| v
                .to_array()
                .iter()
                .all(|x| x.to_bits() != (-0.0f64).to_bits())));
        }
    }

    #[test]
    fn joined_runs_weld_as_one_welder() {
        let all = corners(3 * 6000, 7);
        let (whole, whole_collapsed) = welded_in_f64(&all);
        for per_run in [6000, 1500, 1001, 97] {
            let runs: Vec<Welder32> = all
                .chunks(3 * per_run)
                .map(|run| {
                    let mut w = Welder32::for_run(run.len() / 3, 6000);
                    for f in run.chunks_exact(3) {
                        w.push([key(f[0]), key(f[1]), key(f[2])]);
                    }
                    w
                })
                .collect();
            let (joined, joined_collapsed) = Welder32::join(runs);
            assert!(same(&joined, &whole), "{per_run} facets a run");
            assert_eq!(joined_collapsed, whole_collapsed);
        }
    }
}
