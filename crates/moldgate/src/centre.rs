//! Centres of mass: the paper's surface superposition (Eq. 3-5) and the volumetric centre of
//! the enclosed solid (divergence theorem).

use rayon::prelude::*;
use serde::Serialize;

use crate::math::DVec3;
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

impl Centres {
    /// Computes both centres in one pass over the triangles.
    pub fn of(mesh: &Mesh) -> Centres {
        // Moments are taken about the box centre so that the volume sums do not cancel
        // catastrophically on parts far from the origin.
        let bounds = mesh.bounds();
        let origin = bounds.centre();
        // Partial sums over fixed runs of triangles, in parallel, added in run order: the
        // result does not depend on the number of threads.
        const RUN: usize = 8192;
        let partial: Vec<(f64, DVec3, f64, DVec3)> = (0..mesh.triangles.len().div_ceil(RUN))
            .into_par_iter()
            .map(|r| {
                let mut sums = (0.0, DVec3::ZERO, 0.0, DVec3::ZERO);
                for t in r * RUN..((r + 1) * RUN).min(mesh.triangles.len()) {
                    let [a, b, c] = mesh.corners(t).map(|p| p - origin);
                    let cross = (b - a).cross(c - a);
                    let a_f = 0.5 * cross.length(); // Eq. 3
                    let c_f = (a + b + c) / 3.0; // Eq. 4
                    sums.0 += a_f;
                    sums.1 += c_f * a_f;
                    // Signed tetrahedron (origin, a, b, c): volume a.(b x c)/6, centroid
                    // (a+b+c)/4.
                    let v = a.dot(b.cross(c)) / 6.0;
                    sums.2 += v;
                    sums.3 += (a + b + c) * (v / 4.0);
                }
                sums
            })
            .collect();
        let (mut area, mut area_moment, mut volume, mut volume_moment) =
            (0.0, DVec3::ZERO, 0.0, DVec3::ZERO);
        for p in partial {
            area += p.0;
            area_moment += p.1;
            volume += p.2;
            volume_moment += p.3;
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
