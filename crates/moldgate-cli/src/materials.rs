//! The `materials` command and the `--material` look-up: the built-in library and a
//! user's `--materials-file`, where a user material wins over a built-in of the same name.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use moldgate::material::{self, name, MaterialInfo, ParameterSources};
use moldgate::Material;

use crate::Failure;

/// How many names an unknown `--material` is answered with.
const SUGGESTIONS: usize = 3;

/// The material called `query` (case and separators ignored): the user's first, then the
/// library's; an unknown name fails with the closest known names.
pub fn lookup(query: &str, user: &BTreeMap<String, Material>) -> Result<Material, Failure> {
    if let Some(m) = user.values().find(|m| name::same(&m.name, query)) {
        return Ok(m.clone());
    }
    if let Some(info) = material::find(query) {
        return Ok(info.material.clone());
    }
    // Aliases count for closeness, but the answer is the material's own name.
    let known =
        user.keys()
            .map(|k| (k.as_str(), k.as_str()))
            .chain(material::library().iter().flat_map(|i| {
                std::iter::once(&i.material.name)
                    .chain(&i.aliases)
                    .map(|spelling| (spelling.as_str(), i.material.name.as_str()))
            }));
    let closest = name::closest_of(query, known, SUGGESTIONS);
    Err(Failure::usage(format!(
        "unknown material '{query}'; closest: {} (`moldgate materials` lists them all)",
        closest.join(", ")
    )))
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
fn listing(user: BTreeMap<String, Material>, file: Option<&Path>) -> Vec<Listed> {
    let listed = |info: MaterialInfo, origin: String| Listed {
        melt_velocity_m_s: info.material.melt_velocity_m_s(),
        gate_radius_mm: info.material.gate_radius_mm(),
        info,
        origin,
    };
    let mut user: Vec<Material> = user.into_values().collect();
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
    let mut out = Vec::new();
    for info in material::library() {
        let names = || std::iter::once(&info.material.name).chain(&info.aliases);
        match user
            .iter()
            .position(|m| names().any(|n| name::same(n, &m.name)))
        {
            Some(i) => out.push(from_user(user.remove(i))),
            None => out.push(listed(info.clone(), "built-in".into())),
        }
    }
    out.extend(user.into_iter().map(from_user));
    out
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

/// `moldgate materials`: the table, or with `json` the full data with every source.
pub fn run(
    user: BTreeMap<String, Material>,
    file: Option<&Path>,
    json: bool,
) -> Result<String, Failure> {
    let rows = listing(user, file);
    Ok(if json {
        let listing = Listing {
            schema_version: 1,
            materials: rows,
        };
        serde_json::to_string_pretty(&listing).expect("a listing serialises") + "\n"
    } else {
        table(&rows)
    })
}
