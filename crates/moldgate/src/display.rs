//! The surface a field of the fill analysis is drawn on, at the resolution of its cells.
//!
//! The fill's fields (flow length, fill time, the wall it used) live on voxel cells, while
//! the writers (the PNG, the GLB, and the HTML page that shows the PNG) colour a triangle by
//! blending its corners' values. On a coarse mesh a triangle spans many cells, so the
//! blend of three corners misses the field in between: the floor around a gate, tens of
//! millimetres across in two triangles, would read as far from the gate as its corners. A
//! [`Display`] is the part's surface refined so that no edge is longer than about a cell
//! ([`refine`]), with the field sampled from the cells at every vertex: drawn linearly
//! over these smaller triangles, the colours follow the cells.
//!
//! The refinement splits an edge in its middle while it is longer than the chosen length,
//! a decision made from the edge's two ends alone, so both triangles of an edge split it
//! at the same points and the refined surface has no cracks (nor T-junctions). Triangles
//! whose edges are all short enough are kept as they are, with their own vertices: where
//! the mesh is already finer than the cells nothing changes. The height along D is linear
//! over a triangle and is never refined.
//!
//! **Limit.** The refined surface has at most [`MAX_DISPLAY_TRIANGLES`] triangles (or the
//! mesh's own count, when larger): the count is taken before any vertex is made (a lower
//! bound per triangle first, then the exact count), and when the cell's length would give
//! more, the length is doubled until it fits, so a finer field is drawn at a coarser
//! resolution rather than refused.

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use crate::flow::voxel::CellGrid;
use crate::math::DVec3;
use crate::mesh::Mesh;

/// The most triangles a refined surface may have (when the mesh itself has fewer): a GLB of
/// about 60 MB, and a picture drawn in about the time of a 2-million-triangle part.
pub const MAX_DISPLAY_TRIANGLES: usize = 2_000_000;

/// A field with one value per solid cell, in real units (NaN where unknown), and the cells'
/// lookup by position.
#[derive(Debug, Clone, PartialEq)]
pub struct CellField {
    grid: CellGrid,
    values: Vec<f32>,
}

impl CellField {
    /// The field `values` (one per cell of `grid`).
    pub fn new(grid: CellGrid, values: Vec<f32>) -> CellField {
        debug_assert_eq!(grid.len(), values.len());
        CellField { grid, values }
    }

    /// The cell side, mm.
    pub fn cell_mm(&self) -> f64 {
        self.grid.h
    }

    /// The value at `p`: the value of the solid cell nearest it ([`CellGrid::cell_near`]),
    /// NaN where no cell is near or the value is unknown.
    pub fn value_at(&self, p: DVec3) -> f32 {
        self.grid
            .cell_near(p)
            .map_or(f32::NAN, |c| self.values[c as usize])
    }

    /// The smallest and largest finite value over every cell, the field's real range (the
    /// one the report quotes); `None` when no value is finite.
    pub fn range(&self) -> Option<[f32; 2]> {
        let (lo, hi) = self
            .values
            .par_chunks(1 << 16)
            .map(|block| {
                block
                    .iter()
                    .filter(|v| v.is_finite())
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
                        (lo.min(v), hi.max(v))
                    })
            })
            .reduce(
                || (f32::INFINITY, f32::NEG_INFINITY),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
        (lo <= hi).then_some([lo, hi])
    }

    /// The colour bar's span: the values' range, unless a few cells lie far beyond the
    /// rest (the largest value over [`TAIL_FACTOR`] times the 99th percentile: on the 352k
    /// housing, two thin keyhole slots fill in up to 0.12 s where 99 % of the part fills
    /// within 0.033 s, and one scale over both paints the whole part one colour). Then the
    /// span stops at the 99th percentile, those cells take its top colour, and the largest
    /// value comes beside it.
    pub fn colour_span(&self) -> Option<([f32; 2], Option<f32>)> {
        colour_span_of(&self.values, self.range()?)
    }
}

/// [`CellField::colour_span`] of `values`, whose finite range is `[lo, hi]`.
fn colour_span_of(values: &[f32], [lo, hi]: [f32; 2]) -> Option<([f32; 2], Option<f32>)> {
    let mut finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
    // The fill's 99 % time's rank (`GateFill::fill_time_99_s`): the bar of the fill time
    // ends at the time the report gives.
    let k = rank_of_99th(finite.len())?;
    let (_, &mut p99, _) = finite.select_nth_unstable_by(k, f32::total_cmp);
    Some(if p99 > lo && p99 > 0.0 && hi > TAIL_FACTOR * p99 {
        ([lo, p99], Some(hi))
    } else {
        ([lo, hi], None)
    })
}

/// The rank from 0 of the 99th percentile of `n` values in order: the value of rank
/// ceil(0.99 n) counted from 1, the least at or below which 99 % of them lie (`None` for no
/// value). The fill's 99 % time and the colour bar's far tail both take it.
pub(crate) fn rank_of_99th(n: usize) -> Option<usize> {
    (n * 99).div_ceil(100).checked_sub(1)
}

/// How far beyond the 99th percentile the largest value of a field on cells must lie for
/// its colours to stop at that percentile ([`CellField::colour_span`]).
pub const TAIL_FACTOR: f32 = 2.0;

/// The part's surface as drawn for a field on cells: refined triangles, the triangle of the
/// mesh each comes from, and the field at every vertex.
#[derive(Debug, Clone)]
pub struct Display {
    /// The refined surface: the mesh's vertices first (same numbers), then the new ones.
    pub mesh: Mesh,
    /// For each triangle of `mesh`, the mesh triangle it lies in (in order: the triangles of
    /// mesh triangle 0 first).
    pub parent: Vec<u32>,
    /// The field at each vertex of `mesh`, sampled from the cells.
    pub values: Vec<f32>,
    /// The longest an edge of the refined surface may be, mm (the cell's side, or a
    /// multiple of it when the limit asked for it).
    pub edge_mm: f64,
}

/// The surface of `mesh` refined for `field` (see the module documentation), or `None`
/// when no edge is longer than the field's cell (the mesh is drawn as it is).
pub fn refine(mesh: &Mesh, field: &CellField) -> Option<Display> {
    refine_within(mesh, field, MAX_DISPLAY_TRIANGLES.max(mesh.triangles.len()))
}

/// [`refine`] with at most `limit` triangles.
pub fn refine_within(mesh: &Mesh, field: &CellField, limit: usize) -> Option<Display> {
    let cell = field.cell_mm();
    if !(cell > 0.0 && cell.is_finite()) || mesh.triangles.is_empty() {
        return None;
    }
    let longest = mesh
        .triangles
        .par_iter()
        .map(|tri| {
            let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
            a.distance_squared(b)
                .max(b.distance_squared(c))
                .max(c.distance_squared(a))
        })
        .reduce(|| 0.0, f64::max)
        .sqrt();
    // The shortest edge length the limit allows, by doubling from the cell.
    let mut edge = cell;
    let triangles = loop {
        if longest <= edge {
            return None; // every edge is short enough: nothing to refine
        }
        if lower_bound(mesh, edge) <= limit as f64 {
            let n = count(mesh, edge, limit);
            if n <= limit {
                break n;
            }
        }
        edge *= 2.0;
    };
    let (vertices, triangles, parent) = split_all(mesh, edge, triangles);
    let values: Vec<f32> = vertices.par_iter().map(|&p| field.value_at(p)).collect();
    Some(Display {
        mesh: Mesh {
            vertices,
            triangles,
        },
        parent,
        values,
        edge_mm: edge,
    })
}

/// Whether the edge from `a` to `b` is split at length `edge` (the same answer from either
/// end: the squares of the negated differences are the same).
#[inline]
fn long(a: DVec3, b: DVec3, edge2: f64) -> bool {
    a.distance_squared(b) > edge2
}

/// A lower bound of the refined triangles at `edge`: each is at most equilateral of side
/// `edge` in area, and each holds at most one piece of its mesh triangle's longest edge.
fn lower_bound(mesh: &Mesh, edge: f64) -> f64 {
    let most_area = 3f64.sqrt() / 4.0 * edge * edge;
    mesh.triangles
        .par_iter()
        .map(|tri| {
            let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
            let area = 0.5 * (b - a).cross(c - a).length();
            let side = a.distance(b).max(b.distance(c)).max(c.distance(a));
            (area / most_area).max((side / edge).ceil()).max(1.0)
        })
        .sum()
}

/// The exact number of refined triangles at `edge`, or more than `limit` once it is over
/// (each mesh triangle's count stops there too).
fn count(mesh: &Mesh, edge: f64, limit: usize) -> usize {
    let edge2 = edge * edge;
    mesh.triangles
        .par_iter()
        .map(|tri| {
            let corners = tri.map(|v| mesh.vertices[v as usize]);
            let mut n = 0usize;
            let mut stack = vec![corners];
            while let Some(t) = stack.pop() {
                if n > limit {
                    break;
                }
                let before = stack.len();
                split_one(t, t, edge2, |a, b| (a + b) * 0.5, &mut stack);
                if stack.len() == before {
                    n += 1;
                }
            }
            n
        })
        .reduce(|| 0, |a, b| a.saturating_add(b).min(limit + 1))
}

/// Splits triangle `t` (corners in order, at positions `p`) once: pushes its two to four
/// children on `out` when an edge is longer than `edge2.sqrt()`, nothing otherwise.
/// `mid(a, b)` makes the middle of an edge, at `(a + b) / 2`. One split edge: two children
/// through the middle and the opposite corner; two: the corner triangle between them and
/// the rest cut along its shorter diagonal; three: four children. Children keep the
/// triangle's winding.
#[inline]
fn split_one<V: Copy>(
    t: [V; 3],
    p: [DVec3; 3],
    edge2: f64,
    mut mid: impl FnMut(V, V) -> V,
    out: &mut Vec<[V; 3]>,
) {
    let split = [
        long(p[0], p[1], edge2),
        long(p[1], p[2], edge2),
        long(p[2], p[0], edge2),
    ];
    let [v0, v1, v2] = t;
    match split {
        [false, false, false] => {}
        [true, true, true] => {
            let (m01, m12, m20) = (mid(v0, v1), mid(v1, v2), mid(v2, v0));
            out.extend([
                [v0, m01, m20],
                [m01, v1, m12],
                [m20, m12, v2],
                [m01, m12, m20],
            ]);
        }
        _ => {
            // Turn the corners round so that edge 0 -> 1 is split, and with two split edges,
            // 1 -> 2 is the other.
            let k = match split {
                [true, false, false] | [true, true, false] => 0,
                [false, true, false] | [false, true, true] => 1,
                _ => 2,
            };
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let (pa, pb, pc) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            let mab = mid(a, b);
            if split.iter().filter(|&&s| s).count() == 1 {
                out.extend([[a, mab, c], [mab, b, c]]);
            } else {
                let mbc = mid(b, c);
                out.push([mab, b, mbc]);
                // The quadrilateral a, mab, mbc, c along its shorter diagonal.
                let (pmab, pmbc) = ((pa + pb) * 0.5, (pb + pc) * 0.5);
                if pa.distance_squared(pmbc) <= pmab.distance_squared(pc) {
                    out.extend([[a, mab, mbc], [a, mbc, c]]);
                } else {
                    out.extend([[a, mab, c], [mab, mbc, c]]);
                }
            }
        }
    }
}

/// The place of a mesh edge's far end along it, for the middles on the edge: they halve it
/// exactly 62 levels deep, far below any refinement within the limit.
const ALONG_ONE: u64 = 1 << 62;

/// Where a new vertex lies: on the mesh edge from vertex `lo` to vertex `hi` (`lo < hi`), at
/// `along / ALONG_ONE` of the way from `lo`; `lo == u32::MAX` inside a mesh triangle.
#[derive(Debug, Clone, Copy)]
struct Along {
    lo: u32,
    hi: u32,
    along: u64,
}

/// The refined surface at `edge`: vertices (the mesh's, then one per split edge, numbered
/// in the order the mesh's triangles meet them), triangles and their mesh triangles; the
/// output of [`split_all_in_order`].
///
/// A middle inside a mesh triangle is met by that triangle alone, so it is looked up among
/// that triangle's middles only (a small table, cleared for each triangle); a middle on a
/// mesh edge is met by the triangles on both sides, and is looked up by the edge and its
/// place along it. That holds unless two triangles have the same three corners, or one
/// repeats a corner: such meshes take [`split_all_in_order`].
fn split_all(mesh: &Mesh, edge: f64, count: usize) -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<u32>) {
    let edge2 = edge * edge;
    let mut split: Vec<[u32; 3]> = mesh
        .triangles
        .par_iter()
        .filter(|tri| {
            let [a, b, c] = tri.map(|v| mesh.vertices[v as usize]);
            long(a, b, edge2) || long(b, c, edge2) || long(c, a, edge2)
        })
        .map(|tri| {
            let mut t = *tri;
            t.sort_unstable();
            t
        })
        .collect();
    split.par_sort_unstable();
    if split.par_windows(2).any(|w| w[0] == w[1])
        || split.par_iter().any(|t| t[0] == t[1] || t[1] == t[2])
    {
        return split_all_in_order(mesh, edge, count);
    }
    drop(split);
    let first = mesh.vertices.len() as u32;
    let new_vertices = (count / 2).saturating_sub(mesh.vertices.len() / 2);
    let mut vertices = Vec::with_capacity(mesh.vertices.len() + new_vertices);
    vertices.extend_from_slice(&mesh.vertices);
    let mut along: Vec<Along> = Vec::with_capacity(new_vertices);
    let mut triangles = Vec::with_capacity(count);
    let mut parent = Vec::with_capacity(count);
    let mut on_edges: FxHashMap<(u32, u32, u64), u32> = FxHashMap::default();
    let mut middles: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    let mut stack: Vec<[u32; 3]> = Vec::new();
    let mut children: Vec<[u32; 3]> = Vec::with_capacity(4);
    for (t, &tri) in mesh.triangles.iter().enumerate() {
        middles.clear();
        stack.push(tri);
        while let Some(s) = stack.pop() {
            let p = s.map(|v| vertices[v as usize]);
            children.clear();
            let mid = |a: u32, b: u32| {
                *middles.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let on = on_edge(a, b, first, &along);
                    let mut make = || {
                        vertices.push((vertices[a as usize] + vertices[b as usize]) * 0.5);
                        along.push(on);
                        (vertices.len() - 1) as u32
                    };
                    if on.lo == u32::MAX {
                        make()
                    } else {
                        *on_edges
                            .entry((on.lo, on.hi, on.along))
                            .or_insert_with(make)
                    }
                })
            };
            split_one(s, p, edge2, mid, &mut children);
            if children.is_empty() {
                triangles.push(s);
                parent.push(t as u32);
            } else {
                // Last pushed is taken first: reversed, a triangle's pieces come in order.
                stack.extend(children.iter().rev());
            }
        }
    }
    (vertices, triangles, parent)
}

/// Where the middle of vertices `a` and `b` lies ([`Along`]); vertices from `first` on are
/// new, `along` holds theirs.
fn on_edge(a: u32, b: u32, first: u32, along: &[Along]) -> Along {
    const INSIDE: Along = Along {
        lo: u32::MAX,
        hi: u32::MAX,
        along: 0,
    };
    let of = |v: u32| (v >= first).then(|| along[(v - first) as usize]);
    let (lo, hi) = match (of(a), of(b)) {
        (None, None) => (a.min(b), a.max(b)),
        (Some(x), _) | (None, Some(x)) => (x.lo, x.hi),
    };
    if lo == u32::MAX {
        return INSIDE;
    }
    let place = |v: u32| match of(v) {
        None if v == lo => Some(0),
        None if v == hi => Some(ALONG_ONE),
        None => None,
        Some(x) => ((x.lo, x.hi) == (lo, hi)).then_some(x.along),
    };
    match (place(a), place(b)) {
        (Some(x), Some(y)) => Along {
            lo,
            hi,
            along: (x + y) / 2,
        },
        _ => INSIDE,
    }
}

/// [`split_all`] with every middle looked up by its two ends in one table: the reference
/// (and the way for meshes with a repeated triangle or corner).
fn split_all_in_order(
    mesh: &Mesh,
    edge: f64,
    count: usize,
) -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<u32>) {
    let edge2 = edge * edge;
    // About one vertex for two triangles on a closed surface.
    let new_vertices = (count / 2).saturating_sub(mesh.vertices.len() / 2);
    let mut vertices = Vec::with_capacity(mesh.vertices.len() + new_vertices);
    vertices.extend_from_slice(&mesh.vertices);
    let mut triangles = Vec::with_capacity(count);
    let mut parent = Vec::with_capacity(count);
    let mut middles: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    middles.reserve(new_vertices);
    let mut stack: Vec<[u32; 3]> = Vec::new();
    let mut children: Vec<[u32; 3]> = Vec::with_capacity(4);
    for (t, &tri) in mesh.triangles.iter().enumerate() {
        stack.push(tri);
        while let Some(s) = stack.pop() {
            let p = s.map(|v| vertices[v as usize]);
            children.clear();
            let mid = |a: u32, b: u32| {
                *middles.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    vertices.push((vertices[a as usize] + vertices[b as usize]) * 0.5);
                    (vertices.len() - 1) as u32
                })
            };
            split_one(s, p, edge2, mid, &mut children);
            if children.is_empty() {
                triangles.push(s);
                parent.push(t as u32);
            } else {
                // Last pushed is taken first: reversed, a triangle's pieces come in order.
                stack.extend(children.iter().rev());
            }
        }
    }
    (vertices, triangles, parent)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_far_tail_of_a_few_cells_stops_the_colour_span_at_the_99th_percentile() {
        let span_of = |v: &[f32]| {
            let finite = v.iter().copied().filter(|x| x.is_finite());
            let range = [
                finite.clone().fold(f32::INFINITY, f32::min),
                finite.fold(f32::NEG_INFINITY, f32::max),
            ];
            (super::colour_span_of(v, range).unwrap(), range)
        };
        // 1000 cells from 1 to 10, and 2 of them far beyond: the span stops below them.
        let mut values: Vec<f32> = (0..1000).map(|i| 1.0 + 9.0 * i as f32 / 999.0).collect();
        values[17] = 100.0;
        values[500] = 80.0;
        values[999] = f32::NAN;
        let ((span, beyond), _) = span_of(&values);
        assert_eq!(beyond, Some(100.0));
        assert!(
            span[0] == 1.0 && span[1] > 9.0 && span[1] < 10.0,
            "{span:?}"
        );
        // Without a far tail the span is the range.
        values[17] = 15.0;
        values[500] = 12.0;
        let ((span, beyond), range) = span_of(&values);
        assert_eq!((span, beyond), (range, None));
    }

    use super::*;
    use crate::flow::voxel::Voxels;

    /// A closed box `x` by `y` by `z` mm of 12 triangles, wound outwards.
    fn cuboid(x: f64, y: f64, z: f64) -> Mesh {
        let vertices = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { 0.0 } else { x },
                    if i & 2 == 0 { 0.0 } else { y },
                    if i & 4 == 0 { 0.0 } else { z },
                )
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles = quads
            .iter()
            .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
            .collect();
        Mesh {
            vertices,
            triangles,
        }
    }

    fn area(m: &Mesh, t: usize) -> f64 {
        let [a, b, c] = m.corners(t);
        0.5 * (b - a).cross(c - a).length()
    }

    #[test]
    fn the_refined_surface_is_closed_short_edged_and_covers_each_triangle() {
        let mesh = cuboid(40.0, 25.0, 3.0);
        for edge in [0.7, 2.0, 4.5] {
            let n = count(&mesh, edge, usize::MAX - 1);
            let (vertices, triangles, parent) = split_all(&mesh, edge, n);
            assert_eq!(triangles.len(), n);
            assert!(n as f64 >= lower_bound(&mesh, edge));
            let refined = Mesh {
                vertices,
                triangles,
            };
            // No crack and no T-junction: every directed edge has its reverse once.
            let mut edges: FxHashMap<(u32, u32), i32> = FxHashMap::default();
            for tri in &refined.triangles {
                for k in 0..3 {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    *edges.entry((a, b)).or_default() += 1;
                    let [p, q] = [a, b].map(|v| refined.vertices[v as usize]);
                    assert!(p.distance(q) <= edge, "{edge}: {}", p.distance(q));
                }
            }
            for (&(a, b), &k) in &edges {
                assert_eq!(k, 1);
                assert_eq!(edges.get(&(b, a)), Some(&1), "{edge}: edge {a}-{b}");
            }
            // The pieces of each triangle tile it, facing its way.
            let mut covered = vec![0.0; mesh.triangles.len()];
            for (i, &t) in parent.iter().enumerate() {
                covered[t as usize] += area(&refined, i);
                assert!(refined.normal(i).dot(mesh.normal(t as usize)) > 0.999);
            }
            for (t, &a) in covered.iter().enumerate() {
                assert!((a - area(&mesh, t)).abs() < 1e-9 * area(&mesh, t), "{t}");
            }
            // The mesh's vertices keep their numbers.
            assert_eq!(refined.vertices[..8], mesh.vertices[..]);
        }
    }

    /// A closed, uneven surface: the box's corners moved apart by different amounts, so
    /// its edges split to different depths, and a long thin sliver.
    fn uneven() -> Mesh {
        let mut m = cuboid(37.0, 21.0, 4.0);
        for (i, v) in m.vertices.iter_mut().enumerate() {
            *v += DVec3::new(0.37 * i as f64, 1.3 * (i % 3) as f64, 0.71 * (i % 2) as f64);
        }
        m
    }

    #[test]
    fn middles_looked_up_by_triangle_and_edge_number_as_one_table_does() {
        let mut repeated = uneven();
        let again = repeated.triangles[3];
        repeated.triangles.push([again[1], again[2], again[0]]);
        for mesh in [cuboid(40.0, 25.0, 3.0), uneven(), repeated] {
            for edge in [0.45, 1.3, 2.0, 7.0] {
                let n = count(&mesh, edge, usize::MAX - 1);
                let fast = split_all(&mesh, edge, n);
                let reference = split_all_in_order(&mesh, edge, n);
                assert_eq!(fast.1, reference.1, "{edge}");
                assert_eq!(fast.2, reference.2, "{edge}");
                assert_eq!(fast.0.len(), reference.0.len(), "{edge}");
                for (p, q) in fast.0.iter().zip(&reference.0) {
                    assert_eq!(
                        p.to_array().map(f64::to_bits),
                        q.to_array().map(f64::to_bits)
                    );
                }
            }
        }
    }

    fn field_on(mesh: &Mesh, h: f64) -> CellField {
        let grid = Voxels::new(mesh, h).into_grid();
        // Any value per cell: its number.
        let values = (0..grid.len()).map(|c| c as f32).collect();
        CellField::new(grid, values)
    }

    #[test]
    fn a_mesh_finer_than_the_cells_is_drawn_as_it_is() {
        let mesh = cuboid(4.0, 3.0, 2.0);
        assert!(refine(&mesh, &field_on(&mesh, 6.0)).is_none());
        let d = refine(&mesh, &field_on(&mesh, 0.5)).expect("refined");
        assert_eq!(d.edge_mm, 0.5);
        assert_eq!(d.values.len(), d.mesh.vertices.len());
        assert!(d.values.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn over_the_limit_the_edge_doubles_until_the_surface_fits() {
        let mesh = cuboid(40.0, 25.0, 3.0);
        let field = field_on(&mesh, 0.5);
        let free = refine_within(&mesh, &field, usize::MAX / 2).unwrap();
        assert_eq!(free.edge_mm, 0.5);
        let limit = free.mesh.triangles.len() / 5;
        let bounded = refine_within(&mesh, &field, limit).unwrap();
        assert!(bounded.edge_mm >= 1.0, "{}", bounded.edge_mm);
        assert!(bounded.mesh.triangles.len() <= limit);
        // Half that length was over the limit: the first length that fits is kept.
        assert!(count(&mesh, bounded.edge_mm / 2.0, limit) > limit);
    }
}
