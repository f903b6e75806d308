//! One line of a batch summary: what came of one part, in the columns every front end's
//! batch writes (the command line's `--summary x.jsonl` and CSV, the Python package's
//! batches), so their rows can be compared and joined.

use serde::Serialize;

use crate::mesh::Units;
use crate::report::Report;

/// What came of one part of a batch. Each status is the exit code the part would give alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// A gate was found (exit code 0).
    Ok,
    /// The part was studied but no gate qualifies (4).
    NoGate,
    /// The file could not be read (3).
    InputError,
    /// An option was refused (2).
    OptionError,
    /// The study was stopped at its time limit (6).
    /// Stopped after the gate was located, a study whose answer is the method's gate has
    /// the numbers of the part located before the stop; any other, none.
    Timeout,
    /// An output could not be written (5).
    OutputError,
    /// A defect of moldgate (1).
    InternalError,
    /// A folder's entry that is not a regular file (0: it does not change a batch's exit
    /// code).
    Skipped,
}

impl Status {
    /// The status of an exit code (anything unknown is an internal error).
    pub fn from_exit_code(code: u8) -> Status {
        match code {
            0 => Status::Ok,
            2 => Status::OptionError,
            3 => Status::InputError,
            4 => Status::NoGate,
            5 => Status::OutputError,
            6 => Status::Timeout,
            _ => Status::InternalError,
        }
    }

    /// The exit code of the status.
    pub fn exit_code(self) -> u8 {
        match self {
            Status::Ok | Status::Skipped => 0,
            Status::InternalError => 1,
            Status::OptionError => 2,
            Status::InputError => 3,
            Status::NoGate => 4,
            Status::OutputError => 5,
            Status::Timeout => 6,
        }
    }

    /// The status in snake case (`"no_gate"`), as in the rows.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::NoGate => "no_gate",
            Status::InputError => "input_error",
            Status::OptionError => "option_error",
            Status::Timeout => "timeout",
            Status::OutputError => "output_error",
            Status::InternalError => "internal_error",
            Status::Skipped => "skipped",
        }
    }
}

/// One line of a batch summary. The JSON keys, in this order, are the CSV header.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BatchRow {
    /// The input file as given.
    pub file: String,
    /// What came of it.
    pub status: Status,
    /// The part's own exit code, as `moldgate locate FILE` would give.
    pub exit_code: u8,
    /// Unit the file was read in.
    pub units: String,
    /// Demolding direction as given.
    pub demold: String,
    /// Triangles after welding.
    pub triangles: Option<u64>,
    /// The gate, mm.
    pub gate_x_mm: Option<f64>,
    /// The gate, mm.
    pub gate_y_mm: Option<f64>,
    /// The gate, mm.
    pub gate_z_mm: Option<f64>,
    /// The answer's gates: 1, or K of a layout of several (`gates` K); the first is
    /// `gate_x_mm` ...
    pub gates: Option<usize>,
    /// A layout's gates after the first, each `x,y,z` in mm, joined by `; `; null with one
    /// gate.
    pub other_gates_mm: Option<String>,
    /// 3D distance from the gate to the centre of mass, mm.
    pub distance_mm: Option<f64>,
    /// R_gate, mm.
    pub gate_radius_mm: Option<f64>,
    /// Grid nodes.
    pub nodes: Option<usize>,
    /// Nodes whose disc lies on the part.
    pub circle_on_part: Option<usize>,
    /// Nodes passing every rule.
    pub qualifying: Option<usize>,
    /// The report's warnings joined by ` | `; null when the part failed or had none.
    pub warnings: Option<String>,
    /// Seconds to load and analyse the part, to 0.1 ms (varies from run to run).
    pub time_s: f64,
    /// Why the part failed, or null.
    pub error: Option<String>,
}

impl BatchRow {
    /// The row of one part: its report when it could be studied, and its failure (status and
    /// message) when it is not a success. A message that starts with the file's name has it
    /// taken off (the row has it in `file`).
    pub fn new(
        file: &str,
        units: Units,
        demold: &str,
        report: Option<&Report>,
        failure: Option<(Status, &str)>,
        time_s: f64,
    ) -> BatchRow {
        let gate = report.and_then(|r| r.gate.as_ref());
        let status = failure.map_or(Status::Ok, |(s, _)| s);
        let prefix = format!("{file}: ");
        BatchRow {
            file: file.to_string(),
            status,
            exit_code: status.exit_code(),
            units: units.to_string(),
            demold: demold.to_string(),
            triangles: report.map(|r| r.mesh.triangles),
            gate_x_mm: gate.map(|g| g.point[0]),
            gate_y_mm: gate.map(|g| g.point[1]),
            gate_z_mm: gate.map(|g| g.point[2]),
            gates: gate.map(|g| g.gates.as_ref().map_or(1, Vec::len)),
            other_gates_mm: gate
                .and_then(|g| g.gates.as_ref())
                .filter(|all| all.len() > 1)
                .map(|all| {
                    all[1..]
                        .iter()
                        .map(|g| format!("{},{},{}", g.point[0], g.point[1], g.point[2]))
                        .collect::<Vec<_>>()
                        .join("; ")
                }),
            distance_mm: gate.map(|g| g.distance_3d_mm),
            gate_radius_mm: report.map(|r| r.options.gate_radius_mm),
            nodes: report.map(|r| r.counts.nodes),
            circle_on_part: report.map(|r| r.counts.circle_on_part),
            qualifying: report.map(|r| r.counts.qualifying),
            warnings: report
                .filter(|r| !r.warnings.is_empty())
                .map(|r| r.warnings.join(" | ")),
            time_s: (time_s * 1e4).round() / 1e4,
            error: failure.map(|(_, m)| m.strip_prefix(&prefix).unwrap_or(m).to_string()),
        }
    }

    /// The row of a part that was studied: `ok`, or `no_gate` with the report's reason.
    pub fn studied(
        file: &str,
        units: Units,
        demold: &str,
        report: &Report,
        time_s: f64,
    ) -> BatchRow {
        let failure = match (&report.gate, &report.no_gate_reason) {
            (None, Some(reason)) => Some((Status::NoGate, reason.as_str())),
            _ => None,
        };
        BatchRow::new(file, units, demold, Some(report), failure, time_s)
    }

    /// The row as one line of JSON, without the line break.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("a row is plain data")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_and_exit_codes_agree() {
        for code in 0..=6 {
            assert_eq!(Status::from_exit_code(code).exit_code(), code);
        }
        let json = serde_json::to_string(&Status::NoGate).unwrap();
        assert_eq!(json, format!("\"{}\"", Status::NoGate.name()));
    }

    #[test]
    fn a_failed_row_has_no_numbers_and_loses_the_file_prefix() {
        let failure = Some((Status::InputError, "a.stl: empty file"));
        let row = BatchRow::new("a.stl", Units::Mm, "+z", None, failure, 0.123456);
        assert_eq!(row.exit_code, 3);
        assert_eq!(row.error.as_deref(), Some("empty file"));
        assert_eq!(row.time_s, 0.1235);
        assert!(row
            .to_json()
            .starts_with(r#"{"file":"a.stl","status":"input_error","exit_code":3,"units":"mm""#));
    }
}
