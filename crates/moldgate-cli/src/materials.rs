//! `moldgate materials` (the built-in library with a user's `--materials-file`, where a user
//! material wins over a built-in of the same name), and reading that file. The `--material`
//! look-up itself is the library's (`StudyOptions::validate_with`).

use std::path::Path;

use moldgate::material::{self, ListedMaterial, Listing};
use moldgate::Material;

use crate::args::MaterialsArgs;
use crate::output::print_stdout;
use crate::toml_file::read_toml_text;
use crate::Failure;

/// Reads a TOML file of user materials, each named by its table, in the order of their
/// names.
pub fn read_materials(path: &Path) -> Result<Vec<Material>, Failure> {
    let text = read_toml_text(path, moldgate::files::MAX_MATERIALS_BYTES)?;
    material::materials_from_toml(&text)
        .map_err(|e| Failure::usage(format!("{}: {e}", moldgate::files::shown(&path))))
}

/// The listing as a table: name, Eq. 8's radius, L/t, what the values rest on, family and
/// description.
fn table(rows: &[ListedMaterial]) -> String {
    let mut out = format!(
        "{:<10} {:>9} {:>5}  {:<8} {:<16} {}\n",
        "material", "R_gate_mm", "L/t", "basis", "family", "description"
    );
    for r in rows {
        let basis = match (&r.info.family[..], r.info.typical) {
            ("user", _) => "user",
            (_, true) => "typical",
            (_, false) => "paper",
        };
        let ratio = r
            .info
            .material
            .max_flow_ratio
            .map_or("-".to_string(), |x| format!("{x:.0}"));
        out += &format!(
            "{:<10} {:>9.4} {:>5}  {:<8} {:<16} {}\n",
            r.info.material.name, r.gate_radius_mm, ratio, basis, r.info.family, r.info.description
        );
    }
    out
}

/// `moldgate materials`: the table, or with `--json` the full data with every source; the
/// materials of `--materials-file` in place of built-ins of the same name or after them.
pub fn run_materials(a: MaterialsArgs) -> Result<(), Failure> {
    let user = match &a.materials_file {
        Some(p) => read_materials(p)?,
        None => Vec::new(),
    };
    let origin = a
        .materials_file
        .as_deref()
        .map(|p| moldgate::files::shown(&p))
        .unwrap_or_default();
    let listing = Listing::new(user, &origin);
    print_stdout(&if a.json {
        serde_json::to_string_pretty(&listing).expect("a listing serialises") + "\n"
    } else {
        table(&listing.materials)
    })
}
