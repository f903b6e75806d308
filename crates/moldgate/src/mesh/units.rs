//! Length units of mesh files.

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

/// The length unit a mesh file is written in. Loading converts every coordinate to millimetres.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// Millimetres (the default: what CAD exports to STL most often).
    #[default]
    Mm,
    /// Centimetres.
    Cm,
    /// Metres.
    M,
    /// Inches.
    In,
}

impl Units {
    /// How many millimetres one unit is.
    pub fn mm_per_unit(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::Cm => 10.0,
            Units::M => 1000.0,
            Units::In => 25.4,
        }
    }

    /// The unit's short name, as accepted by [`Units::from_str`].
    pub fn name(self) -> &'static str {
        match self {
            Units::Mm => "mm",
            Units::Cm => "cm",
            Units::M => "m",
            Units::In => "in",
        }
    }
}

impl fmt::Display for Units {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Units {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "mm" => Ok(Units::Mm),
            "cm" => Ok(Units::Cm),
            "m" => Ok(Units::M),
            "in" | "inch" | "inches" => Ok(Units::In),
            _ => Err(format!(
                "unknown unit '{}' (expected mm, cm, m or in)",
                crate::error::excerpt(s.as_bytes())
            )),
        }
    }
}

/// Parts smaller than this across (bounding-box diagonal, mm) get a warning that the file
/// may be in other units: a part 5 inches long read as millimetres is 5 mm long, and a
/// moulded part under a centimetre across is rare enough to deserve the question.
pub const SMALL_PART_MM: f64 = 10.0;

/// Parts larger than this across (mm) get a warning that the file may be in other units.
pub const LARGE_PART_MM: f64 = 2000.0;

/// True when a part of this diagonal (mm) is outside the plausible range of moulded parts,
/// so that the units it was read in are in doubt.
pub fn size_is_suspicious(diagonal_mm: f64) -> bool {
    !(SMALL_PART_MM..=LARGE_PART_MM).contains(&diagonal_mm)
}

/// A warning when a part measured in millimetres has a size that suggests another unit, or
/// `None` when the size is plausible for a moulded part ([`SMALL_PART_MM`] to
/// [`LARGE_PART_MM`] across).
pub fn size_warning(diagonal_mm: f64, units: Units) -> Option<String> {
    if diagonal_mm < SMALL_PART_MM {
        let hint = if units == Units::Mm {
            "; if the file is in inches, centimetres or metres, set its units to in, cm or m (--units)"
        } else {
            ""
        };
        Some(format!(
            "the part is only {diagonal_mm:.4} mm across (read as {units}){hint}"
        ))
    } else if diagonal_mm > LARGE_PART_MM {
        Some(format!(
            "the part is {diagonal_mm:.0} mm across (read as {units}), large for a moulded part; check the file's units (--units)"
        ))
    } else {
        None
    }
}
