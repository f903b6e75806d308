//! Shortest flow paths through the solid cells: the arrival field of a melt front.
//!
//! The field T solves the eikonal equation |grad T| = c(x) (c is the cost of a millimetre
//! of path at x: 1 for flow length, the flow resistance for fill order) by first-order fast
//! marching (Sethian) over the six face neighbours, as the front is accepted in order of T.
//! Each cell also takes the best straight step from any of its 26 neighbours,
//! T(u) + |u - v| (c(u) + c(v)) / 2, so that walls one cell thick, whose cells touch only at
//! edges or corners, still pass the melt. Fast marching alone would stop at such a wall;
//! the straight steps alone (Dijkstra on the 26-neighbour graph) overestimate lengths by up
//! to 8 % in directions between the axes and diagonals, and that error does not shrink as
//! cells get smaller. The first-order error of fast marching does.
//!
//! Cells of a source are seeded with their exact straight distance to the source point
//! (within 1.5 cells), which removes most of fast marching's error near a point source.

use crate::math::DVec3;

use super::voxel::{neighbour_offsets, Neighbours, Voxels};

/// A source of the melt: a point, seeded into the cells around it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Source {
    /// The point, mm.
    pub point: DVec3,
    /// The cell that holds it (see [`Voxels::cell_near`]).
    pub cell: u32,
}

/// An arrival field: T per solid cell (`f64::INFINITY` where the melt does not reach), and
/// for fields with several sources, which source reached each cell first.
#[derive(Debug, Clone)]
pub struct Field {
    /// Arrival value per cell: mm of path, weighted by the cost.
    pub t: Vec<f64>,
    /// Index of the source whose front arrived first, per cell (`u32::MAX` if unreached).
    pub source: Vec<u32>,
}

/// A queue entry: the value rounded up to f32 in the high half (the bits of a non-negative
/// f32 order like the number), the cell in the low half. Entries pop in order of value, then
/// of cell, so the march is deterministic; the exact value stays in the field.
#[inline]
fn key(t: f64, cell: u32) -> u64 {
    let mut f = t as f32;
    if (f as f64) < t {
        f = f32::from_bits(f.to_bits() + 1);
    }
    ((f.to_bits() as u64) << 32) | cell as u64
}

/// The march's priority queue: a 4-ary min-heap of [`key`]s holding each cell at most once,
/// with the position of each cell in it, so that a cell whose value falls moves up in place
/// instead of being pushed again. It pops the cells in the same order as a binary heap of
/// every key pushed that skips the cells already taken: each cell once, at its smallest key.
/// Against that heap it holds a quarter as many entries (a cell is improved about 3.5 times
/// before it is taken) and is half as deep.
pub(crate) struct Queue {
    heap: Vec<u64>,
    /// Position of each cell in `heap`; `u32::MAX` when not in it.
    at: Vec<u32>,
}

impl Queue {
    const ARITY: usize = 4;

    pub(crate) fn new(cells: usize) -> Queue {
        Queue {
            heap: Vec::new(),
            at: vec![u32::MAX; cells],
        }
    }

    /// Empties the queue for `cells` cells.
    fn clear(&mut self, cells: usize) {
        self.heap.clear();
        self.at.clear();
        self.at.resize(cells, u32::MAX);
    }

    /// Puts the cell of `key` in the queue at `key`, or moves it there if it is in the queue
    /// at a key not smaller (a value that fell).
    #[inline]
    pub(crate) fn set(&mut self, key: u64) {
        let cell = key as u32 as usize;
        let mut i = match self.at[cell] {
            u32::MAX => {
                self.heap.push(key);
                self.heap.len() - 1
            }
            i => i as usize,
        };
        while i > 0 {
            let parent = (i - 1) / Self::ARITY;
            let above = self.heap[parent];
            if above <= key {
                break;
            }
            self.heap[i] = above;
            self.at[above as u32 as usize] = i as u32;
            i = parent;
        }
        self.heap[i] = key;
        self.at[cell] = i as u32;
    }

    /// The cell of the smallest key, without taking it out.
    #[inline]
    fn peek_cell(&self) -> Option<u32> {
        self.heap.first().map(|&k| k as u32)
    }

    /// Takes the smallest key out.
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<u64> {
        let top = *self.heap.first()?;
        self.at[top as u32 as usize] = u32::MAX;
        let last = self.heap.pop().expect("not empty");
        let len = self.heap.len();
        if len > 0 {
            // Move the hole at the root down past every smaller child, then fill it.
            let mut i = 0;
            loop {
                let first = Self::ARITY * i + 1;
                if first >= len {
                    break;
                }
                let (child, least) = match self.heap.get(first..first + Self::ARITY) {
                    // All four children: the least without branches, and its place from
                    // the cell's own (the keys are distinct, so it is the one child the
                    // loop below finds).
                    Some(&[a, b, c, d]) => {
                        let least = a.min(b).min(c.min(d));
                        (self.at[least as u32 as usize] as usize, least)
                    }
                    _ => {
                        let mut child = first;
                        let mut least = self.heap[first];
                        for j in first + 1..len {
                            if self.heap[j] < least {
                                least = self.heap[j];
                                child = j;
                            }
                        }
                        (child, least)
                    }
                };
                if least >= last {
                    break;
                }
                self.heap[i] = least;
                self.at[least as u32 as usize] = i as u32;
                i = child;
            }
            self.heap[i] = last;
            self.at[last as u32 as usize] = i as u32;
        }
        Some(top)
    }
}

/// Marches the fronts of `sources` through `voxels`. `cost` gives the cost per mm of each
/// cell (`None`: 1 everywhere, the flow length).
pub fn march(voxels: &Voxels, sources: &[Source], cost: Option<&[f32]>) -> Field {
    // One loop per kind of cost, so that the cost of a cell is a plain load (or the
    // constant 1) inside the loop; both give the same numbers as a cost of 1 per cell.
    match cost {
        None => march_with(voxels, sources, |_| 1.0, |_, _| false).0,
        Some(c) => march_with(voxels, sources, |i| c[i as usize] as f64, |_, _| false).0,
    }
}

/// Marches like [`march`], but stops as soon as `stop(cell, t)` is true for a cell just
/// accepted (cells are accepted in order of their value, and an accepted value is final).
/// The searches use it when they need only the near part of a field: the nearest candidate,
/// or every cell of a share. Returns the field, with every cell not accepted set to
/// unreached (infinite, source `u32::MAX`), and the value of the last cell accepted
/// (infinite when the march ran to its end). Every accepted value has the same bits as in
/// the whole field, and a cell left out has a value of at least the one returned, to within
/// the f32 rounding of the queue's keys (a relative 2.4e-7).
pub fn march_until(
    voxels: &Voxels,
    sources: &[Source],
    cost: Option<&[f32]>,
    stop: impl FnMut(u32, f64) -> bool,
) -> (Field, f64) {
    let (mut field, stopped) = match cost {
        None => march_with(voxels, sources, |_| 1.0, stop),
        Some(c) => march_with(voxels, sources, |i| c[i as usize] as f64, stop),
    };
    match stopped {
        None => (field, f64::INFINITY),
        Some((reach, known)) => {
            for (c, k) in known.iter().enumerate() {
                if !k {
                    field.t[c] = f64::INFINITY;
                    field.source[c] = u32::MAX;
                }
            }
            (field, reach)
        }
    }
}

/// Seeds the march: the source cell and its neighbours within 1.5 cells of the point, at
/// their straight distance times the mean cost; the source cell itself always, even if the
/// point is off its centre.
fn seed(
    voxels: &Voxels,
    sources: &[Source],
    c: &impl Fn(u32) -> f64,
    t: &mut [f64],
    source: &mut [u32],
    mut push: impl FnMut(u64),
) {
    let h = voxels.h;
    let offsets = neighbour_offsets();
    for (s, src) in sources.iter().enumerate() {
        let mut seed_cell = |cell: u32| {
            let d = voxels.centre(cell).distance(src.point);
            if d <= 1.5 * h {
                let v = d * 0.5 * (c(src.cell) + c(cell));
                if v < t[cell as usize] {
                    t[cell as usize] = v;
                    source[cell as usize] = s as u32;
                    push(key(v, cell));
                }
            }
        };
        seed_cell(src.cell);
        for &(o, _) in &offsets {
            if let Some(nb) = voxels.neighbour(src.cell, o) {
                seed_cell(nb);
            }
        }
        if t[src.cell as usize].is_infinite() {
            let v = voxels.centre(src.cell).distance(src.point) * c(src.cell);
            t[src.cell as usize] = v;
            source[src.cell as usize] = s as u32;
            push(key(v, src.cell));
        }
    }
}

/// Cells accepted between two readings of the cells' cancellation token.
const CANCEL_CHECK: u32 = 4096;

/// The march; when `stop` ends it early, also the last value accepted and which cells were.
fn march_with(
    voxels: &Voxels,
    sources: &[Source],
    c: impl Fn(u32) -> f64,
    stop: impl FnMut(u32, f64) -> bool,
) -> (Field, Option<(f64, Vec<bool>)>) {
    match &voxels.table {
        Neighbours::Near(rows) => march_rows(voxels, sources, c, stop, rows.as_slice()),
        Neighbours::Far(rows) => march_rows(voxels, sources, c, stop, rows.as_slice()),
    }
}

/// An entry of a row of [`Neighbours`], as a march reads it: each kind of table gets a
/// march of its own, with the entry's reading inlined.
trait Entry: Copy {
    /// The neighbour this entry of cell `v`'s row names (`v` itself where there is none).
    fn neighbour(self, v: u32) -> u32;
}

impl Entry for u32 {
    #[inline(always)]
    fn neighbour(self, v: u32) -> u32 {
        match self {
            u32::MAX => v,
            u => u,
        }
    }
}

impl Entry for i16 {
    #[inline(always)]
    fn neighbour(self, v: u32) -> u32 {
        (v as i32 + i32::from(self)) as u32
    }
}

/// [`march_with`] on the rows of `table`.
fn march_rows<E: Entry>(
    voxels: &Voxels,
    sources: &[Source],
    c: impl Fn(u32) -> f64,
    mut stop: impl FnMut(u32, f64) -> bool,
    table: &[[E; 26]],
) -> (Field, Option<(f64, Vec<bool>)>) {
    let n = voxels.len();
    let h = voxels.h;
    let mut t = vec![f64::INFINITY; n];
    let mut source = vec![u32::MAX; n];
    // Per cell, the least accepted value of its two face neighbours along each axis
    // (infinite while neither is accepted): what the fast-marching update of the cell reads,
    // kept up to date as its face neighbours are accepted, so that the update reads one
    // row and not the six neighbours' values.
    let mut scratch = Scratch::take(n);
    let Scratch { axis_least, queue } = &mut scratch;
    let mut known = vec![false; n];
    let offsets = neighbour_offsets();

    seed(voxels, sources, &c, &mut t, &mut source, |k| queue.set(k));

    // Half the step length of each of the 26 neighbours (the straight step costs its
    // length times the mean of the two cells' costs). The neighbours are relaxed in an
    // unrolled sequence, the face neighbours (the fast-marching update) with their axis
    // known where they are written (4 and 21 along z, 10 and 15 along y, 12 and 13 along
    // x; a test holds these to `neighbour_offsets`): each neighbour's tests get a branch of
    // their own.
    let half_step: [f64; 26] = std::array::from_fn(|k| offsets[k].1 * h * 0.5);
    let cancel = voxels.cancel.as_ref();
    let mut accepted = 0u32;
    while let Some(entry) = queue.pop() {
        let v = entry as u32;
        // The next cell taken is most often the queue's top now: its row of neighbours is
        // asked from memory while this cell's are relaxed (a row is 52 or 104 bytes of a
        // table too large for the cache, and its first read was a quarter of the march's
        // time).
        if let Some(next) = queue.peek_cell() {
            read_ahead(&table[next as usize]);
        }
        known[v as usize] = true;
        let tv = t[v as usize];
        // A cancelled march stops as if `stop` had said so (its caller discards it).
        accepted = accepted.wrapping_add(1);
        let cancelled = accepted % CANCEL_CHECK == 0 && crate::cancel::is_set(cancel);
        if cancelled || stop(v, tv) {
            scratch.give_back();
            return (Field { t, source }, Some((tv, known)));
        }
        let cv = c(v);
        let sv = source[v as usize];
        let row = &table[v as usize];
        // A face neighbour: the straight step and the fast-marching update of u from its
        // accepted face neighbours, v now among them.
        macro_rules! relax_face {
            ($k:expr, $axis:expr) => {{
                // No neighbour there: v itself, accepted.
                let u = row[$k].neighbour(v);
                if !known[u as usize] {
                    let cu = c(u);
                    let least: &mut [f64; 3] = &mut axis_least[u as usize];
                    least[$axis] = least[$axis].min(tv);
                    let best = (tv + half_step[$k] * (cv + cu)).min(eikonal(*least, h * cu));
                    if best < t[u as usize] {
                        t[u as usize] = best;
                        source[u as usize] = sv;
                        queue.set(key(best, u));
                    }
                }
            }};
        }
        // An edge or corner neighbour: the straight step only. Whether u is accepted is
        // asked only when the step would lower it: an accepted cell's value is at most v's
        // (but for the f32 rounding of the queue's keys), so the step rarely would, and the
        // question is asked about one relaxation in eight instead of every one.
        macro_rules! relax_step {
            ($k:expr) => {{
                // No neighbour there: v itself, whose value the step does not lower either.
                let u = row[$k].neighbour(v);
                let best = tv + half_step[$k] * (cv + c(u));
                if best < t[u as usize] && !known[u as usize] {
                    t[u as usize] = best;
                    source[u as usize] = sv;
                    queue.set(key(best, u));
                }
            }};
        }
        relax_step!(0);
        relax_step!(1);
        relax_step!(2);
        relax_step!(3);
        relax_face!(4, 2);
        relax_step!(5);
        relax_step!(6);
        relax_step!(7);
        relax_step!(8);
        relax_step!(9);
        relax_face!(10, 1);
        relax_step!(11);
        relax_face!(12, 0);
        relax_face!(13, 0);
        relax_step!(14);
        relax_face!(15, 1);
        relax_step!(16);
        relax_step!(17);
        relax_step!(18);
        relax_step!(19);
        relax_step!(20);
        relax_face!(21, 2);
        relax_step!(22);
        relax_step!(23);
        relax_step!(24);
        relax_step!(25);
    }
    scratch.give_back();
    (Field { t, source }, None)
}

/// Reads the cache lines of `row` ahead of its use, without using what it reads: the
/// processor goes on with the work before it while they come (a plain read rather than a
/// prefetch instruction, which needs `unsafe`).
#[inline(always)]
fn read_ahead<E: Entry>(row: &[E; 26]) {
    // The first, middle and last entries: every cache line of the 52 or 104 bytes.
    std::hint::black_box((row[0], row[13], row[25]));
}

/// The working arrays of one march (the queue and each cell's least face neighbours),
/// kept by each thread for its next march while a [`KeepArrays`] lives: the marches of a
/// search or of a several-gate layout would otherwise each map them afresh, and the
/// kernel zero their pages every time (a 2 MiB page for the face neighbours of 41,541
/// cells).
struct Scratch {
    axis_least: Vec<[f64; 3]>,
    queue: Queue,
}

thread_local! {
    static SCRATCH: std::cell::Cell<Option<Scratch>> = const { std::cell::Cell::new(None) };
}

/// How many [`KeepArrays`] live.
static KEEPING: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// While one lives, each thread keeps its march's working arrays for its next march; when
/// the last is dropped, every thread of the pool (and this one) lets them go, so that a
/// long-lived process (the service, a Python session) does not hold them between
/// analyses. An analysis that runs many marches (the fill's) holds one for its duration.
pub(crate) struct KeepArrays(());

impl KeepArrays {
    pub(crate) fn new() -> KeepArrays {
        KEEPING.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        KeepArrays(())
    }
}

impl Drop for KeepArrays {
    fn drop(&mut self) {
        if KEEPING.fetch_sub(1, std::sync::atomic::Ordering::SeqCst) == 1 {
            // A march running now holds its own arrays (taken out of its thread's slot), so
            // only the kept ones go; the pool's threads let theirs go when they next look
            // for work, without this thread waiting for them.
            SCRATCH.with(|s| drop(s.take()));
            rayon::spawn_broadcast(|_| SCRATCH.with(|s| drop(s.take())));
        }
    }
}

impl Scratch {
    /// This thread's arrays for `n` cells, as a new march needs them (every least infinite,
    /// the queue empty).
    fn take(n: usize) -> Scratch {
        match SCRATCH.with(|s| s.take()) {
            Some(mut s) => {
                s.axis_least.clear();
                s.axis_least.resize(n, [f64::INFINITY; 3]);
                s.queue.clear(n);
                s
            }
            None => Scratch {
                axis_least: vec![[f64::INFINITY; 3]; n],
                queue: Queue::new(n),
            },
        }
    }

    /// Keeps the arrays for this thread's next march, while a [`KeepArrays`] lives.
    fn give_back(self) {
        if KEEPING.load(std::sync::atomic::Ordering::SeqCst) > 0 {
            SCRATCH.with(|s| s.set(Some(self)));
        }
    }
}

/// The first-order upwind solution of sum_k (T - a_k)^2 = f^2 over the finite a_k, using as
/// many of the smallest as keep T above them.
#[inline]
fn eikonal(a: [f64; 3], f: f64) -> f64 {
    // Sorted by a network of min and max, without branches: the values are never NaN nor
    // -0, so this is the order `total_cmp` gives.
    let (low, high) = (a[0].min(a[1]), a[0].max(a[1]));
    let (middle, top) = (high.min(a[2]), high.max(a[2]));
    solve_sorted([low.min(middle), low.max(middle), top], f)
}

/// The update of [`eikonal`] from its three values in increasing order.
#[inline]
fn solve_sorted(a: [f64; 3], f: f64) -> f64 {
    if a[0].is_infinite() {
        return f64::INFINITY;
    }
    let mut t = a[0] + f;
    if a[1] < t {
        let d = a[0] - a[1];
        let disc = 2.0 * f * f - d * d;
        if disc >= 0.0 {
            t = 0.5 * (a[0] + a[1] + disc.sqrt());
        }
        if a[2] < t {
            let s = a[0] + a[1] + a[2];
            let q = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
            let disc = s * s - 3.0 * (q - f * f);
            if disc >= 0.0 {
                t = (s + disc.sqrt()) / 3.0;
            }
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;

    /// The update as first written, sorting by `total_cmp`: the oracle of the sorting network.
    fn reference_eikonal(mut a: [f64; 3], f: f64) -> f64 {
        a.sort_by(f64::total_cmp);
        solve_sorted(a, f)
    }

    /// The face neighbours written out in `march_with`, as (index, axis).
    const FACES: [(usize, usize); 6] = [(4, 2), (10, 1), (12, 0), (13, 0), (15, 1), (21, 2)];

    #[test]
    fn the_faces_written_out_are_the_face_neighbours_with_their_axes() {
        let offsets = neighbour_offsets();
        let faces: Vec<(usize, usize)> = (0..26)
            .filter_map(|k| {
                let o = offsets[k].0;
                let axes: Vec<usize> = (0..3).filter(|&j| o[j] != 0).collect();
                (axes.len() == 1).then(|| (k, axes[0]))
            })
            .collect();
        assert_eq!(faces, FACES.to_vec());
    }

    #[test]
    fn the_sorting_network_gives_the_sorted_update_s_bits() {
        let inf = f64::INFINITY;
        let mut x = 0.377f64;
        let mut values = vec![0.0, 1.0, inf];
        for _ in 0..300 {
            x = (x * 7919.0 + 0.123).rem_euclid(10.0);
            values.push(x);
        }
        for (i, &a) in values.iter().enumerate() {
            for &b in &values[i % 7..][..12] {
                for &c in &values[(i * 5) % 250..][..12] {
                    for f in [0.5, 1.0, 3.7] {
                        for abc in [[a, b, c], [b, c, a], [c, a, b], [a, a, c], [c, b, b]] {
                            let (new, old) = (eikonal(abc, f), reference_eikonal(abc, f));
                            assert_eq!(new.to_bits(), old.to_bits(), "{abc:?} {f}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_queue_pops_in_the_order_of_a_binary_heap_of_every_key_pushed() {
        // Keys rise and fall as a march's do: a cell set again at a smaller value, taken
        // once at its smallest key; the binary heap skips the cells already taken.
        let cells = 500u32;
        let mut queue = Queue::new(cells as usize);
        let mut heap = BinaryHeap::new();
        let mut value = vec![f64::INFINITY; cells as usize];
        let mut taken = vec![false; cells as usize];
        let mut x = 0.61f64;
        let mut next = || {
            x = (x * 7919.0 + 0.37).rem_euclid(1.0);
            x
        };
        let mut floor = 0.0;
        let (mut from_queue, mut from_heap) = (Vec::new(), Vec::new());
        for round in 0..4000 {
            // Set a few cells at values above the last taken (some falls, some ties).
            for _ in 0..3 {
                let c = (next() * cells as f64) as u32;
                let t = floor + (next() * 8.0).floor() * 0.25;
                if !taken[c as usize] && t < value[c as usize] {
                    value[c as usize] = t;
                    queue.set(key(t, c));
                    heap.push(Reverse(key(t, c)));
                }
            }
            if round % 2 == 0 {
                if let Some(k) = queue.pop() {
                    from_queue.push(k);
                    taken[k as u32 as usize] = true;
                    floor = f32::from_bits((k >> 32) as u32) as f64;
                }
                while let Some(Reverse(k)) = heap.pop() {
                    if !from_heap.contains(&(k as u32)) {
                        from_heap.push(k as u32);
                        break;
                    }
                }
            }
        }
        while let Some(k) = queue.pop() {
            from_queue.push(k);
        }
        while let Some(Reverse(k)) = heap.pop() {
            if !from_heap.contains(&(k as u32)) {
                from_heap.push(k as u32);
            }
        }
        let cells_taken: Vec<u32> = from_queue.iter().map(|&k| k as u32).collect();
        assert!(cells_taken.len() > 400, "{}", cells_taken.len());
        assert_eq!(cells_taken, from_heap);
    }

    #[test]
    fn eikonal_matches_the_one_two_and_three_dimensional_closed_forms() {
        let inf = f64::INFINITY;
        assert_eq!(eikonal([inf, inf, inf], 1.0), inf);
        assert_eq!(eikonal([2.0, inf, inf], 1.0), 3.0);
        // Two equal neighbours: T - a = f / sqrt 2.
        assert!((eikonal([0.0, 0.0, inf], 1.0) - 0.5f64.sqrt()).abs() < 1e-12);
        // Three equal: f / sqrt 3.
        assert!((eikonal([0.0, 0.0, 0.0], 1.0) - (1.0f64 / 3.0).sqrt()).abs() < 1e-12);
        // A far second neighbour is ignored.
        assert_eq!(eikonal([0.0, 5.0, inf], 1.0), 1.0);
    }

    /// The march as first written (one loop for both kinds of cost, every test inside it):
    /// the oracle of the faster loop, which must give the same bits.
    fn reference_march(voxels: &Voxels, sources: &[Source], cost: Option<&[f32]>) -> Field {
        let n = voxels.len();
        let h = voxels.h;
        let c = |i: u32| cost.map_or(1.0, |c| c[i as usize] as f64);
        let mut t = vec![f64::INFINITY; n];
        let mut source = vec![u32::MAX; n];
        let mut known = vec![false; n];
        let mut heap = BinaryHeap::new();
        let offsets = neighbour_offsets();

        seed(voxels, sources, &c, &mut t, &mut source, |k| {
            heap.push(Reverse(k))
        });

        // Step lengths of the 26 neighbours, and for each face neighbour (axis k, side), the
        // positions in the table of the two face neighbours of a cell along each axis.
        let step: Vec<f64> = offsets.iter().map(|&(_, len)| len * h).collect();
        let face_pair: [[usize; 2]; 3] = std::array::from_fn(|k| {
            let find = |sgn: i32| {
                offsets
                    .iter()
                    .position(|&(o, _)| (0..3).all(|j| o[j] == if j == k { sgn } else { 0 }))
                    .expect("face neighbour")
            };
            [find(-1), find(1)]
        });
        while let Some(Reverse(entry)) = heap.pop() {
            let v = entry as u32;
            if known[v as usize] {
                continue;
            }
            known[v as usize] = true;
            let tv = t[v as usize];
            let cv = c(v);
            let sv = source[v as usize];
            for (k, u) in voxels.table.of(v).into_iter().enumerate() {
                if u == u32::MAX || known[u as usize] {
                    continue;
                }
                let cu = c(u);
                // Straight step from v.
                let mut best = tv + step[k] * 0.5 * (cv + cu);
                // Fast-marching update of u from its known face neighbours.
                if step[k] == h {
                    let ru = voxels.table.of(u);
                    let mut a = [f64::INFINITY; 3];
                    for (axis, pair) in face_pair.iter().enumerate() {
                        for &slot in pair {
                            let w = ru[slot];
                            if w != u32::MAX && known[w as usize] {
                                a[axis] = a[axis].min(t[w as usize]);
                            }
                        }
                    }
                    best = best.min(reference_eikonal(a, h * cu));
                }
                if best < t[u as usize] {
                    t[u as usize] = best;
                    source[u as usize] = sv;
                    heap.push(Reverse(key(best, u)));
                }
            }
        }
        Field { t, source }
    }

    #[test]
    fn march_gives_the_same_fields_as_the_reference_loop() {
        use crate::samples::sample;
        for name in ["plate", "cover", "cap", "bracket"] {
            let mesh = sample(name).expect("sample");
            let v = Voxels::new(&mesh, 1.0);
            // A cost that varies from cell to cell, as a wall-dependent one does.
            let cost: Vec<f32> = (0..v.len()).map(|i| 1.0 + (i % 7) as f32 * 0.37).collect();
            // And one over six orders of magnitude, whose steps across the cheap cells are
            // smaller than the f32 rounding of the queue's keys at the values reached: cells
            // of one key are taken out of the order of their values, and a step from one
            // must not lower another already taken.
            let wide: Vec<f32> = (0..v.len())
                .map(|i| {
                    if (i / 16) % 3 == 0 {
                        1e-6
                    } else {
                        1.0 + (i % 5) as f32
                    }
                })
                .collect();
            let at = |c: u32| Source {
                point: v.centre(c) + DVec3::new(0.21, -0.13, 0.08),
                cell: c,
            };
            let n = v.len() as u32;
            // The same cells with their neighbours as numbers rather than offsets (the kind
            // a part with a layer of more than 32,767 cells gets) march to the same bits.
            assert!(matches!(v.table, Neighbours::Near(_)), "{name}");
            let mut far = v.clone();
            far.table = Neighbours::Far(v.neighbour_table());
            for c in 0..n {
                assert_eq!(v.table.of(c), far.table.of(c), "{name} {c}");
            }
            for sources in [vec![at(0)], vec![at(n / 3), at(n - 1)]] {
                for c in [None, Some(&cost[..]), Some(&wide[..])] {
                    let old = reference_march(&v, &sources, c);
                    for (kind, cells) in [("offsets", &v), ("numbers", &far)] {
                        let new = march(cells, &sources, c);
                        assert_eq!(new.source, old.source, "{name} {kind}");
                        assert!(
                            new.t
                                .iter()
                                .zip(&old.t)
                                .all(|(a, b)| a.to_bits() == b.to_bits()),
                            "{name} {kind}: the fields differ"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_layer_of_more_than_32767_cells_keeps_the_neighbours_as_numbers() {
        // A plate 200 x 200 cells across and 3 thick: a neighbour in the next layer is
        // about 40,000 cells on, past a 16-bit offset.
        let mut plate = crate::samples::BoxUnion::default();
        plate.add([0.0, 0.0, 0.0], [200.0, 200.0, 2.5]);
        let mesh = plate.mesh();
        let v = Voxels::new(&mesh, 1.0);
        assert!(v.len() > 2 * 32_768, "{}", v.len());
        let Neighbours::Far(rows) = &v.table else {
            panic!("offsets past 16 bits kept");
        };
        assert_eq!(rows, &v.neighbour_table());
        let sources = [Source {
            point: v.centre(0),
            cell: 0,
        }];
        let (new, old) = (
            march(&v, &sources, None),
            reference_march(&v, &sources, None),
        );
        assert_eq!(new.source, old.source);
        assert!(new
            .t
            .iter()
            .zip(&old.t)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn a_march_after_others_on_this_thread_gives_the_fields_of_fresh_arrays() {
        // Each thread keeps its march's queue and face-neighbour arrays for the next march:
        // after a march of more cells, of fewer, and one stopped early (cells left in its
        // queue), a march gives the reference's fields bit for bit.
        use crate::samples::sample;
        let keep = KeepArrays::new();
        let domains: Vec<Voxels> = ["bracket", "plate", "cover"]
            .iter()
            .map(|name| Voxels::new(&sample(name).expect("sample"), 1.0))
            .collect();
        let at = |v: &Voxels, c: u32| Source {
            point: v.centre(c),
            cell: c,
        };
        for (i, v) in domains.iter().enumerate() {
            let before = &domains[(i + 1) % domains.len()];
            let (_, reach) = march_until(before, &[at(before, 0)], None, |_, t| t > 3.0);
            assert!(reach.is_finite(), "the march before stops early");
            let src = [at(v, v.len() as u32 / 2)];
            let (new, old) = (march(v, &src, None), reference_march(v, &src, None));
            assert_eq!(new.source, old.source);
            assert!(new
                .t
                .iter()
                .zip(&old.t)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        assert!(domains.windows(2).any(|w| w[0].len() != w[1].len()));
        // Kept on this thread, for the largest domain seen.
        let most = domains.iter().map(Voxels::len).max().expect("domains");
        let kept = SCRATCH
            .with(|s| s.take())
            .expect("arrays kept while a keeper lives");
        assert!(kept.axis_least.capacity() >= most);
        drop(keep);
        // Let go when the last keeper goes (other tests' fills may hold one meanwhile).
        let _ = march(&domains[0], &[at(&domains[0], 0)], None);
        if KEEPING.load(std::sync::atomic::Ordering::SeqCst) == 0 {
            assert!(SCRATCH.with(|s| s.take()).is_none(), "kept with no keeper");
        }
    }

    #[test]
    fn a_march_stopped_early_keeps_the_accepted_values_and_leaves_out_only_farther_cells() {
        use crate::samples::sample;
        for name in ["plate", "cover", "bracket"] {
            let mesh = sample(name).expect("sample");
            let v = Voxels::new(&mesh, 1.0);
            let cost: Vec<f32> = (0..v.len()).map(|i| 1.0 + (i % 5) as f32 * 0.29).collect();
            let src = [Source {
                point: v.centre(3),
                cell: 3,
            }];
            for c in [None, Some(&cost[..])] {
                let whole = march(&v, &src, c);
                let max = whole.t.iter().copied().fold(0.0, f64::max);
                for share in [0.1, 0.5, 0.9] {
                    let limit = share * max;
                    let (part, reach) = march_until(&v, &src, c, |_, t| t > limit);
                    assert!(reach > limit && reach <= max, "{name}: reach {reach}");
                    let mut kept = 0;
                    for (a, b) in part.t.iter().zip(&whole.t) {
                        if a.is_finite() {
                            kept += 1;
                            assert_eq!(a.to_bits(), b.to_bits(), "{name}: an accepted value");
                        } else {
                            // Left out: at least the reach, to the f32 rounding of the keys.
                            assert!(*b >= reach * (1.0 - 2.4e-7), "{name}: {b} < {reach}");
                        }
                    }
                    assert!(kept > 0 && kept < v.len(), "{name}: {kept} cells kept");
                }
                // A stop that never comes gives the whole field.
                let (all, reach) = march_until(&v, &src, c, |_, _| false);
                assert!(reach.is_infinite());
                assert!(all
                    .t
                    .iter()
                    .zip(&whole.t)
                    .all(|(a, b)| a.to_bits() == b.to_bits()));
            }
        }
    }

    #[test]
    fn a_march_on_cancelled_cells_stops_within_a_check_of_cells() {
        let mesh = crate::samples::sample("cover").expect("sample");
        let mut v = Voxels::new(&mesh, 0.7);
        assert!(v.len() > 20 * CANCEL_CHECK as usize, "{} cells", v.len());
        let src = [Source {
            point: v.centre(3),
            cell: 3,
        }];
        let whole = march(&v, &src, None);
        let token = crate::cancel::Cancel::new();
        v.cancel = Some(token.clone());
        // Not set: the same field.
        let same = march(&v, &src, None);
        assert!(same
            .t
            .iter()
            .zip(&whole.t)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        token.cancel();
        let (cut, reach) = march_until(&v, &src, None, |_, _| false);
        let kept = cut.t.iter().filter(|t| t.is_finite()).count();
        assert_eq!(kept, CANCEL_CHECK as usize);
        assert!(reach.is_finite());
    }
}
