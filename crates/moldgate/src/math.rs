//! Concrete geometry types: f64 vectors for positions and sums, and an axis-aligned box.
//!
//! Everything after loading is in millimetres.

pub use glam::{DVec2, DVec3};

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: DVec3,
    /// Largest corner.
    pub max: DVec3,
}

impl Aabb {
    /// The box that contains nothing; growing it by a point gives that point's box.
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    /// The smallest box around `points`.
    pub fn of_points<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grown(*p))
    }

    /// This box grown to contain `p`.
    pub fn grown(self, p: DVec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// Edge lengths along x, y and z.
    pub fn size(&self) -> DVec3 {
        self.max - self.min
    }

    /// Length of the diagonal: the part's size, used to scale tolerances.
    pub fn diagonal(&self) -> f64 {
        self.size().length()
    }

    /// The centre of the box.
    pub fn centre(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }
}

/// The bits of `x` made to compare as unsigned numbers in the order of [`f32::total_cmp`]
/// (for sort and depth keys); [`from_ordered_bits`] gives `x` back.
#[inline]
pub(crate) fn ordered_bits(x: f32) -> u32 {
    let bits = x.to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | 1 << 31
    }
}

/// The value of [`ordered_bits`].
#[inline]
pub(crate) fn from_ordered_bits(ordered: u32) -> f32 {
    f32::from_bits(if ordered >> 31 == 1 {
        ordered & !(1 << 31)
    } else {
        !ordered
    })
}

/// Twice the signed area of the 2D triangle (a, b, c): positive when counter-clockwise.
#[inline]
pub fn orient2d(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// The point of segment `a`-`b` nearest to `p`.
pub fn nearest_on_segment(a: DVec3, b: DVec3, p: DVec3) -> DVec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 == 0.0 {
        return a;
    }
    let t = ((p - a).dot(ab) / len2).clamp(0.0, 1.0);
    a + ab * t
}
