//! The demolding direction D and the projection frame (u, w) perpendicular to it.

use std::str::FromStr;

use crate::error::OptionsError;
use crate::math::{DVec2, DVec3};

/// A unit demolding direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Direction(DVec3);

impl Direction {
    /// +Z, the default.
    pub const PLUS_Z: Direction = Direction(DVec3::Z);

    /// Normalises `v`; a zero or non-finite vector is an error.
    pub fn new(v: DVec3) -> Result<Direction, OptionsError> {
        // Scaled by its largest component first, so that neither huge nor tiny components
        // overflow or underflow when squared.
        let largest = v.abs().max_element();
        if !(v.is_finite() && largest > 0.0) {
            return Err(OptionsError::ZeroDirection(v.x, v.y, v.z));
        }
        Ok(Direction((v / largest).normalize()))
    }

    /// The unit vector.
    pub fn vector(self) -> DVec3 {
        self.0
    }
}

impl Default for Direction {
    fn default() -> Self {
        Direction::PLUS_Z
    }
}

impl FromStr for Direction {
    type Err = OptionsError;

    /// Reads `+z`, `-y`, `x` (an axis with an optional sign) or `x,y,z` (three numbers).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim().to_ascii_lowercase();
        let (sign, axis) = match t.strip_prefix('-') {
            Some(rest) => (-1.0, rest),
            None => (1.0, t.strip_prefix('+').unwrap_or(&t)),
        };
        let unit = match axis {
            "x" => Some(DVec3::X),
            "y" => Some(DVec3::Y),
            "z" => Some(DVec3::Z),
            _ => None,
        };
        if let Some(u) = unit {
            return Direction::new(u * sign);
        }
        let parts: Vec<&str> = t.split(',').map(str::trim).collect();
        let numbers: Option<Vec<f64>> = parts.iter().map(|p| p.parse::<f64>().ok()).collect();
        match numbers.as_deref() {
            Some(&[x, y, z]) => Direction::new(DVec3::new(x, y, z)),
            _ => Err(OptionsError::BadDirection(crate::error::excerpt(
                s.as_bytes(),
            ))),
        }
    }
}

/// An orthonormal frame: the demolding direction `d` and two axes `u`, `w` of the projection
/// plane, with u x w = d.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// The demolding direction; rays come from its + side and travel along -d.
    pub d: DVec3,
    /// First axis of the projection plane.
    pub u: DVec3,
    /// Second axis of the projection plane.
    pub w: DVec3,
}

impl Frame {
    /// The frame of `d`. `u` is the world axis least aligned with `d` (the first on ties),
    /// made perpendicular to it, and w = d x u: for +Z this gives u = +X and w = +Y, for +Y it
    /// gives u = +X and w = -Z. The rule is fixed so that grids are reproducible.
    pub fn new(d: Direction) -> Frame {
        let d = d.vector();
        let a = d.abs();
        let helper = if a.x <= a.y && a.x <= a.z {
            DVec3::X
        } else if a.y <= a.z {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let u = (helper - d * helper.dot(d)).normalize();
        Frame {
            d,
            u,
            w: d.cross(u),
        }
    }

    /// Coordinates of `p` in the projection plane.
    #[inline]
    pub fn project(&self, p: DVec3) -> DVec2 {
        DVec2::new(p.dot(self.u), p.dot(self.w))
    }

    /// Height of `p` along `d`.
    #[inline]
    pub fn height(&self, p: DVec3) -> f64 {
        p.dot(self.d)
    }

    /// The 3D point with plane coordinates `q` and height `h`.
    #[inline]
    pub fn point(&self, q: DVec2, h: f64) -> DVec3 {
        self.u * q.x + self.w * q.y + self.d * h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_and_tiny_vectors_normalise() {
        for v in [DVec3::new(1e308, 1e308, 0.0), DVec3::new(1e-320, 0.0, 0.0)] {
            let d = Direction::new(v).unwrap().vector();
            assert!((d.length() - 1.0).abs() < 1e-15, "{v}");
        }
        assert!(Direction::new(DVec3::ZERO).is_err());
        assert!(Direction::new(DVec3::new(f64::NAN, 0.0, 1.0)).is_err());
    }

    #[test]
    fn parses_axes_and_vectors() {
        assert_eq!("+z".parse::<Direction>().unwrap().vector(), DVec3::Z);
        assert_eq!("-Y".parse::<Direction>().unwrap().vector(), -DVec3::Y);
        assert_eq!("x".parse::<Direction>().unwrap().vector(), DVec3::X);
        let v = "1, 1, 0".parse::<Direction>().unwrap().vector();
        assert!((v - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-15);
        assert!(matches!(
            "0,0,0".parse::<Direction>(),
            Err(OptionsError::ZeroDirection(..))
        ));
        assert!(matches!(
            "up".parse::<Direction>(),
            Err(OptionsError::BadDirection(_))
        ));
        assert!("1,2".parse::<Direction>().is_err());
        assert!("nan,0,1".parse::<Direction>().is_err());
    }

    #[test]
    fn frames_are_right_handed_and_match_the_documented_axes() {
        let f = Frame::new(Direction::PLUS_Z);
        assert_eq!((f.u, f.w), (DVec3::X, DVec3::Y));
        let f = Frame::new(Direction::new(DVec3::Y).unwrap());
        assert_eq!((f.u, f.w), (DVec3::X, -DVec3::Z));
        for v in [
            DVec3::new(1.0, 2.0, 3.0),
            DVec3::new(-0.3, 0.0, -5.0),
            -DVec3::X,
        ] {
            let f = Frame::new(Direction::new(v).unwrap());
            assert!((f.u.cross(f.w) - f.d).length() < 1e-12);
            assert!(f.u.dot(f.d).abs() < 1e-12 && f.w.dot(f.d).abs() < 1e-12);
            let p = DVec3::new(3.0, -4.0, 5.0);
            assert!((f.point(f.project(p), f.height(p)) - p).length() < 1e-12);
        }
    }
}
