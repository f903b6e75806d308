//! `moldgate materials` (the built-in library with a user's `--materials-file`, where a user
//! material wins over a built-in of the same name), and reading that file. The `--material`
//! look-up itself is the library's (`StudyOptions::validate_with`).

use std::path::Path;

use serde::Serialize;

use moldgate::material::{self, MaterialInfo, ParameterSources};
use moldgate::Material;

use crate::args::MaterialsArgs;
use crate::output::print_stdout;
use crate::toml_file::read_toml_text;
use crate::Failure;

/// Reads a TOML file of user materials, each named by its table, in the order of their
/// names.
pub fn read_materials(path: &Path) -> Result<Vec<Material>, Failure> {
    let text = read_toml_text(path)?;
    material::materials_from_toml(&text)
        .map_err(|e| Failure::usage(format!("{}: {e}", path.display())))
}

/// A row of the listing: a library material, or a user one described by its file.
#[derive(Serialize)]
struct Listed {
    /// The material and its sources.
    #[serde(flatten)]
    info: MaterialInfo,
    /// `built-in` or the user file's path.
    origin: String,
    /// Eq. 7, m/s.
    melt_velocity_m_s: f64,
    /// Eq. 8, mm.
    gate_radius_mm: f64,
}

/// `moldgate materials --json`.
#[derive(Serialize)]
struct Listing {
    /// Bumped when a field changes meaning or goes away.
    schema_version: u32,
    materials: Vec<Listed>,
}

/// The library, with each user material in place of a built-in of the same name or after
/// them.
fn listing(user: Vec<Material>, file: Option<&Path>) -> Vec<Listed> {
    let listed = |info: MaterialInfo, origin: String| Listed {
        melt_velocity_m_s: info.material.melt_velocity_m_s(),
        gate_radius_mm: info.material.gate_radius_mm(),
        info,
        origin,
    };
    let from_user = |m: Material| {
        let path = file.map(|p| p.display().to_string()).unwrap_or_default();
        let said = format!("the user file {path}");
        let info = MaterialInfo {
            aliases: Vec::new(),
            description: format!("from {path}"),
            family: "user".into(),
            typical: false,
            max_shear_rate: None,
            mu_1000: None,
            sources: ParameterSources {
                n: said.clone(),
                t_melt: said.clone(),
                t_wall: said.clone(),
                gamma_opt: said.clone(),
                mu_opt: said.clone(),
                k: said.clone(),
                max_flow_ratio: said,
            },
            material: m,
        };
        listed(info, path)
    };
    material::library_with(user)
        .into_iter()
        .map(|m| match m {
            material::Listed::BuiltIn(info) => listed(info.clone(), "built-in".into()),
            material::Listed::User(m) => from_user(m),
        })
        .collect()
}

/// The listing as a table: name, Eq. 8's radius, L/t, what the values rest on, family and
/// description.
fn table(rows: &[Listed]) -> String {
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
    let rows = listing(user, a.materials_file.as_deref());
    print_stdout(&if a.json {
        let listing = Listing {
            schema_version: 1,
            materials: rows,
        };
        serde_json::to_string_pretty(&listing).expect("a listing serialises") + "\n"
    } else {
        table(&rows)
    })
}
