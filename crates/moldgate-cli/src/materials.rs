//! `moldgate materials`, and the TOML file of user materials (`--materials-file`).

use std::collections::BTreeMap;
use std::path::Path;

use moldgate::Material;

use crate::args::MaterialsArgs;
use crate::output::print_stdout;
use crate::toml_file::read_toml;
use crate::Failure;

/// Reads a TOML file of user materials, each named by its table.
pub fn read_materials(path: &Path) -> Result<Vec<Material>, Failure> {
    let table: BTreeMap<String, Material> = read_toml(path)?;
    let mut out = Vec::with_capacity(table.len());
    for (name, mut m) in table {
        m.name = name;
        m.validate()
            .map_err(|e| Failure::usage(format!("{}: {e}", path.display())))?;
        out.push(m);
    }
    Ok(out)
}

/// Lists the built-in materials, and those of `--materials-file`, with Eq. 7-8.
pub fn run_materials(a: MaterialsArgs) -> Result<(), Failure> {
    let mut all: Vec<Material> = moldgate::material::BUILTIN
        .iter()
        .filter_map(|n| Material::builtin(n))
        .collect();
    if let Some(p) = &a.materials_file {
        all.extend(read_materials(p)?);
    }
    let mut out = format!(
        "{:<10} {:>7} {:>7} {:>7} {:>9} {:>8} {:>6} {:>10} {:>10}\n",
        "material", "n", "Tmelt_C", "Twall_C", "gamma_1/s", "mu_Pa.s", "k", "v_m/s", "R_gate_mm"
    );
    for m in all {
        out += &format!(
            "{:<10} {:>7} {:>7} {:>7} {:>9} {:>8} {:>6} {:>10.5} {:>10.4}\n",
            m.name,
            m.n,
            m.t_melt,
            m.t_wall,
            m.gamma_opt,
            m.mu_opt,
            m.k,
            m.melt_velocity_m_s(),
            m.gate_radius_mm()
        );
    }
    print_stdout(&out)
}
