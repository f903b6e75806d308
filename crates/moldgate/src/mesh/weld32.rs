//! Welding the corners of a binary STL on their `f32` bits.
//!
//! A binary STL stores single-precision corners. Widening an `f32` to `f64` is exact and
//! keeps distinct values distinct, so welding on the 12 bytes of the file's own bits (with
//! -0.0 and values nearer zero than [`super::NOISE_OF_ZERO`] read as 0.0) gives the same vertices, in the same order, as [`super::Welder`]
//! welding the widened positions on their 24 bytes; the vertices are widened once, at the
//! end. A corner's position is looked up far more often than a vertex is made (a vertex of
//! a closed mesh has about six triangles, and the corners of a file come in no useful
//! order), so the look-up is most of the cost of loading a large file, and it is bound by
//! the latency of memory: the table and the keys are kept small enough to stay in the
//! processor's cache. The table holds 4-byte slots (a vertex number, and in the bits the
//! table's size leaves free, bits of the position's hash) at most half full, and the keys
//! are a list of 12 bytes a vertex beside it: a probe reads one slot, and the key only
//! when the hash bits match (for a new vertex almost never). A run of half the 352k part
//! holds a 1 MiB table and 1.2 MB of keys, against the 2 to 4 MiB table of 16-byte slots
//! (key and number together) that this replaced.

use rayon::prelude::*;

use super::{join_numbers, Mesh, NEW};
use crate::math::DVec3;

/// The bits of a corner's three coordinates, as [`key_bits`] reads them.
pub(super) type Key = [u32; 3];

/// The welding key of a coordinate's bits (a finite value: NaN is refused before
/// welding): 0.0 for -0.0 and for a magnitude below [`super::NOISE_OF_ZERO`] (2^-40, exact
/// in `f32`), as the `f64` welder reads them, and every other value is its own.
#[inline(always)]
pub(super) fn key_bits(bits: u32) -> u32 {
    // Below the bits of 2^-40 (biased exponent 87) in magnitude.
    const NOISE: u32 = 87 << 23;
    if bits & 0x7fff_ffff < NOISE {
        0
    } else {
        bits
    }
}

#[inline(always)]
fn hash_of(key: Key) -> u64 {
    let xy = u64::from(key[0]) | u64::from(key[1]) << 32;
    let h = xy.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ u64::from(key[2]).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    (h ^ (h >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9)
}

/// Facets a [`Welder32::push_batch`] takes.
pub const BATCH: usize = 16;

/// The largest table made before any vertex is welded (2^30 slots); beyond it a table
/// grows with its vertices.
const MAX_FIRST_BITS: u32 = 30;

/// Welds binary STL facets, given as the bits of their corners, into shared vertices.
///
/// An open-addressing table (linear probing, at most half full) of vertex numbers with
/// hash bits, beside the list of the vertices' keys; vertices are numbered by first
/// appearance, as [`super::Welder`] numbers them, and runs of consecutive facets welded
/// apart are joined by [`Welder32::join`] into the mesh one welder would have made.
#[derive(Debug)]
pub struct Welder32 {
    /// Per slot 0 (free), or the hash bits above the table's index bits and the vertex
    /// number plus one below them. Vertex numbers stay below half the table's size, so the
    /// number plus one fits below the hash bits; a zeroed allocation is an empty table.
    slots: Vec<u32>,
    /// log2 of the table's size: the slot of a key is the top `bits` of its hash.
    bits: u32,
    /// The vertices' keys, by vertex number.
    keys: Vec<Key>,
    /// The welded triangles.
    triangles: Vec<[u32; 3]>,
    collapsed: u64,
}

impl Welder32 {
    /// A welder for a run of about `triangles` facets whose triangle list has room for
    /// `room` (the whole file's, for the run that [`Welder32::join`] extends).
    pub fn for_run(triangles: usize, room: usize) -> Welder32 {
        // A closed mesh has about half as many vertices as triangles; a thirty-second more
        // for the run's own border and slightly open meshes. At most half full: a run of
        // the 352k part has 2^18 slots (1 MiB) for its 100,000 vertices. The keys' list
        // has room for more (room never written costs no memory).
        let vertices = triangles / 2 + triangles / 32 + 16;
        let bits = (2 * vertices)
            .next_power_of_two()
            .trailing_zeros()
            .clamp(6, MAX_FIRST_BITS);
        Welder32 {
            slots: vec![0; 1 << bits],
            bits,
            keys: Vec::with_capacity(triangles / 2 + triangles / 4 + 16),
            triangles: Vec::with_capacity(room.max(triangles)),
            collapsed: 0,
        }
    }

    /// The mask of the index bits of a slot (and of the vertex number plus one).
    #[inline(always)]
    fn mask(&self) -> u32 {
        (self.slots.len() - 1) as u32
    }

    /// The vertex with this key, if welded here; the table is only read.
    fn find(&self, key: Key) -> Option<u32> {
        let hash = hash_of(key);
        let mask = self.mask();
        let tag = hash as u32 & !mask;
        let mut at = (hash >> (64 - self.bits)) as usize;
        loop {
            let s = self.slots[at];
            if s == 0 {
                return None;
            }
            if s & !mask == tag {
                let v = (s & mask) - 1;
                if self.keys[v as usize] == key {
                    return Some(v);
                }
            }
            at = (at + 1) & mask as usize;
        }
    }

    #[inline(always)]
    fn vertex(&mut self, key: Key) -> u32 {
        self.vertex_hashed(key, hash_of(key))
    }

    /// [`Welder32::vertex`] for a key whose hash is known.
    #[inline(always)]
    fn vertex_hashed(&mut self, key: Key, hash: u64) -> u32 {
        let mask = self.mask();
        let tag = hash as u32 & !mask;
        let mut at = (hash >> (64 - self.bits)) as usize;
        loop {
            let s = self.slots[at];
            if s == 0 {
                let v = self.keys.len() as u32;
                self.slots[at] = tag | (v + 1);
                self.keys.push(key);
                if 2 * self.keys.len() > self.slots.len() {
                    self.grow();
                }
                return v;
            }
            if s & !mask == tag {
                let v = (s & mask) - 1;
                if self.keys[v as usize] == key {
                    return v;
                }
            }
            at = (at + 1) & mask as usize;
        }
    }

    /// Doubles the table: every key is placed again, with the hash bits of the new size.
    fn grow(&mut self) {
        self.bits += 1;
        self.slots = vec![0; 1 << self.bits];
        let mask = self.mask();
        for (v, &key) in self.keys.iter().enumerate() {
            let hash = hash_of(key);
            let mut at = (hash >> (64 - self.bits)) as usize;
            while self.slots[at] != 0 {
                at = (at + 1) & mask as usize;
            }
            self.slots[at] = hash as u32 & !mask | (v as u32 + 1);
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
            self.triangles.push([a, b, c]);
        }
    }

    /// Adds facets as [`Welder32::push`] adds them one by one, reading every corner's first
    /// slot before the first of them is welded: those reads do not wait on each other, so
    /// their cache misses overlap, where in the welding each probe waits on the one before
    /// (its slot decides whether a vertex is made). The reads change nothing; the facets are
    /// then welded in order, the same vertices and numbering.
    pub fn push_batch(&mut self, facets: &[[Key; 3]; BATCH]) {
        let hashes: [[u64; 3]; BATCH] = facets.map(|f| f.map(hash_of));
        let shift = 64 - self.bits;
        let mut seen = 0u32;
        for h in hashes.iter().flatten() {
            seen ^= self.slots[(h >> shift) as usize];
        }
        std::hint::black_box(seen);
        for (f, h) in facets.iter().zip(&hashes) {
            let a = self.vertex_hashed(f[0], h[0]);
            let b = self.vertex_hashed(f[1], h[1]);
            let c = self.vertex_hashed(f[2], h[2]);
            if a == b || b == c || a == c {
                self.collapsed += 1;
            } else {
                self.triangles.push([a, b, c]);
            }
        }
    }

    /// The welded mesh and the number of dropped facets.
    pub fn finish(self) -> (Mesh, u64) {
        let mut vertices = Vec::with_capacity(self.keys.len());
        vertices.par_extend(self.keys.par_iter().map(|&k| widen(k)));
        let mesh = Mesh {
            vertices,
            triangles: self.triangles,
        };
        (mesh, self.collapsed)
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
        // Only the earlier runs' tables are searched: the last run's goes back now, so that
        // the join holds no more than the welding did.
        if let Some(last) = later.last_mut() {
            last.slots = Vec::new();
        }
        // found[i][l]: (earlier run << 32 | its vertex) for vertex l of run i + 1, or NEW.
        let found: Vec<Vec<u64>> = later
            .par_iter()
            .enumerate()
            .map(|(i, run)| {
                run.keys
                    .par_iter()
                    .map(|&key| {
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
        // The tables are done with: their memory goes back before the mesh is made.
        for run in std::iter::once(&mut whole).chain(&mut later) {
            run.slots = Vec::new();
        }
        let number = join_numbers(whole.keys.len() as u32, &found);
        let new: usize = found
            .iter()
            .map(|f| f.iter().filter(|&&f| f == NEW).count())
            .sum();
        let mut vertices = Vec::with_capacity(whole.keys.len() + new);
        vertices.par_extend(whole.keys.par_iter().map(|&k| widen(k)));
        whole.keys = Vec::new();
        for ((run, found), number) in later.iter_mut().zip(&found).zip(&number) {
            // A run's new vertices go straight into the room made for them, on this thread
            // beside the renumbering of its triangles: a filtered parallel extend would
            // collect them in blocks grown by copying (fresh pages, zeroed and faulted).
            let (keys, triangles) = (&run.keys, &run.triangles);
            rayon::join(
                || {
                    vertices.extend(
                        keys.iter()
                            .zip(found)
                            .filter(|(_, &f)| f == NEW)
                            .map(|(&k, _)| widen(k)),
                    )
                },
                || {
                    whole.triangles.par_extend(
                        triangles
                            .par_iter()
                            .map(|tri| tri.map(|v| number[v as usize])),
                    )
                },
            );
            run.keys = Vec::new();
            run.triangles = Vec::new();
            whole.collapsed += run.collapsed;
        }
        let mesh = Mesh {
            vertices,
            triangles: whole.triangles,
        };
        (mesh, whole.collapsed)
    }
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

    /// Corners on a small lattice (many repeats), with -0.0 beside 0.0, values in the noise
    /// at zero and 2^-40 itself beside them, and neighbours one bit apart, from a seeded
    /// generator.
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
                        3 => [-2.731_848e-16, 6.1e-17, 1e-40, -(2.0f32.powi(-40))]
                            [(r / 8 % 4) as usize],
                        _ => (r % 11) as f32 * 0.5 - 2.0,
                    }
                })
            })
            .collect()
    }

    fn key(c: [f32; 3]) -> Key {
        c.map(|x| key_bits(x.to_bits()))
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
    fn coordinates_in_the_noise_at_zero_are_welded_as_zero_and_no_others() {
        let edge = 2.0f32.powi(-40);
        for zero in [
            0.0f32,
            -0.0,
            -2.731_848e-16,
            6.1e-17,
            1e-40,
            edge.next_down(),
        ] {
            assert_eq!(key_bits(zero.to_bits()), 0, "{zero:e}");
            assert_eq!(key_bits((-zero).to_bits()), 0, "{:e}", -zero);
        }
        for kept in [edge, -edge, 1e-12, 1.0, -3.5e20] {
            assert_eq!(key_bits(kept.to_bits()), kept.to_bits(), "{kept:e}");
        }
        assert_eq!(f64::from(edge), crate::mesh::NOISE_OF_ZERO);
    }

    #[test]
    fn welding_in_batches_matches_welding_facet_by_facet() {
        for seed in 0..4 {
            // Not a whole number of batches; sized for one facet, so the table grows inside
            // batches, after their first slots were read with the smaller table's bits.
            let all = corners(3 * (40 * BATCH + 7), seed);
            let facets: Vec<[Key; 3]> = all
                .chunks_exact(3)
                .map(|f| [key(f[0]), key(f[1]), key(f[2])])
                .collect();
            let mut one = Welder32::for_run(1, 1);
            for &f in &facets {
                one.push(f);
            }
            let mut batched = Welder32::for_run(1, 1);
            let mut batches = facets.chunks_exact(BATCH);
            for b in &mut batches {
                batched.push_batch(b.try_into().expect("a batch"));
            }
            for &f in batches.remainder() {
                batched.push(f);
            }
            let ((a, ca), (b, cb)) = (one.finish(), batched.finish());
            assert!(same(&a, &b), "seed {seed}");
            assert_eq!(ca, cb, "seed {seed}");
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
