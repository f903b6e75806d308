//! Places no gate may go: keep-out boxes and spheres, and cosmetic faces (faces that face a
//! visible direction).
//!
//! A candidate is kept out when its gate disc (radius R_gate around the node's surface point)
//! reaches into a region: the point lies within R_gate of a box, or within r + R_gate of a
//! sphere's centre. A cosmetic direction C forbids candidates whose surface normal leans
//! towards C (n.C > 0.01, i.e. faces turned towards C by more than about half a degree);
//! faces parallel to C stay allowed.

use std::str::FromStr;

use serde::Serialize;

use crate::error::OptionsError;
use crate::math::DVec3;

/// A keep-out region, in mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "shape", rename_all = "lowercase")]
pub enum Region {
    /// An axis-aligned box between two corners.
    Box {
        /// Smaller corner.
        min: [f64; 3],
        /// Larger corner.
        max: [f64; 3],
    },
    /// A ball.
    Sphere {
        /// Centre.
        centre: [f64; 3],
        /// Radius.
        radius: f64,
    },
}

impl Region {
    /// True when a disc of radius `r` at `p` reaches into the region (distance from `p` to
    /// the region below `r`, or `p` inside).
    pub fn touches(&self, p: DVec3, r: f64) -> bool {
        match *self {
            Region::Box { min, max } => {
                let q = p.clamp(DVec3::from_array(min), DVec3::from_array(max));
                q.distance(p) < r || q == p
            }
            Region::Sphere { centre, radius } => DVec3::from_array(centre).distance(p) < radius + r,
        }
    }
}

impl Region {
    /// True when a disc of radius `r` somewhere in the box `min..max` could reach into the
    /// region: the region comes within `r` of the box.
    pub fn meets_box(&self, min: DVec3, max: DVec3, r: f64) -> bool {
        match *self {
            Region::Box { min: a, max: b } => {
                let (a, b) = (DVec3::from_array(a), DVec3::from_array(b));
                // The gap between the two boxes along each axis.
                let gap = (a - max).max(min - b).max(DVec3::ZERO);
                gap.length() < r || gap == DVec3::ZERO
            }
            Region::Sphere { centre, radius } => {
                let c = DVec3::from_array(centre);
                c.clamp(min, max).distance(c) < radius + r
            }
        }
    }

    /// The eight corners of a box between `min` and `max`, corner i taking `max` on the
    /// axes whose bit is set in i (x 1, y 2, z 4): two corners whose numbers differ in one
    /// bit share an edge.
    pub fn box_corners(min: [f64; 3], max: [f64; 3]) -> [DVec3; 8] {
        std::array::from_fn(|i| {
            DVec3::new(
                if i & 1 == 0 { min[0] } else { max[0] },
                if i & 2 == 0 { min[1] } else { max[1] },
                if i & 4 == 0 { min[2] } else { max[2] },
            )
        })
    }

    /// The region in words, mm.
    pub fn describe(&self) -> String {
        let v = |p: [f64; 3]| format!("({:.3}, {:.3}, {:.3})", p[0], p[1], p[2]);
        match *self {
            Region::Box { min, max } => format!("the box {} to {} mm", v(min), v(max)),
            Region::Sphere { centre, radius } => {
                format!("the sphere of radius {radius:.3} mm at {} mm", v(centre))
            }
        }
    }
}

impl FromStr for Region {
    type Err = OptionsError;

    /// Reads `box:x0,y0,z0,x1,y1,z1` (any two opposite corners) or `sphere:x,y,z,r`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || OptionsError::BadRegion(crate::error::excerpt(s.as_bytes()));
        let (shape, numbers) = s.split_once(':').ok_or_else(bad)?;
        let v: Vec<f64> = numbers
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad())?;
        if v.iter().any(|x| !x.is_finite()) {
            return Err(bad());
        }
        match (shape.trim().to_ascii_lowercase().as_str(), v.as_slice()) {
            ("box", &[x0, y0, z0, x1, y1, z1]) => Ok(Region::Box {
                min: [x0.min(x1), y0.min(y1), z0.min(z1)],
                max: [x0.max(x1), y0.max(y1), z0.max(z1)],
            }),
            ("sphere", &[x, y, z, r]) if r > 0.0 => Ok(Region::Sphere {
                centre: [x, y, z],
                radius: r,
            }),
            _ => Err(bad()),
        }
    }
}

/// The threshold of n.C above which a face counts as facing the cosmetic direction.
pub const COSMETIC_COS: f64 = 0.01;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_parse_and_reach_by_the_gate_radius() {
        let b: Region = "box:10,0,0,0,10,10".parse().unwrap();
        assert_eq!(
            b,
            Region::Box {
                min: [0.0; 3],
                max: [10.0; 3]
            }
        );
        assert!(b.touches(DVec3::new(5.0, 5.0, 5.0), 1.0));
        assert!(b.touches(DVec3::new(10.5, 5.0, 5.0), 1.0));
        assert!(!b.touches(DVec3::new(11.5, 5.0, 5.0), 1.0));
        let s: Region = "Sphere: 0, 0, 0, 2".parse().unwrap();
        assert!(s.touches(DVec3::new(2.9, 0.0, 0.0), 1.0));
        assert!(!s.touches(DVec3::new(3.1, 0.0, 0.0), 1.0));
        for bad in [
            "box:1,2,3",
            "sphere:0,0,0,-1",
            "cone:1,2,3,4",
            "box:1,2,3,4,5,nan",
            "sphere",
        ] {
            assert!(bad.parse::<Region>().is_err(), "{bad}");
        }
    }

    #[test]
    fn a_region_meets_a_box_when_it_comes_within_the_radius() {
        let (min, max) = (DVec3::ZERO, DVec3::splat(10.0));
        let sphere = |c: [f64; 3], radius| Region::Sphere { centre: c, radius };
        // Inside, touching across a gap below r, and beyond r (along an axis, and past a
        // corner, where the gap is the diagonal).
        assert!(sphere([5.0; 3], 1.0).meets_box(min, max, 0.5));
        assert!(sphere([11.9, 5.0, 5.0], 1.0).meets_box(min, max, 1.0));
        assert!(!sphere([12.1, 5.0, 5.0], 1.0).meets_box(min, max, 1.0));
        assert!(!sphere([11.5, 11.5, 11.5], 1.0).meets_box(min, max, 1.0));
        let cube = |a: [f64; 3], b: [f64; 3]| Region::Box { min: a, max: b };
        assert!(cube([2.0; 3], [3.0; 3]).meets_box(min, max, 0.1));
        assert!(cube([-5.0; 3], [20.0; 3]).meets_box(min, max, 0.1));
        assert!(cube([10.5, 0.0, 0.0], [11.0, 1.0, 1.0]).meets_box(min, max, 0.6));
        assert!(!cube([10.5, 0.0, 0.0], [11.0, 1.0, 1.0]).meets_box(min, max, 0.4));
        assert!(!cube([10.3, 10.3, 10.3], [11.0; 3]).meets_box(min, max, 0.5));
        // Each agrees with `touches` at the box's nearest point.
        for (region, expect) in [
            (sphere([12.1, 5.0, 5.0], 1.0), false),
            (cube([10.5, 0.0, 0.0], [11.0, 1.0, 1.0]), true),
        ] {
            assert_eq!(region.touches(DVec3::new(10.0, 0.5, 0.5), 0.6), expect);
        }
    }
}
