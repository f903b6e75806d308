//! Typed errors of the library. Each carries where the problem is: a line, a byte offset, a
//! triangle index, or the option at fault. Messages are lower-case with no final period.

use thiserror::Error;

/// Where in a mesh file a problem was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// A 1-based line of a text file.
    Line(u64),
    /// A 0-based byte offset of a binary file.
    Byte(u64),
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Place::Line(n) => write!(f, "line {n}"),
            Place::Byte(n) => write!(f, "byte {n}"),
        }
    }
}

/// A non-finite coordinate in words: NaN, or an infinity, which in a text file is also what a
/// number too large for a 64-bit float reads as (1e400, or a hundred thousand digits).
pub(crate) fn non_finite(value: &f64) -> String {
    if value.is_nan() {
        "NaN".into()
    } else {
        format!("{value}: infinite, or a number too large to represent")
    }
}

/// Bytes in GiB.
fn gib(bytes: u64) -> f64 {
    bytes as f64 / f64::from(1u32 << 30)
}

/// A mesh file that cannot be read.
#[derive(Debug, Error)]
pub enum LoadError {
    /// The operating system refused to read the file.
    #[error("cannot read: {0}")]
    Io(#[from] std::io::Error),
    /// The file has no bytes.
    #[error("empty file")]
    Empty,
    /// A binary STL shorter than its header.
    #[error("truncated binary STL: {len} bytes, shorter than the 84-byte header")]
    TruncatedHeader {
        /// File length in bytes.
        len: u64,
    },
    /// A binary STL whose data stops before the triangle count in its header says.
    #[error(
        "truncated binary STL: the header declares {declared} triangles ({expected} bytes) but the file has {len} bytes; triangle {triangle} is cut at byte {offset}{}",
        far_short(*.expected, *.len)
    )]
    Truncated {
        /// Triangle count in the header.
        declared: u64,
        /// Size the header implies: 84 + 50 x declared.
        expected: u64,
        /// Actual file length.
        len: u64,
        /// Index of the first incomplete triangle.
        triangle: u64,
        /// Byte offset where that triangle starts.
        offset: u64,
    },
    /// A binary STL longer than its triangle count says.
    #[error(
        "binary STL triangle count does not match the file size: the header declares {declared} triangles ({expected} bytes) but the file has {len} bytes (extra data from byte {expected})"
    )]
    CountMismatch {
        /// Triangle count in the header.
        declared: u64,
        /// Size the header implies.
        expected: u64,
        /// Actual file length.
        len: u64,
    },
    /// A syntax error in a text mesh file.
    #[error("{place}: {message}")]
    Syntax {
        /// Where the error is.
        place: Place,
        /// What is wrong.
        message: String,
    },
    /// A coordinate that is NaN or infinite.
    #[error("{place}: triangle {triangle} has a non-finite coordinate ({})", non_finite(.value))]
    NonFinite {
        /// Where the coordinate is.
        place: Place,
        /// 0-based triangle index.
        triangle: u64,
        /// The offending value as read.
        value: f64,
    },
    /// A mesh whose facets all have zero area.
    #[error("no facet has a non-zero area ({facets} facets read)")]
    NoArea {
        /// How many facets were read.
        facets: u64,
    },
    /// A vertex of an array mesh with a NaN or infinite coordinate.
    #[error("vertex {vertex} has a non-finite coordinate ({})", non_finite(.value))]
    NonFiniteVertex {
        /// 0-based vertex index.
        vertex: u64,
        /// The offending value.
        value: f64,
    },
    /// A vertex of an array mesh with a coordinate beyond [`crate::mesh::MAX_COORDINATE_MM`]
    /// once in millimetres, as a file's would be refused.
    #[error(
        "vertex {vertex}: a coordinate of {value:.4e} ({mm:.4e} mm) is beyond the limit of ±{limit_mm:.0e} mm; the arrays are not a part in these units"
    )]
    VertexOutOfRange {
        /// 0-based vertex index.
        vertex: u64,
        /// The value as given, in the arrays' units.
        value: f64,
        /// The value in millimetres.
        mm: f64,
        /// The limit in millimetres.
        limit_mm: f64,
    },
    /// A triangle of an array mesh with a vertex index outside the vertex array.
    #[error("triangle {triangle} uses vertex {index}, {}", match vertices { 0 => "but there are no vertices".to_string(), n => format!("outside the {n} vertices (0 to {})", n - 1) })]
    IndexOutOfRange {
        /// 0-based triangle index.
        triangle: u64,
        /// The offending index.
        index: i64,
        /// How many vertices there are.
        vertices: u64,
    },
    /// More vertices or triangles than a mesh may have.
    #[error("{count} {what}, more than the limit of {limit}")]
    TooLarge {
        /// `vertices` or `triangles`.
        what: &'static str,
        /// How many were given.
        count: u64,
        /// The limit.
        limit: u64,
    },
    /// The faces read so far make more triangles than this process has the memory to
    /// analyse (a file of large polygons makes many triangles of few bytes each): counted as
    /// they are read, by [`crate::mesh::check_triangle_memory`].
    #[error(
        "{place}: the faces read so far make {triangles} triangles, which may take {:.2} GiB of memory to analyse ({} bytes a triangle), more than the {:.2} GiB this process may use (the memory available, or its limit): use a machine with more memory or a coarser mesh",
        gib(*.need),
        crate::mesh::BYTES_PER_TRIANGLE,
        gib(*.limit)
    )]
    TooMuchMemory {
        /// Where the reading stopped.
        place: Place,
        /// The triangles read so far.
        triangles: u64,
        /// The memory they may take, bytes.
        need: u64,
        /// The memory this process may use, bytes.
        limit: u64,
    },
    /// A file whose format is not supported.
    #[error("unsupported mesh format: {0}")]
    Unsupported(String),
    /// A coordinate beyond [`crate::mesh::MAX_COORDINATE_MM`] once in millimetres: no
    /// moulded part is that large, and squares and sums of such numbers overflow.
    #[error(
        "{place}: a coordinate of {value:.4e} ({mm:.4e} mm) is beyond the limit of ±{limit_mm:.0e} mm; the file is not a part in these units"
    )]
    OutOfRange {
        /// Where the coordinate is.
        place: Place,
        /// The value as read, in file units.
        value: f64,
        /// The value in millimetres.
        mm: f64,
        /// The limit in millimetres.
        limit_mm: f64,
    },
    /// A file that is another kind of file than a mesh, recognised by its first bytes.
    #[error("this is {what}, {}: {advice}", if .advice.contains("extension") { "not what its extension says" } else { "not a mesh" })]
    NotAMesh {
        /// What the file is, with its article ("a STEP file (ISO-10303-21)").
        what: &'static str,
        /// What to do instead.
        advice: &'static str,
    },
}

/// An analysis option that is out of range.
#[derive(Debug, Error, PartialEq)]
pub enum OptionsError {
    /// The gate's rays were stopped by a cancel (a study's time limit, Ctrl-C) before they
    /// were all cast: there is no analysis. A study gives its own `Cancelled` instead.
    #[error("the gate's rays were stopped (time limit or cancel) before they were all cast")]
    Stopped,
    /// The demolding direction has zero length or is not finite.
    #[error("a direction must be a non-zero finite vector, got ({0}, {1}, {2})")]
    ZeroDirection(f64, f64, f64),
    /// A demolding direction that cannot be parsed.
    #[error("cannot read direction '{0}': expected +x, -y, ... or three numbers x,y,z")]
    BadDirection(String),
    /// A material parameter that must be positive is not.
    #[error("material '{material}': {parameter} must be a positive finite number, got {value:?}")]
    NonPositiveMaterial {
        /// The material's name.
        material: String,
        /// The parameter's name.
        parameter: &'static str,
        /// Its value.
        value: f64,
    },
    /// A material parameter beyond what any polymer melt has.
    #[error("material '{material}': {parameter} = {value:?} is out of range: {why}")]
    MaterialOutOfRange {
        /// The material's name.
        material: String,
        /// The parameter's name.
        parameter: &'static str,
        /// Its value.
        value: f64,
        /// The range and why.
        why: &'static str,
    },
    /// The melt is not hotter than the mould wall.
    #[error(
        "material '{material}': the melt temperature ({t_melt:?} C) must be above the wall temperature ({t_wall:?} C)"
    )]
    MeltNotAboveWall {
        /// The material's name.
        material: String,
        /// Melt temperature in degrees Celsius.
        t_melt: f64,
        /// Mould wall temperature in degrees Celsius.
        t_wall: f64,
    },
    /// Parameters each in range whose gate radius (Eq. 7-8) is not a positive finite length
    /// (extreme values that overflow or vanish together).
    #[error(
        "material '{material}': its parameters give {} by Eq. 7-8, not a positive finite length (check n, k, mu_opt, gamma_opt and the temperatures)",
        match .radius_mm {
            r if r.is_infinite() => "an infinite gate radius (the numbers overflow)".to_string(),
            r if r.is_nan() => "no gate radius (the numbers overflow or vanish together)".to_string(),
            r => format!("a gate radius of {r:?} mm"),
        }
    )]
    MaterialRadius {
        /// The material's name.
        material: String,
        /// The radius Eq. 7-8 gives, mm.
        radius_mm: f64,
    },
    /// A keep-out region that cannot be read.
    #[error("cannot read keep-out region '{0}': expected box:x0,y0,z0,x1,y1,z1 or sphere:x,y,z,r (mm, r > 0)")]
    BadRegion(String),
    /// A length or count option that must be positive is not.
    #[error("{option} must be a positive finite number, got {value:?}")]
    NonPositive {
        /// The option's name.
        option: &'static str,
        /// Its value.
        value: f64,
    },
    /// A grid offset that is not a fraction of the spacing: a shift of a spacing or more
    /// would move the grid off one side of the part.
    #[error("grid offset must be a fraction of the spacing, above -1 and below 1, got {0}")]
    GridOffset(f64),
    /// The grid would have more nodes than the limit.
    #[error(
        "a spacing of {} mm gives a grid of {} nodes, more than the limit of {limit}; {}",
        length_text(*.spacing_mm),
        grid_text(*.n_u, *.n_w, *.nodes),
        spacing_advice("use", *.min_spacing_mm)
    )]
    GridTooLarge {
        /// Requested spacing.
        spacing_mm: f64,
        /// Nodes along u.
        n_u: u64,
        /// Nodes along w.
        n_w: u64,
        /// n_u x n_w.
        nodes: u64,
        /// The node limit.
        limit: u64,
        /// The smallest spacing within the limit.
        min_spacing_mm: f64,
    },
    /// A count option above its stated limit.
    #[error("{option} must be at most {limit}, got {value}")]
    AboveLimit {
        /// The option's name.
        option: &'static str,
        /// Its value.
        value: u64,
        /// The largest value accepted.
        limit: u64,
    },
    /// The rays' hit records of the part's grid would take more memory than the budget
    /// (checked once the grid is laid, before its rays).
    #[error(
        "a grid of {nodes} nodes with {circle_points} circle points can need {} MiB for the ray hits (up to {runs} sets of one 24-byte and {circle_points} 8-byte records a node), more than the budget of {} MiB; use at most {points_within} circle points, or a spacing of at least {} mm (at most {nodes_within} nodes)",
        .bytes >> 20, .budget >> 20, figures(*.min_spacing_mm)
    )]
    RayMemory {
        /// The grid's nodes.
        nodes: u64,
        /// Points on each node's circle.
        circle_points: u64,
        /// Sets of hits drawn apart (one per thread, up to a limit).
        runs: u64,
        /// Bytes the hits could take.
        bytes: u64,
        /// The budget in bytes.
        budget: u64,
        /// The most circle points within the budget on this grid.
        points_within: u64,
        /// The largest grid within the budget with these circle points.
        nodes_within: u64,
        /// The least spacing whose grid over this part is within the budget, mm.
        min_spacing_mm: f64,
    },
    /// The rays' hit records of the part's grid, on the threads that draw them, would take
    /// more memory than the process may still use (its limits, the memory available):
    /// refused before the rays instead of failing an allocation part way.
    #[error(
        "a grid of {nodes} nodes with {circle_points} circle points may need {} MiB for the ray hits (twice {runs} sets of one 24-byte and {circle_points} 8-byte records a node, for their arrays' growth), more than the {} MiB this process may still use (its memory limits and the memory available); use at most {points_within} circle points, or a spacing of at least {} mm (at most {nodes_within} nodes)",
        .bytes >> 20, .room >> 20, figures(*.min_spacing_mm)
    )]
    MachineMemory {
        /// The grid's nodes.
        nodes: u64,
        /// Points on each node's circle.
        circle_points: u64,
        /// Sets of hits drawn apart (one per thread drawing).
        runs: u64,
        /// Bytes the hits would take.
        bytes: u64,
        /// Bytes the process may still use.
        room: u64,
        /// The most circle points within that room on this grid.
        points_within: u64,
        /// The largest grid within that room with these circle points.
        nodes_within: u64,
        /// The least spacing whose grid over this part fits that room, mm.
        min_spacing_mm: f64,
    },
    /// The automatic spacing gives too many nodes: the part is too large for its gate (most
    /// often a file in other units than the ones it was read in).
    #[error(
        "the part spans {} mm, so the automatic spacing of {} mm (the gate radius, or a hundredth of the part's longest side when smaller) gives {} nodes, more than the limit of {limit}; check the file's units (--units) and the gate radius, or {}",
        figures(*.span_mm),
        figures(*.spacing_mm),
        count_text(*.nodes),
        spacing_advice("give", *.min_spacing_mm)
    )]
    PartTooLarge {
        /// The longest side of the projected box, in mm.
        span_mm: f64,
        /// The automatic spacing.
        spacing_mm: f64,
        /// Nodes it would give.
        nodes: u64,
        /// The node limit.
        limit: u64,
        /// The smallest spacing within the limit.
        min_spacing_mm: f64,
    },
    /// The triangles overlap so deeply along the demolding direction that the rays would
    /// cost more than the budget: not the surface of a moulded part (random or repeated
    /// triangles).
    #[error(
        "the triangles overlap about {depth:.0} deep along the demolding direction (the rays would make about {ray_tests:.2e} ray-triangle tests, more than the budget of {budget:.1e}); the surface of a moulded part is crossed a few times by each ray, so this mesh holds overlapping or random triangles"
    )]
    OverlappingSurface {
        /// Mean number of triangles over a node of the projected box.
        depth: f64,
        /// Estimated ray-triangle tests (lattice points covered, over every lattice).
        ray_tests: f64,
        /// The budget of tests.
        budget: f64,
    },
    /// The walls' rays would cost more than [`crate::thickness::WALL_WORK_BUDGET`] on a
    /// tree whose boxes overlap across the part (random or overlapping triangles): known
    /// from the tree's area cost before any wall is measured.
    #[error(
        "the triangles' boxes overlap across the part (the ray tree's area cost is {cost:.0}, where moulded parts have 15 to 40), so measuring the walls of {facets} facets would take about {work:.1e} box and triangle visits, more than the budget of {budget:.1e}; this mesh holds overlapping or random triangles: leave out the wall map and the fill analysis"
    )]
    TangledSurface {
        /// The tree's area cost ([`crate::raycast::Bvh::area_cost`]).
        cost: f64,
        /// The facets whose walls would be measured.
        facets: u64,
        /// The cost times the facets.
        work: f64,
        /// The budget of work.
        budget: f64,
    },
}

impl OptionsError {
    /// Whether the part is at fault, not an option: a part too large for the automatic
    /// spacing, or triangles overlapping far beyond a surface's depth. Every front end
    /// reports these as the input's error (the command line's exit code 3, the service's
    /// 422 `mesh`, Python's `LoadError`), the others as an option's.
    pub fn is_the_parts(&self) -> bool {
        matches!(
            self,
            OptionsError::PartTooLarge { .. }
                | OptionsError::OverlappingSurface { .. }
                | OptionsError::TangledSurface { .. }
        )
    }

    /// The [`crate::study::StudyOptions`] field the error is about, where one is (the
    /// service's `at`): `spacing`, `circle_points`, `max_nodes`, ...
    pub fn field(&self) -> Option<&'static str> {
        let named = |option: &str| match option {
            "gate radius" => Some("gate_radius"),
            "circle points" => Some("circle_points"),
            "the node limit" => Some("max_nodes"),
            "keep-out regions" => Some("keep_out"),
            "spacing" => Some("spacing"),
            "grid offset" => Some("grid_offset"),
            "flatness tolerance" => Some("flat_tol"),
            _ => None,
        };
        match self {
            OptionsError::NonPositive { option, .. } | OptionsError::AboveLimit { option, .. } => {
                named(option)
            }
            OptionsError::GridTooLarge { .. } => Some("spacing"),
            OptionsError::GridOffset(_) => Some("grid_offset"),
            OptionsError::RayMemory { .. } | OptionsError::MachineMemory { .. } => {
                Some("circle_points")
            }
            OptionsError::BadRegion(_) => Some("keep_out"),
            OptionsError::ZeroDirection(..) | OptionsError::BadDirection(_) => Some("demold"),
            _ => None,
        }
    }
}

/// The most characters of the input an error message quotes.
pub const EXCERPT_CHARS: usize = 40;

/// A short, printable excerpt of input bytes for an error message: at most
/// [`EXCERPT_CHARS`] characters (then `...` and the full length), with control characters,
/// escape sequences and bytes that are not UTF-8 written as escapes (`\u{1b}`, `\xff`), so nothing
/// read from a file can move the terminal's cursor or make a message longer than a line.
pub fn excerpt(bytes: &[u8]) -> String {
    let mut out = String::new();
    let mut cut = bytes.len() > 4 * EXCERPT_CHARS;
    let mut n = 0;
    // Bytes that are not UTF-8 are shown as themselves (`\xff`), not as a replacement
    // character that hides them.
    'chunks: for chunk in bytes[..bytes.len().min(4 * EXCERPT_CHARS)].utf8_chunks() {
        let shown = chunk
            .valid()
            .chars()
            .map(Ok)
            .chain(chunk.invalid().iter().map(|&b| Err(b)));
        for c in shown {
            if n == EXCERPT_CHARS {
                cut = true;
                break 'chunks;
            }
            n += 1;
            match c {
                Ok(c) if c.is_control() || c == '\u{feff}' || c == '\u{fffd}' => {
                    out.extend(c.escape_default());
                }
                Ok(c) => out.push(c),
                Err(b) => out += &format!("\\x{b:02x}"),
            }
        }
    }
    if cut {
        out += &format!("... ({} bytes)", bytes.len());
    }
    out
}

/// Why no gate could be placed.
#[derive(Debug, Error)]
pub enum LocateError {
    /// An option is out of range.
    #[error(transparent)]
    Options(#[from] OptionsError),
    /// No node of the grid passed every rule.
    #[error("no node qualifies for a gate: {reason}")]
    NoCandidate {
        /// Which rule removed the last nodes, with the counts.
        reason: String,
    },
}

/// A length as given, or in scientific notation when it is very small or very large (a
/// spacing of 1e-300 mm is not written with 300 zeros).
/// A file that holds less than a thousandth of what its binary STL header declares is
/// more likely not an STL than a download cut short: said so after the truncation.
fn far_short(expected: u64, len: u64) -> &'static str {
    if len.saturating_mul(1000) < expected {
        " (less than a thousandth of what the header declares: the file may not be an STL at all)"
    } else {
        ""
    }
}

fn length_text(x: f64) -> String {
    if x != 0.0 && !(1e-4..1e9).contains(&x.abs()) {
        format!("{x:.4e}")
    } else {
        x.to_string()
    }
}

/// `x` to four significant digits, without trailing zeros (a spacing computed from f32
/// coordinates, 0.7979999923706055, reads 0.798).
pub(crate) fn figures(x: f64) -> String {
    if !(x.is_finite() && x != 0.0) {
        return x.to_string();
    }
    // Past a part's largest coordinate, or below a nanometre's thousandth, the exponent
    // says more than its digits (1e-200 would read 0).
    if x.abs() >= 1e9 || x.abs() < 1e-6 {
        return format!("{x:.3e}");
    }
    let decimals = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let text = format!("{x:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

/// What to do about a grid over the node limit: a spacing of at least `min_spacing_mm`
/// (`verb` it), or, when no spacing is wide enough (a limit of one node), a larger limit.
fn spacing_advice(verb: &str, min_spacing_mm: f64) -> String {
    if min_spacing_mm.is_finite() {
        format!(
            "{verb} a spacing of at least {} mm, or raise the node limit (--max-nodes)",
            rounded_up(min_spacing_mm)
        )
    } else {
        "raise the node limit (--max-nodes): no spacing gives so few nodes".to_string()
    }
}

/// A grid's size, `n_u x n_w = nodes`, or only that it has more than `u64::MAX` nodes when
/// a side is too many to count (a side of 2^64 - 1 would read as a count).
fn grid_text(n_u: u64, n_w: u64, nodes: u64) -> String {
    if n_u == u64::MAX || n_w == u64::MAX {
        count_text(u64::MAX)
    } else {
        format!("{n_u} x {n_w} = {}", count_text(nodes))
    }
}

/// A count of nodes, saturated counts (past 64 bits) written as such.
fn count_text(n: u64) -> String {
    if n == u64::MAX {
        "more than 1.8e19".to_string()
    } else {
        n.to_string()
    }
}

/// `x` rounded up to four significant digits and written out, so that a suggested minimum is
/// never below the true one (rounding to nearest could suggest a spacing that is refused).
fn rounded_up(x: f64) -> String {
    if !(x.is_finite() && x > 0.0) {
        return x.to_string();
    }
    let decimals = (3 - x.log10().floor() as i32).max(0);
    let scale = 10f64.powi(decimals);
    let mut up = (x * scale).ceil() / scale;
    if up < x {
        up += 1.0 / scale;
    }
    format!("{up:.*}", decimals as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn automatic_spacings_read_in_four_figures_and_a_limit_of_one_node_asks_for_more() {
        assert_eq!(figures(0.7979999923706055), "0.798");
        assert_eq!(figures(1.4254456510205669), "1.425");
        assert_eq!(figures(120.0), "120");
        let e = OptionsError::PartTooLarge {
            span_mm: 79.80000305175781,
            spacing_mm: 0.7979999923706055,
            nodes: 9292,
            limit: 1,
            min_spacing_mm: f64::INFINITY,
        }
        .to_string();
        assert!(e.contains("spacing of 0.798 mm"), "{e}");
        assert!(
            e.contains("no spacing gives so few nodes") && !e.contains("inf"),
            "{e}"
        );
    }

    #[test]
    fn grids_too_large_for_any_count_say_so_readably() {
        let e = OptionsError::GridTooLarge {
            spacing_mm: 1e-300,
            n_u: u64::MAX,
            n_w: 3,
            nodes: u64::MAX,
            limit: 4_000_000,
            min_spacing_mm: 0.049,
        }
        .to_string();
        assert!(
            e.starts_with(
                "a spacing of 1.0000e-300 mm gives a grid of more than 1.8e19 nodes, more than"
            ),
            "{e}"
        );
        assert!(!e.contains("18446744073709551615"), "{e}");
        let e = OptionsError::GridTooLarge {
            spacing_mm: 0.01,
            n_u: 12001,
            n_w: 8001,
            nodes: 96020001,
            limit: 4_000_000,
            min_spacing_mm: 0.049,
        }
        .to_string();
        assert!(
            e.starts_with("a spacing of 0.01 mm gives a grid of 12001 x 8001 = 96020001 nodes"),
            "{e}"
        );
    }

    #[test]
    fn excerpts_are_short_and_escape_control_bytes() {
        assert_eq!(excerpt(b"facet"), "facet");
        let ansi = excerpt(b"\x1b[31mred\x07\r\n");
        assert!(!ansi.chars().any(|c| c.is_control()), "{ansi}");
        assert!(ansi.contains("\\u{1b}[31mred"), "{ansi}");
        let long = excerpt(&vec![b'9'; 100_000_000]);
        assert!(long.len() < 80, "{long}");
        assert!(long.ends_with("... (100000000 bytes)"), "{long}");
        assert!(!excerpt(&[0xff, 0xfe, b'a']).chars().any(|c| c.is_control()));
        // Bytes that are not UTF-8 are shown as themselves, beside the text around them.
        assert_eq!(excerpt(&[b'c', b'a', b'f', 0xe9, 0xff]), "caf\\xe9\\xff");
        assert_eq!(excerpt("café".as_bytes()), "café");
    }

    #[test]
    fn suggested_spacing_is_rounded_up_to_four_significant_digits() {
        assert_eq!(rounded_up(0.024_999_1), "0.02500");
        assert_eq!(rounded_up(0.025_000_1), "0.02501");
        assert_eq!(rounded_up(0.038_753_68), "0.03876");
        assert_eq!(rounded_up(2.449_1), "2.450");
        assert_eq!(rounded_up(1234.01), "1235");
        for x in [1e-7, 3.3e-3, 0.1, 0.7777777, 12.345678, 98765.4321] {
            let shown: f64 = rounded_up(x).parse().unwrap();
            assert!(shown >= x && shown <= x * 1.001, "{x} shown as {shown}");
        }
    }

    /// Every option a locate error names is a field of the study's options (the service
    /// says where an error is by that field).
    #[test]
    fn locate_errors_name_a_field_of_the_study_options() {
        let fields = serde_json::to_value(crate::study::StudyOptions::default()).unwrap();
        let options = crate::LocateOptions::default();
        let cases = [
            crate::LocateOptions {
                circle_points: 0,
                ..options.clone()
            },
            crate::LocateOptions {
                circle_points: 1 << 20,
                ..options.clone()
            },
            crate::LocateOptions {
                gate_radius_mm: f64::NAN,
                ..options.clone()
            },
            crate::LocateOptions {
                max_nodes: 0,
                ..options.clone()
            },
            crate::LocateOptions {
                spacing: crate::gate::Spacing::Mm(-1.0),
                ..options.clone()
            },
            crate::LocateOptions {
                grid_offset: f64::INFINITY,
                ..options.clone()
            },
            crate::LocateOptions {
                flat_tolerance_mm: Some(-1.0),
                ..options.clone()
            },
        ];
        for o in cases {
            let e = o.validate().unwrap_err();
            let field = e.field().unwrap_or_else(|| panic!("no field for {e}"));
            assert!(fields.get(field).is_some(), "{field} ({e})");
        }
        assert_eq!(
            OptionsError::BadDirection("x".into()).field(),
            Some("demold")
        );
    }
}
