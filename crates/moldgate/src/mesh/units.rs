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
    /// The unit's name in words ("inches").
    pub fn long_name(self) -> &'static str {
        match self {
            Units::Mm => "millimetres",
            Units::Cm => "centimetres",
            Units::M => "metres",
            Units::In => "inches",
        }
    }

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

/// What to do about a part of `diagonal_mm` across read in `read_as` whose size is in
/// doubt: the units in which the file would be a part of a plausible size ("if the file
/// is in metres, set its units to m (--units)"), or, when no unit would, to check them.
pub fn units_advice(diagonal_mm: f64, read_as: Units) -> String {
    let raw = diagonal_mm / read_as.mm_per_unit();
    let plausible: Vec<Units> = [Units::Mm, Units::Cm, Units::M, Units::In]
        .into_iter()
        .filter(|&u| u != read_as && !size_is_suspicious(raw * u.mm_per_unit()))
        .collect();
    let name = |u: Units| u.long_name();
    let list = |words: Vec<String>| match words.as_slice() {
        [] => String::new(),
        [one] => one.clone(),
        [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
    };
    if plausible.is_empty() {
        return "check the file's units (--units)".into();
    }
    format!(
        "if the file is in {}, set its units to {} (--units)",
        list(plausible.iter().map(|&u| name(u).to_string()).collect()),
        list(plausible.iter().map(|u| u.to_string()).collect())
    )
}

/// A warning when a part measured in millimetres has a size that suggests another unit, or
/// `None` when the size is plausible for a moulded part ([`SMALL_PART_MM`] to
/// [`LARGE_PART_MM`] across).
pub fn size_warning(diagonal_mm: f64, units: Units) -> Option<String> {
    if diagonal_mm < SMALL_PART_MM {
        Some(format!(
            "the part is only {diagonal_mm:.4} mm across (read as {units}); {}",
            units_advice(diagonal_mm, units)
        ))
    } else if diagonal_mm > LARGE_PART_MM {
        Some(format!(
            "the part is {diagonal_mm:.0} mm across (read as {units}), large for a moulded part; {}",
            units_advice(diagonal_mm, units)
        ))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_advice_names_the_units_that_make_a_part_of_a_plausible_size() {
        // A part of 65.9 mm across exported in metres and read in inches.
        let as_inches = 0.0659 * 25.4;
        assert_eq!(
            units_advice(as_inches, Units::In),
            "if the file is in metres, set its units to m (--units)"
        );
        // 3 mm across read as mm: a part drawn in centimetres or inches.
        assert_eq!(
            units_advice(3.0, Units::Mm),
            "if the file is in centimetres or inches, set its units to cm or in (--units)"
        );
        // A dust grain in any unit: no unit helps.
        assert_eq!(
            units_advice(1e-6, Units::Mm),
            "check the file's units (--units)"
        );
        // Too large read in metres: millimetres, centimetres or inches would do.
        assert_eq!(
            units_advice(40_000.0, Units::M),
            "if the file is in millimetres, centimetres or inches, set its units to mm, cm or in (--units)"
        );
    }
}
