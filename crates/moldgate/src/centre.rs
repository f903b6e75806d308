//! Centres of mass: the paper's surface superposition (Eq. 3-5) and the volumetric centre of
//! the enclosed solid (divergence theorem).

use rayon::prelude::*;
use serde::Serialize;

use crate::math::{Aabb, DVec3};
use crate::mesh::Mesh;

/// Which centre of mass the gate is placed by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CentreKind {
    /// The area-weighted mean of the facet centroids, the paper's Eq. 5 (the default).
    #[default]
    Surface,
    /// The centroid of the enclosed volume; needs a closed mesh.
    Volume,
}

/// Both centres of mass of a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Centres {
    /// Eq. 5: sum(C_f A_f) / sum(A_f), with A_f from Eq. 3 and C_f from Eq. 4.
    pub surface: DVec3,
    /// Total facet area in mm^2 (the denominator of Eq. 5).
    pub area_mm2: f64,
    /// The centroid of the enclosed solid, when its signed volume is not negligible.
    pub volume: Option<DVec3>,
    /// Signed enclosed volume in mm^3 (positive for outward-facing normals).
    pub volume_mm3: f64,
}

/// Triangles in a run of [`Centres::of`]'s partial sums: the runs' sums are added in
/// order, so the result does not depend on the number of threads.
pub(crate) const RUN: usize = 8192;

/// The sums of one run of triangles, moments about the box centre.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Moments {
    area: f64,
    area_moment: DVec3,
    volume: f64,
    volume_moment: DVec3,
}

impl Moments {
    /// Adds a triangle with corners `a`, `b`, `c` (relative to the box centre) and
    /// `cross` = (b - a) x (c - a).
    #[inline]
    pub(crate) fn add(&mut self, [a, b, c]: [DVec3; 3], cross: DVec3) {
        let a_f = 0.5 * cross.length(); // Eq. 3
        let sum = a + b + c;
        let c_f = sum / 3.0; // Eq. 4
        self.area += a_f;
        self.area_moment += c_f * a_f;
        // Signed tetrahedron (origin, a, b, c): volume a.(b x c)/6, centroid (a+b+c)/4.
        let v = a.dot(b.cross(c)) / 6.0;
        self.volume += v;
        self.volume_moment += sum * (v / 4.0);
    }
}

impl Centres {
    /// Computes both centres in one pass over the triangles. A loaded part has them already
    /// ([`crate::LoadedMesh::centres`], summed in the pass that measures its area).
    pub fn of(mesh: &Mesh) -> Centres {
        // Moments are taken about the box centre so that the volume sums do not cancel
        // catastrophically on parts far from the origin.
        let bounds = mesh.bounds();
        let origin = bounds.centre();
        // Partial sums over fixed runs of triangles, in parallel, added in run order: the
        // result does not depend on the number of threads.
        let partial: Vec<Moments> = (0..mesh.triangles.len().div_ceil(RUN))
            .into_par_iter()
            .map(|r| {
                let mut sums = Moments::default();
                for t in r * RUN..((r + 1) * RUN).min(mesh.triangles.len()) {
                    let [a, b, c] = mesh.corners(t).map(|p| p - origin);
                    sums.add([a, b, c], (b - a).cross(c - a));
                }
                sums
            })
            .collect();
        Centres::from_runs(&bounds, &partial)
    }

    /// The centres from the sums of consecutive runs of [`RUN`] triangles, in order, with
    /// moments about the centre of `bounds` (the mesh's box).
    pub(crate) fn from_runs(bounds: &Aabb, partial: &[Moments]) -> Centres {
        let origin = bounds.centre();
        let (mut area, mut area_moment, mut volume, mut volume_moment) =
            (0.0, DVec3::ZERO, 0.0, DVec3::ZERO);
        for p in partial {
            area += p.area;
            area_moment += p.area_moment;
            volume += p.volume;
            volume_moment += p.volume_moment;
        }
        let size = bounds.diagonal();
        let volume_centre = if volume.abs() > 1e-9 * size * size * size {
            Some(origin + volume_moment / volume).filter(|c| c.is_finite())
        } else {
            None
        };
        // Loading refuses meshes without area, and takes areas about the same box centre, so
        // `area` is positive here; the box centre stands in should it ever not be.
        let surface = if area > 0.0 {
            origin + area_moment / area // Eq. 5
        } else {
            origin
        };
        Centres {
            surface,
            area_mm2: area,
            volume: volume_centre,
            volume_mm3: volume,
        }
    }

    /// The centre of the kind asked for, or `None` for a volume centre of a mesh that
    /// encloses no volume.
    pub fn get(&self, kind: CentreKind) -> Option<DVec3> {
        match kind {
            CentreKind::Surface => Some(self.surface),
            CentreKind::Volume => self.volume,
        }
    }
}
