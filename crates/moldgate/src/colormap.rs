//! The one colour map of every picture and 3D file: viridis, a perceptually uniform map from
//! dark purple (low) through blue and green to yellow (high), readable in grey and by the
//! common forms of colour blindness. The PNG renderer and the glTF writer both colour the
//! scene's field with [`colour`] after [`Range::t`], so a value has the same colour in both.
//!
//! The map is matplotlib's `viridis` (van der Walt and Smith, CC0), sampled every 16th of its
//! 256 entries plus the last, and interpolated linearly in sRGB between the samples (the
//! largest difference from the full table is under one step of 8-bit colour).

/// The colour of an unknown value (NaN): a neutral grey, outside the map's hues.
pub const NAN_GREY: [u8; 3] = [128, 128, 128];

/// Viridis in sRGB (0..1) at the table positions 0, 16, ..., 240 and 255 of 255.
const VIRIDIS: [(f32, [f32; 3]); 17] = [
    (0.0, [0.267004, 0.004874, 0.329415]),
    (16.0, [0.282327, 0.094955, 0.417331]),
    (32.0, [0.278826, 0.175490, 0.483397]),
    (48.0, [0.258965, 0.251537, 0.524736]),
    (64.0, [0.229739, 0.322361, 0.545706]),
    (80.0, [0.199430, 0.387607, 0.554642]),
    (96.0, [0.172719, 0.448791, 0.557885]),
    (112.0, [0.149039, 0.508051, 0.557250]),
    (128.0, [0.127568, 0.566949, 0.550556]),
    (144.0, [0.120638, 0.625828, 0.533488]),
    (160.0, [0.157851, 0.683765, 0.501686]),
    (176.0, [0.246070, 0.738910, 0.452024]),
    (192.0, [0.369214, 0.788888, 0.382914]),
    (208.0, [0.515992, 0.831158, 0.294279]),
    (224.0, [0.678489, 0.863742, 0.189503]),
    (240.0, [0.845561, 0.887322, 0.099702]),
    (255.0, [0.993248, 0.906157, 0.143936]),
];

/// The sRGB colour of `t` in 0..1 (clamped); NaN gives [`NAN_GREY`].
pub fn colour(t: f32) -> [u8; 3] {
    if t.is_nan() {
        return NAN_GREY;
    }
    let x = t.clamp(0.0, 1.0) * 255.0;
    // The sample at or below x, and the one after it.
    let k = VIRIDIS
        .iter()
        .rposition(|&(p, _)| p <= x)
        .unwrap_or(0)
        .min(VIRIDIS.len() - 2);
    let (p0, c0) = VIRIDIS[k];
    let (p1, c1) = VIRIDIS[k + 1];
    let f = ((x - p0) / (p1 - p0)).clamp(0.0, 1.0);
    let mut out = [0u8; 3];
    for i in 0..3 {
        let v = c0[i] + (c1[i] - c0[i]) * f;
        out[i] = (v * 255.0).round().clamp(0.0, 255.0) as u8;
    }
    out
}

/// The linear-light value (0..1) of an 8-bit sRGB channel (IEC 61966-2-1), as glTF's vertex
/// colours and material factors are linear.
pub fn srgb_to_linear(c: u8) -> f32 {
    let s = c as f32 / 255.0;
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// The span of a field's finite values, which [`Range::t`] maps onto 0..1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// Smallest finite value.
    pub min: f32,
    /// Largest finite value.
    pub max: f32,
}

impl Range {
    /// The span of the finite values, or `None` when there is none (every value NaN or
    /// infinite, or no value).
    pub fn of(values: &[f32]) -> Option<Range> {
        let mut finite = values.iter().copied().filter(|v| v.is_finite());
        let first = finite.next()?;
        let (min, max) = finite.fold((first, first), |(lo, hi), v| (lo.min(v), hi.max(v)));
        Some(Range { min, max })
    }

    /// Where `v` lies in the range, 0 at `min` and 1 at `max` (clamped); 0.5 for every value
    /// of a range with no width; NaN for NaN.
    pub fn t(&self, v: f32) -> f32 {
        if v.is_nan() {
            return f32::NAN;
        }
        let width = self.max - self.min;
        if width > 0.0 && width.is_finite() {
            ((v - self.min) / width).clamp(0.0, 1.0)
        } else {
            0.5
        }
    }
}

/// The colour of every value of a field, normalised by its own range; unknown values grey.
pub fn colours(values: &[f32]) -> Vec<[u8; 3]> {
    let range = Range::of(values);
    values
        .iter()
        .map(|&v| match range {
            Some(r) if v.is_finite() => colour(r.t(v)),
            _ => NAN_GREY,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ends_and_quarters_are_viridis() {
        // The published 8-bit viridis colours at 0, 1/4, 1/2, 3/4 and 1 (#440154, #3b528b,
        // #21918c, #5ec962, #fde725), within one step.
        let expected: [(f32, [u8; 3]); 5] = [
            (0.0, [0x44, 0x01, 0x54]),
            (0.25, [0x3b, 0x52, 0x8b]),
            (0.5, [0x21, 0x91, 0x8c]),
            (0.75, [0x5e, 0xc9, 0x62]),
            (1.0, [0xfd, 0xe7, 0x25]),
        ];
        for (t, want) in expected {
            let got = colour(t);
            for i in 0..3 {
                assert!(
                    (got[i] as i32 - want[i] as i32).abs() <= 1,
                    "t = {t}: {got:?} vs {want:?}"
                );
            }
        }
    }

    #[test]
    fn clamps_and_greys() {
        assert_eq!(colour(-3.0), colour(0.0));
        assert_eq!(colour(7.0), colour(1.0));
        assert_eq!(colour(f32::NAN), NAN_GREY);
    }

    #[test]
    fn lightness_rises() {
        // Viridis is monotone in lightness; the luma of the samples must rise.
        let luma = |c: [u8; 3]| 0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32;
        let mut last = -1.0;
        for i in 0..=100 {
            let l = luma(colour(i as f32 / 100.0));
            assert!(l >= last, "luma falls at t = {}", i as f32 / 100.0);
            last = l;
        }
    }

    #[test]
    fn range_normalises() {
        let r = Range::of(&[f32::NAN, 2.0, -1.0, 5.0, f32::INFINITY]).unwrap();
        assert_eq!(
            r,
            Range {
                min: -1.0,
                max: 5.0
            }
        );
        assert_eq!(r.t(-1.0), 0.0);
        assert_eq!(r.t(5.0), 1.0);
        assert_eq!(r.t(2.0), 0.5);
        assert!(r.t(f32::NAN).is_nan());
        assert_eq!(Range::of(&[f32::NAN]), None);
        assert_eq!(Range::of(&[]), None);
        assert_eq!(Range { min: 3.0, max: 3.0 }.t(3.0), 0.5);
        let c = colours(&[0.0, f32::NAN, 1.0]);
        assert_eq!(c, vec![colour(0.0), NAN_GREY, colour(1.0)]);
    }

    #[test]
    fn linear_light() {
        assert_eq!(srgb_to_linear(0), 0.0);
        assert!((srgb_to_linear(255) - 1.0).abs() < 1e-6);
        // sRGB 50 % grey is about 21.6 % linear light.
        assert!((srgb_to_linear(128) - 0.2158).abs() < 1e-3);
    }
}
