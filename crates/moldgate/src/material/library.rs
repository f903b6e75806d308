//! The built-in material library: `data/materials.toml`, compiled into the crate, with
//! where each value comes from.
//!
//! The paper's three materials (PP, ABS, PC) are exactly its Table 1; the others hold values
//! typical of their family, each with its source. For those, gamma_opt is one tenth of the
//! family's maximum gate shear rate and mu_opt the viscosity at gamma_opt, extrapolated
//! along the power law from a typical viscosity at 1000 1/s (docs/materials.md).

use std::collections::BTreeMap;
use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use super::{name, Material};

/// The library's data, in the format of `--materials-file` plus descriptions and sources.
const DATA: &str = include_str!("../../data/materials.toml");

/// Where each parameter of a material comes from, one sentence each.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterSources {
    /// Source of the power-law index n.
    pub n: String,
    /// Source of the melt temperature.
    pub t_melt: String,
    /// Source of the mould wall temperature.
    pub t_wall: String,
    /// Source of the optimal shear rate.
    pub gamma_opt: String,
    /// Source of the viscosity at that shear rate.
    pub mu_opt: String,
    /// Source of the melt's thermal conductivity.
    pub k: String,
    /// Source of the flow-length-to-thickness limit L/t.
    pub max_flow_ratio: String,
}

/// A material of the library: the parameters of Eq. 7-8, what it is, and what each value
/// rests on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MaterialInfo {
    /// The parameters, as `Material::builtin` gives them.
    #[serde(flatten)]
    pub material: Material,
    /// Other names it answers to (`HDPE` for `PE-HD`); matched like the name, ignoring case
    /// and separators.
    pub aliases: Vec<String>,
    /// What the material is, e.g. "polyamide 66 with 30 % glass fibre".
    pub description: String,
    /// Its family, e.g. `polyamide`.
    pub family: String,
    /// Whether the values are typical of the family (true) rather than those of one
    /// documented case (the paper's Table 1).
    pub typical: bool,
    /// The family's maximum gate shear rate in 1/s that gamma_opt is derived from, if it is.
    pub max_shear_rate: Option<f64>,
    /// The typical viscosity at T_melt and 1000 1/s in Pa s that mu_opt is extrapolated
    /// from, if it is.
    pub mu_1000: Option<f64>,
    /// Where each value comes from.
    pub sources: ParameterSources,
}

/// The library's materials, in the order of the data file: the paper's three first.
pub fn library() -> &'static [MaterialInfo] {
    static LIBRARY: OnceLock<Vec<MaterialInfo>> = OnceLock::new();
    // The data is part of the crate, and `the_built_in_data_parses` checks it: a failure
    // here is a defect of the build, never of the user's input.
    LIBRARY.get_or_init(|| parse(DATA).expect("the built-in material data is valid"))
}

/// The library's material of this name or alias, ignoring case and separators
/// (`pa66 gf30` finds `PA66-GF30`), or `None`.
pub fn find(query: &str) -> Option<&'static MaterialInfo> {
    let query = name::normalized(query);
    library().iter().find(|info| {
        std::iter::once(&info.material.name)
            .chain(&info.aliases)
            .any(|n| name::normalized(n) == query)
    })
}

/// The library's entry that `m` is unchanged (its name and every parameter), or `None` for
/// a user's material, one given in full, or a built-in with overrides: what a report's
/// material rests on.
pub fn entry_of(m: &Material) -> Option<&'static MaterialInfo> {
    find(&m.name).filter(|info| info.material == *m)
}

/// The note a report gives beside a material of typical family values (a starting point,
/// not a grade's data), or `None` for any other material.
pub fn typical_note(m: &Material) -> Option<String> {
    entry_of(m).filter(|info| info.typical).map(|info| {
        format!(
            "from typical {} family values (sources: moldgate materials --json)",
            info.family
        )
    })
}

/// The data file's layout.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    sources: BTreeMap<String, String>,
    material: Vec<Entry>,
}

/// One `[[material]]` of the data file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    name: String,
    #[serde(default)]
    aliases: Vec<String>,
    description: String,
    family: String,
    typical: bool,
    n: f64,
    t_melt: f64,
    t_wall: f64,
    gamma_opt: f64,
    mu_opt: f64,
    k: f64,
    max_flow_ratio: f64,
    max_shear_rate: Option<f64>,
    mu_1000: Option<f64>,
    source: EntrySources,
}

/// Each value's source as `key details`: a key of `[sources]`, then the figures read there.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EntrySources {
    n: String,
    t_melt: String,
    t_wall: String,
    gamma_opt: String,
    mu_opt: String,
    k: String,
    max_flow_ratio: String,
}

/// Reads the library's data, naming the material and the field of any defect.
fn parse(text: &str) -> Result<Vec<MaterialInfo>, String> {
    let file: File = toml::from_str(text).map_err(|e| e.to_string())?;
    let resolve = |material: &str, field: &str, given: &str| -> Result<String, String> {
        let (key, details) = given.split_once(' ').unwrap_or((given, ""));
        let text = file.sources.get(key).ok_or_else(|| {
            format!("material '{material}': {field} cites unknown source '{key}'")
        })?;
        Ok(if details.is_empty() {
            text.clone()
        } else {
            format!("{text}: {details}")
        })
    };
    let mut out = Vec::with_capacity(file.material.len());
    for e in &file.material {
        let s = &e.source;
        let sources = ParameterSources {
            n: resolve(&e.name, "n", &s.n)?,
            t_melt: resolve(&e.name, "t_melt", &s.t_melt)?,
            t_wall: resolve(&e.name, "t_wall", &s.t_wall)?,
            gamma_opt: resolve(&e.name, "gamma_opt", &s.gamma_opt)?,
            mu_opt: resolve(&e.name, "mu_opt", &s.mu_opt)?,
            k: resolve(&e.name, "k", &s.k)?,
            max_flow_ratio: resolve(&e.name, "max_flow_ratio", &s.max_flow_ratio)?,
        };
        let material = Material {
            name: e.name.clone(),
            n: e.n,
            t_melt: e.t_melt,
            t_wall: e.t_wall,
            gamma_opt: e.gamma_opt,
            mu_opt: e.mu_opt,
            k: e.k,
            max_flow_ratio: Some(e.max_flow_ratio),
        };
        material.validate().map_err(|err| err.to_string())?;
        out.push(MaterialInfo {
            material,
            aliases: e.aliases.clone(),
            description: e.description.clone(),
            family: e.family.clone(),
            typical: e.typical,
            max_shear_rate: e.max_shear_rate,
            mu_1000: e.mu_1000,
            sources,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_data_parses() {
        let all = parse(DATA).unwrap();
        assert!(all.len() >= 20, "{} materials", all.len());
        let names: Vec<&str> = all.iter().map(|i| i.material.name.as_str()).collect();
        assert_eq!(names[..3], ["PP", "ABS", "PC"]);
        for wanted in [
            "PP-H",
            "PP-C",
            "PE-HD",
            "PE-LD",
            "PS",
            "HIPS",
            "SAN",
            "ASA",
            "PC/ABS",
            "PMMA",
            "PA6",
            "PA66",
            "PA66-GF30",
            "POM",
            "PBT",
            "PET",
            "TPU",
            "PPS-GF40",
            "PEEK",
        ] {
            assert!(names.contains(&wanted), "{wanted} missing");
        }
    }

    /// A polymer's full name finds its grade, as the abbreviation does: "polypropylene"
    /// once suggested PP-C, POM and PP-H, and "polycarbonate" POM first.
    #[test]
    fn full_names_find_their_grades() {
        for (full, grade) in [
            ("polypropylene", "PP"),
            ("Polycarbonate", "PC"),
            ("acrylonitrile butadiene styrene", "ABS"),
            ("polyoxymethylene", "POM"),
            ("polyamide 66", "PA66"),
            ("high-density polyethylene", "PE-HD"),
        ] {
            let found = find(full).unwrap_or_else(|| panic!("{full}"));
            assert_eq!(found.material.name, grade, "{full}");
        }
    }

    #[test]
    fn names_and_aliases_are_unambiguous() {
        let mut seen = BTreeMap::new();
        for info in library() {
            for n in std::iter::once(&info.material.name).chain(&info.aliases) {
                if let Some(other) = seen.insert(name::normalized(n), &info.material.name) {
                    assert_eq!(other, &info.material.name, "'{n}' names two materials");
                }
            }
        }
    }

    /// Every material: Eq. 8 gives a gate a designer could cut, the melt is hotter than the
    /// wall, every value is positive and finite and has a source.
    #[test]
    fn every_material_is_sane() {
        for info in library() {
            let m = &info.material;
            m.validate().unwrap();
            let r = m.gate_radius_mm();
            assert!((0.3..=4.0).contains(&r), "{}: R = {r} mm", m.name);
            assert!(m.t_melt > m.t_wall, "{}", m.name);
            for v in [m.n, m.t_melt, m.t_wall, m.gamma_opt, m.mu_opt, m.k] {
                assert!(v.is_finite() && v > 0.0, "{}: {v}", m.name);
            }
            assert!(m.n < 1.0, "{}: n = {} is not shear thinning", m.name, m.n);
            let s = &info.sources;
            for source in [
                &s.n,
                &s.t_melt,
                &s.t_wall,
                &s.gamma_opt,
                &s.mu_opt,
                &s.k,
                &s.max_flow_ratio,
            ] {
                assert!(source.len() > 10, "{}: source '{source}'", m.name);
            }
            assert!(!info.description.is_empty() && !info.family.is_empty());
            // A typical material says so in its sources; the paper's cite the paper.
            if info.typical {
                assert!(!s.n.contains("the paper"), "{}", m.name);
            } else {
                assert!(s.mu_opt.starts_with("the paper, Table 1"), "{}", m.name);
            }
        }
    }

    /// The derived values follow from their inputs: gamma_opt is a tenth of the shear-rate
    /// limit, mu_opt the power-law viscosity at gamma_opt (stored to 0.01 Pa s).
    #[test]
    fn derived_values_follow_from_their_inputs() {
        for info in library().iter().filter(|i| i.typical) {
            let m = &info.material;
            let limit = info
                .max_shear_rate
                .expect("typical gamma_opt has its limit");
            assert_eq!(m.gamma_opt, limit / 10.0, "{}", m.name);
            let mu_1000 = info.mu_1000.expect("typical mu_opt has its mu_1000");
            let mu = mu_1000 * (m.gamma_opt / 1000.0).powf(m.n - 1.0);
            assert!((m.mu_opt - mu).abs() <= 0.005 + 1e-9, "{}: {mu}", m.name);
            assert!(info.sources.mu_opt.contains(&format!("{mu_1000} Pa s")));
            assert!(info.sources.gamma_opt.contains(&format!(
                "{},{:03} 1/s",
                limit as u64 / 1000,
                limit as u64 % 1000
            )));
        }
    }

    /// The L/t limits lie in the published ranges for their families.
    #[test]
    fn flow_ratios_are_in_published_ranges() {
        for info in library() {
            let m = &info.material;
            let ratio = m.max_flow_ratio.unwrap();
            let base = name::normalized(&m.name);
            let range = match base.as_str() {
                _ if base.starts_with("PE")
                    && !base.starts_with("PEEK")
                    && !base.starts_with("PET") =>
                {
                    200.0..=300.0
                }
                _ if base.starts_with("PP") && !base.starts_with("PPS") => 200.0..=300.0,
                "PC" => 100.0..=150.0,
                _ if base.starts_with("PA") => 150.0..=250.0,
                "POM" => 150.0..=250.0,
                "PEEK" => 100.0..=150.0,
                _ => 100.0..=300.0,
            };
            assert!(range.contains(&ratio), "{}: L/t {ratio}", m.name);
        }
    }

    #[test]
    fn only_an_unchanged_typical_built_in_has_the_note() {
        let grade = find("PA66-GF30").unwrap().material.clone();
        assert_eq!(
            typical_note(&grade).as_deref(),
            Some("from typical polyamide family values (sources: moldgate materials --json)")
        );
        // The paper's own values, a user's material of the same name, an override: no note.
        assert_eq!(typical_note(&find("PP").unwrap().material), None);
        assert!(entry_of(&find("PP").unwrap().material).is_some());
        let mine = Material {
            mu_opt: grade.mu_opt * 2.0,
            ..grade.clone()
        };
        assert_eq!(typical_note(&mine), None);
        let renamed = Material {
            name: "PA66-GF30 (modified)".into(),
            ..grade
        };
        assert_eq!(entry_of(&renamed), None);
    }

    #[test]
    fn names_match_without_case_or_separators() {
        for spelling in ["pa66-gf30", "PA66 GF30", "pa66gf30"] {
            assert_eq!(find(spelling).unwrap().material.name, "PA66-GF30");
        }
        assert_eq!(find("hdpe").unwrap().material.name, "PE-HD");
        assert_eq!(find("pc abs").unwrap().material.name, "PC/ABS");
        assert_eq!(find("Acetal").unwrap().material.name, "POM");
        assert!(find("PA77").is_none());
    }

    #[test]
    fn bad_data_names_the_material_and_field() {
        let good = "[sources]\nx = \"a source\"\n[[material]]\nname = \"M\"\ndescription = \"d\"\n\
                    family = \"f\"\ntypical = true\nn = 0.3\nt_melt = 200.0\nt_wall = 40.0\n\
                    gamma_opt = 1000.0\nmu_opt = 100.0\nk = 0.2\nmax_flow_ratio = 200.0\n\
                    source = { n = \"x\", t_melt = \"x\", t_wall = \"x\", gamma_opt = \"x\", \
                    mu_opt = \"x\", k = \"x\", max_flow_ratio = \"x 1-2\" }\n";
        let m = &parse(good).unwrap()[0];
        assert_eq!(m.sources.max_flow_ratio, "a source: 1-2");
        let err = parse(&good.replace("k = \"x\"", "k = \"y\"")).unwrap_err();
        assert!(
            err.contains("'M'") && err.contains("k cites unknown source 'y'"),
            "{err}"
        );
        let err = parse(&good.replace("t_wall = 40.0", "t_wall = 240.0")).unwrap_err();
        assert!(err.contains("must be above"), "{err}");
    }
}
