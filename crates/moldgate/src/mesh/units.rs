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
            _ => Err(format!("unknown unit '{s}' (expected mm, cm, m or in)")),
        }
    }
}

/// A warning when a part measured in millimetres has a size that suggests another unit, or
/// `None` when the size is plausible for a moulded part (2 mm to 2 m across).
pub fn size_warning(diagonal_mm: f64, units: Units) -> Option<String> {
    if diagonal_mm < 2.0 {
        let hint = if units == Units::Mm {
            "; if the file is in metres or inches, pass --units m or --units in"
        } else {
            ""
        };
        Some(format!(
            "the part is only {diagonal_mm:.4} mm across (read as {units}){hint}"
        ))
    } else if diagonal_mm > 2000.0 {
        Some(format!(
            "the part is {diagonal_mm:.0} mm across (read as {units}), large for a moulded part; check --units"
        ))
    } else {
        None
    }
}
