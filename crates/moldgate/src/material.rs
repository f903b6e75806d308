//! Thermoplastic materials and the gate radius of the paper's Eq. 7-8.

use serde::{Deserialize, Serialize};

use crate::error::OptionsError;

pub mod library;
pub mod name;

pub use library::{entry_of, find, library, typical_note, MaterialInfo, ParameterSources};

/// The rheological and thermal parameters of a thermoplastic, in the units of the paper's
/// Table 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Name, e.g. `PP`.
    #[serde(default)]
    pub name: String,
    /// Power-law index n of the melt (dimensionless).
    pub n: f64,
    /// Melt temperature T_melt in degrees Celsius.
    pub t_melt: f64,
    /// Mould wall temperature T_wall in degrees Celsius.
    pub t_wall: f64,
    /// Optimal shear rate gamma_opt in 1/s.
    pub gamma_opt: f64,
    /// Viscosity mu_opt at that shear rate, in Pa s.
    pub mu_opt: f64,
    /// Thermal conductivity k in W/(m C).
    pub k: f64,
    /// Largest flow-length-to-wall-thickness ratio L/t the melt fills reliably
    /// (dimensionless), or `None` when unknown. Not in the paper; the built-in values are
    /// design-guide figures, each with its source in [`MaterialInfo::sources`] (for the
    /// paper's three: PP 250, ABS 175, PC 125, inside the typical ranges PP 250-300,
    /// ABS 150-200, PC 100-150 of Plastwise's flow-path guide,
    /// <https://plastwise.com/en/tools/flow-path>).
    #[serde(default)]
    pub max_flow_ratio: Option<f64>,
}

/// The paper's Table 1 materials (cases 1, 3 and 5), the first three of [`library()`].
pub const BUILTIN: [&str; 3] = ["PP", "ABS", "PC"];

impl Material {
    /// A material of the built-in library (the paper's Table 1 and typical grades) by name
    /// or alias, ignoring case and separators, or `None`. [`find`] gives its sources too.
    pub fn builtin(name: &str) -> Option<Material> {
        find(name).map(|info| info.material.clone())
    }

    /// Checks that every parameter is positive and finite and that the melt is hotter than
    /// the wall, so that Eq. 7 has a real root.
    pub fn validate(&self) -> Result<(), OptionsError> {
        for (parameter, value) in [
            ("n", self.n),
            ("gamma_opt", self.gamma_opt),
            ("mu_opt", self.mu_opt),
            ("k", self.k),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(OptionsError::NonPositiveMaterial {
                    material: self.name.clone(),
                    parameter,
                    value,
                });
            }
        }
        for (parameter, value) in [("t_melt", self.t_melt), ("t_wall", self.t_wall)] {
            if !value.is_finite() {
                return Err(OptionsError::NonPositiveMaterial {
                    material: self.name.clone(),
                    parameter,
                    value,
                });
            }
        }
        if let Some(value) = self.max_flow_ratio {
            if !(value.is_finite() && value > 0.0) {
                return Err(OptionsError::NonPositiveMaterial {
                    material: self.name.clone(),
                    parameter: "max_flow_ratio",
                    value,
                });
            }
        }
        let out_of_range = |parameter, value, why| OptionsError::MaterialOutOfRange {
            material: self.name.clone(),
            parameter,
            value,
            why,
        };
        if self.n > 1.0 {
            return Err(out_of_range(
                "n",
                self.n,
                "the power-law index of a polymer melt is at most 1 (1 is Newtonian; melts are about 0.2 to 0.5); above 1 the melt would thicken as it shears",
            ));
        }
        if let Some(value) = self.max_flow_ratio.filter(|&v| v > MAX_FLOW_RATIO) {
            return Err(out_of_range(
                "max_flow_ratio",
                value,
                "the L/t limit is at most 1000 (design guides give 50 to 400)",
            ));
        }
        if self.t_melt <= self.t_wall {
            return Err(OptionsError::MeltNotAboveWall {
                material: self.name.clone(),
                t_melt: self.t_melt,
                t_wall: self.t_wall,
            });
        }
        let radius_mm = self.gate_radius_mm();
        if !(radius_mm.is_finite() && radius_mm > 0.0) {
            return Err(OptionsError::MaterialRadius {
                material: self.name.clone(),
                radius_mm,
            });
        }
        Ok(())
    }

    /// The mean melt-front velocity of Eq. 7, in m/s:
    /// v = sqrt(5 (T_melt - T_wall) k / (3 mu_opt)).
    pub fn melt_velocity_m_s(&self) -> f64 {
        (5.0 * (self.t_melt - self.t_wall) * self.k / (3.0 * self.mu_opt)).sqrt()
    }

    /// The gate radius of Eq. 8 in millimetres: R = (3 + 1/n) v / gamma_opt, which the
    /// formula gives in metres.
    pub fn gate_radius_mm(&self) -> f64 {
        1000.0 * (3.0 + 1.0 / self.n) * self.melt_velocity_m_s() / self.gamma_opt
    }
}

/// The largest L/t limit a material may give (`max_flow_ratio`): design guides give 50 to
/// 400, so a larger one is a mistake of units or digits.
pub const MAX_FLOW_RATIO: f64 = 1000.0;

/// A material of [`library_with`]: the built-in library's, or a user's.
#[derive(Debug, Clone)]
pub enum Listed {
    /// A built-in material, with its sources.
    BuiltIn(&'static MaterialInfo),
    /// A user's material (from a materials file).
    User(Material),
}

/// The built-in library in its order, each material replaced by a user's of the same name
/// or alias (ignoring case and separators, as `--material` looks them up), then the user's
/// other materials in their order: what `moldgate materials` lists.
pub fn library_with(mut user: Vec<Material>) -> Vec<Listed> {
    let mut out = Vec::new();
    for info in library() {
        let names = || std::iter::once(&info.material.name).chain(&info.aliases);
        match user
            .iter()
            .position(|m| names().any(|n| name::same(n, &m.name)))
        {
            Some(i) => out.push(Listed::User(user.remove(i))),
            None => out.push(Listed::BuiltIn(info)),
        }
    }
    out.extend(user.into_iter().map(Listed::User));
    out
}

/// A material as `moldgate materials --json`, the Python package's `materials()`, the
/// service's `GET /v1/materials` and the browser app list it: its parameters, what it is
/// and what each value rests on, where it comes from, and Eq. 7-8's melt velocity and gate
/// radius.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ListedMaterial {
    /// The material and its sources.
    #[serde(flatten)]
    pub info: MaterialInfo,
    /// `built-in`, or where a user's material comes from (its file).
    pub origin: String,
    /// Eq. 7, m/s.
    pub melt_velocity_m_s: f64,
    /// Eq. 8, mm.
    pub gate_radius_mm: f64,
}

/// The listing of every front end: [`library_with`] the user's materials, each described
/// by its `origin` (the file it was read from).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Listing {
    /// Bumped when a field changes meaning or goes away.
    pub schema_version: u32,
    /// The materials in [`library_with`]'s order.
    pub materials: Vec<ListedMaterial>,
}

/// The version of [`Listing`]'s fields.
pub const LISTING_SCHEMA_VERSION: u32 = 1;

impl Listing {
    /// The built-in library, each material replaced by a user's of the same name or alias,
    /// then the user's others ([`library_with`]); a user's material is described as coming
    /// from `origin` (a file's path).
    pub fn new(user: Vec<Material>, origin: &str) -> Listing {
        let listed = |info: MaterialInfo, origin: String| ListedMaterial {
            melt_velocity_m_s: info.material.melt_velocity_m_s(),
            gate_radius_mm: info.material.gate_radius_mm(),
            info,
            origin,
        };
        let from_user = |m: Material| {
            let said = format!("the user file {origin}");
            let info = MaterialInfo {
                aliases: Vec::new(),
                description: format!("from {origin}"),
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
            listed(info, origin.to_string())
        };
        let materials = library_with(user)
            .into_iter()
            .map(|m| match m {
                Listed::BuiltIn(info) => listed(info.clone(), "built-in".into()),
                Listed::User(m) => from_user(m),
            })
            .collect();
        Listing {
            schema_version: LISTING_SCHEMA_VERSION,
            materials,
        }
    }

    /// The built-in library alone.
    pub fn builtin() -> Listing {
        Listing::new(Vec::new(), "")
    }
}

/// The most materials one materials file may hold (its limit in bytes,
/// [`crate::files::MAX_MATERIALS_BYTES`], would allow some 10,000); a study looks a name up
/// among them, and every front end lists them.
pub const MAX_USER_MATERIALS: usize = 1000;

/// The materials of a TOML text (a user's materials file, at most
/// [`crate::files::MAX_MATERIALS_BYTES`]): each table a material named by its key, in the order of their names, each checked as [`Material::validate`] does. A
/// syntax error names its line.
pub fn materials_from_toml(text: &str) -> Result<Vec<Material>, String> {
    let limit = crate::files::MAX_MATERIALS_BYTES;
    if text.len() as u64 > limit {
        return Err(format!(
            "is over the limit of {} for a materials file ({})",
            crate::files::size_text(limit),
            crate::files::size_text(text.len() as u64)
        ));
    }
    let table: std::collections::BTreeMap<String, Material> =
        toml::from_str(text).map_err(|e| crate::files::toml_message(text, &e))?;
    if table.is_empty() {
        return Err("no materials in the file: each is a table [NAME] of n, t_melt, t_wall, gamma_opt, mu_opt and k".into());
    }
    if table.len() > MAX_USER_MATERIALS {
        return Err(format!(
            "{} materials, over the limit of {MAX_USER_MATERIALS} in one file",
            table.len()
        ));
    }
    let mut out: Vec<Material> = Vec::with_capacity(table.len());
    // Each name once case and separators are ignored, with the table that gave it.
    let mut seen: std::collections::HashMap<String, usize> = Default::default();
    for (key, mut m) in table {
        // A material is named by its table; a `name` inside it that says otherwise would be
        // ignored, and two tables whose names differ only in case or separators would be
        // one material to `--material`.
        if !m.name.is_empty() && m.name != key {
            return Err(format!(
                "material [{key}]: a material is named by its table, and its name = \"{}\" says otherwise; leave name out",
                m.name
            ));
        }
        match seen.entry(name::normalized(&key)) {
            std::collections::hash_map::Entry::Occupied(other) => {
                return Err(format!(
                    "materials [{}] and [{key}] are one name (case and separators are ignored): keep one",
                    out[*other.get()].name
                ));
            }
            std::collections::hash_map::Entry::Vacant(slot) => {
                slot.insert(out.len());
            }
        }
        // Two tables that name one built-in (by its name or its aliases) would each replace
        // it, and which one `--material` found would depend on the spelling.
        if let Some(info) = find(&key) {
            if let Some(other) = out
                .iter()
                .find(|m| find(&m.name).is_some_and(|o| std::ptr::eq(o, info)))
            {
                return Err(format!(
                    "materials [{}] and [{key}] both name the built-in {} (by its name or an alias): keep one",
                    other.name, info.material.name
                ));
            }
        }
        // A value out of range is placed at its line (or its table's, when the fault is
        // the parameters together).
        let place = |parameter: Option<&str>| {
            line_of(text, &key, parameter).map_or(String::new(), |l| format!("line {l}: "))
        };
        m.name = key.clone();
        m.validate().map_err(|e| {
            let parameter = match &e {
                OptionsError::NonPositiveMaterial { parameter, .. }
                | OptionsError::MaterialOutOfRange { parameter, .. } => Some(*parameter),
                OptionsError::MeltNotAboveWall { .. } => Some("t_wall"),
                _ => None,
            };
            format!("{}{e}", place(parameter))
        })?;
        // A radius no gate could have, refused here as a study would refuse it: a
        // material listed is one that can be studied.
        let r = m.gate_radius_mm();
        let (least, most) = (
            crate::study::MIN_GATE_RADIUS_MM,
            crate::study::MAX_GATE_RADIUS_MM,
        );
        if !(least..=most).contains(&r) {
            return Err(format!(
                "{}material '{key}': Eq. 8 gives a gate radius of {r:.3e} mm, {}; check its parameters' units (gamma_opt in 1/s, mu_opt in Pa s, k in W/(m C))",
                place(None),
                match r > most {
                    true => format!("more than {most} mm"),
                    false => format!("less than {least} mm"),
                }
            ));
        }
        out.push(m);
    }
    Ok(out)
}

/// The line (from 1) of `parameter` in the material `table` of a materials file's TOML
/// text, or of the table itself without a parameter or when it is not found: the line of
/// `[table]` (or `["table"]`), or of `table = { ... }` for an inline table.
fn line_of(text: &str, table: &str, parameter: Option<&str>) -> Option<usize> {
    let assigns = |line: &str, key: &str| {
        let line = line.trim_start();
        let rest = line
            .strip_prefix(key)
            .or_else(|| line.strip_prefix(&format!("\"{key}\"")));
        rest.is_some_and(|r| r.trim_start().starts_with('='))
    };
    let lines: Vec<&str> = text.lines().collect();
    let header = lines.iter().position(|l| {
        let l = l.trim();
        l == format!("[{table}]") || l == format!("[\"{table}\"]")
    });
    let Some(header) = header else {
        // An inline table: its own line holds its parameters.
        return lines.iter().position(|l| assigns(l, table)).map(|i| i + 1);
    };
    let found = parameter.and_then(|p| {
        lines[header + 1..]
            .iter()
            .take_while(|l| !l.trim_start().starts_with('['))
            .position(|l| assigns(l, p))
            .map(|i| header + 1 + i)
    });
    Some(found.unwrap_or(header) + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_materials_text_over_its_limit_is_refused_before_it_is_parsed_and_a_full_library_fits() {
        // The most materials a file may hold, each with every parameter and a comment, is a
        // fraction of the limit.
        let one = |i: usize| {
            format!("# Grade {i}, from its data sheet\n[Grade{i:04}]\nn = 0.35\nt_melt = 230.0\nt_wall = 40.0\ngamma_opt = 1000.0\nmu_opt = 150.0\nk = 0.2\nmax_flow_ratio = 250.0\n")
        };
        let library: String = (0..MAX_USER_MATERIALS).map(one).collect();
        assert!(library.len() as u64 * 3 < crate::files::MAX_MATERIALS_BYTES);
        assert_eq!(
            materials_from_toml(&library).unwrap().len(),
            MAX_USER_MATERIALS
        );
        // One byte over: refused by its length, whatever it holds (here an array whose parse
        // would take some 80 times its size).
        let mut big = String::from("a = [");
        while (big.len() as u64) < crate::files::MAX_MATERIALS_BYTES {
            big.push_str("1,");
        }
        big.push_str("1]\n");
        let e = materials_from_toml(&big).unwrap_err();
        assert!(
            e.starts_with("is over the limit of 1 MiB for a materials file (1."),
            "{e}"
        );
    }

    #[test]
    fn a_materials_file_s_faults_are_named_with_their_line_or_material() {
        let good = "[MyPA]\nn = 0.4\nt_melt = 280.0\nt_wall = 80.0\ngamma_opt = 1000.0\nmu_opt = 200.0\nk = 0.25\n";
        let m = materials_from_toml(good).unwrap();
        assert_eq!(m[0].name, "MyPA");
        let e = materials_from_toml("[MyPA]\nn = \n").unwrap_err();
        assert!(e.starts_with("line 2: "), "{e}");
        // A value of the wrong type in a person's words, not serde's name of the type.
        let e =
            materials_from_toml(&good.replace("t_melt = 280.0", "t_melt = \"hot\"")).unwrap_err();
        assert_eq!(e, "line 3: t_melt: got the text \"hot\", expected a number");
        // A material whose Eq. 8 radius no gate could have (gamma_opt in 1/min, say), at
        // its table's line.
        let e = materials_from_toml(&good.replace("gamma_opt = 1000.0", "gamma_opt = 1e-9"))
            .unwrap_err();
        assert!(
            e.starts_with("line 1: material 'MyPA': Eq. 8 gives a gate radius of ")
                && e.contains("more than 1000 mm; check its parameters' units"),
            "{e}"
        );
        let e = materials_from_toml(&good.replace("gamma_opt = 1000.0", "gamma_opt = 1e300"))
            .unwrap_err();
        assert!(e.contains("less than 0.001 mm"), "{e}");
        // A value out of range at its own line.
        let e = materials_from_toml(&good.replace("mu_opt = 200.0", "mu_opt = -9.88")).unwrap_err();
        assert!(e.starts_with("line 6: ") && e.contains("mu_opt"), "{e}");
        let e = materials_from_toml(&format!(
            "# mine\n\n{}",
            good.replace("t_wall = 80.0", "t_wall = 300.0")
        ))
        .unwrap_err();
        assert!(e.starts_with("line 6: "), "{e}");
        let e = materials_from_toml("MyPA = { n = -1, t_melt = 280.0, t_wall = 80.0, gamma_opt = 1000.0, mu_opt = 200.0, k = 0.25 }\n").unwrap_err();
        assert!(e.starts_with("line 1: "), "{e}");
        // A whole number beyond 64 bits, without serde's name of its type.
        let e =
            materials_from_toml(&good.replace("k = 0.25", "k = 99999999999999999999")).unwrap_err();
        assert_eq!(
            e,
            "line 7: k: got the number 99999999999999999999, expected a number"
        );
        // A value missing from its key's line, at the key's line.
        for text in [
            good.replace("k = 0.25", "k =\n0.25"),
            good.replace("k = 0.25", "k = # soon"),
            good.replace("k = 0.25", "k =\n\n# soon\n0.25"),
        ] {
            let e = materials_from_toml(&text).unwrap_err();
            assert_eq!(
                e,
                "line 7: k: no value after `=` (a value goes on its key's own line)"
            );
        }
        // What serde calls a table, named as the TOML that made it.
        for (text, says) in [
            (
                good.replace("k = 0.25", "k.value = 0.25"),
                "line 7: k: got a table, expected a number (a dotted key, k.…, makes a table)",
            ),
            (
                good.replace("k = 0.25", "k = 1979-05-27"),
                "line 7: k: got a date, expected a number",
            ),
            (
                good.replace("[MyPA]", "[[MyPA]]"),
                "line 1: MyPA: got a list of tables ([[MyPA]]), expected one table ([MyPA])",
            ),
            (
                good.replace("k = 0.25", "k = 0.25\nk = 0.3"),
                "line 8: k: duplicate key",
            ),
            (
                good.replace("k = 0.25\n", ""),
                "line 1: MyPA: missing field `k`",
            ),
        ] {
            let e = materials_from_toml(&text).unwrap_err();
            assert!(e.starts_with(says), "{e}");
        }
        // Text inside a string that ends in `=` is not a key; a quoted key with `=` in it
        // is not cut at its `=`.
        for (text, not) in [
            (good.replace("k = 0.25", "k = \"b =\nn2 = 1"), "line 7: b:"),
            (
                good.replace("k = 0.25", "k = 'lit =\nn2 = 1"),
                "line 7: lit:",
            ),
            (good.replace("k = 0.25", "\"t =melt\" ="), "line 7: melt:"),
        ] {
            let e = materials_from_toml(&text).unwrap_err();
            assert!(!e.starts_with(not), "{e}");
        }
        // A string with no `=` in it is still named by its key.
        let e = materials_from_toml(&good.replace("k = 0.25", "k = \"x\"")).unwrap_err();
        assert!(e.starts_with("line 7: k: got the text"), "{e}");
        // ... in an inline table too.
        let e = materials_from_toml("MyPA = { n = 0.4, k = \"x\" }\n").unwrap_err();
        assert!(e.starts_with("line 1: k: got the text"), "{e}");
        // An empty file, and one of more materials than the limit, before any is checked.
        let e = materials_from_toml("# nothing yet\n").unwrap_err();
        assert!(e.starts_with("no materials in the file"), "{e}");
        let many: String = (0..=MAX_USER_MATERIALS)
            .map(|i| good.replace("[MyPA]", &format!("[M{i}]")))
            .collect();
        let e = materials_from_toml(&many).unwrap_err();
        assert_eq!(e, "1001 materials, over the limit of 1000 in one file");
        let at_limit: String = (0..MAX_USER_MATERIALS)
            .map(|i| good.replace("[MyPA]", &format!("[M{i}]")))
            .collect();
        assert_eq!(
            materials_from_toml(&at_limit).unwrap().len(),
            MAX_USER_MATERIALS
        );
        // Beyond any polymer melt: a shear-thickening n, an L/t limit of a mistaken digit.
        let e = materials_from_toml(&good.replace("n = 0.4", "n = 5")).unwrap_err();
        assert!(
            e.starts_with("line 2: material 'MyPA': n = 5.0 is out of range: the power-law index of a polymer melt is at most 1"),
            "{e}"
        );
        assert!(materials_from_toml(&good.replace("n = 0.4", "n = 1")).is_ok());
        let e = materials_from_toml(&format!("{good}max_flow_ratio = 1e308\n")).unwrap_err();
        assert!(
            e.starts_with("line 8: material 'MyPA': max_flow_ratio = 1e308 is out of range: the L/t limit is at most 1000"),
            "{e}"
        );
        assert!(materials_from_toml(&format!("{good}max_flow_ratio = 1000\n")).is_ok());
        // Two tables naming one built-in, by its name and an alias, or by two aliases.
        let pe = |name: &str| good.replace("[MyPA]", &format!("[{name}]"));
        for (a, b) in [("hdpe", "PE-HD"), ("hdpe", "pe_hd")] {
            let e = materials_from_toml(&format!("{}{}", pe(a), pe(b))).unwrap_err();
            assert!(
                e.ends_with("both name the built-in PE-HD (by its name or an alias): keep one"),
                "{e}"
            );
        }
        // One table replacing a built-in is fine.
        assert!(materials_from_toml(&pe("hdpe")).is_ok());
        // Each parameter in range, but Eq. 7-8 overflow together.
        let huge = good
            .replace("k = 0.25", "k = 1e308")
            .replace("mu_opt = 200.0", "mu_opt = 1e-308");
        let e = materials_from_toml(&huge).unwrap_err();
        assert!(
            e.starts_with("line 1: material 'MyPA': its parameters give an infinite gate radius"),
            "{e}"
        );
        // A huge value is written short, not in 309 digits.
        let e = materials_from_toml(&good.replace("t_wall = 80.0", "t_wall = 1e308")).unwrap_err();
        assert!(e.contains("(1e308 C)") && e.len() < 200, "{e}");
        // Two tables that `--material` cannot tell apart, and a name that is not the table's.
        let twice = format!("{good}{}", good.replace("[MyPA]", "[my-pa]"));
        let e = materials_from_toml(&twice).unwrap_err();
        assert_eq!(
            e,
            "materials [MyPA] and [my-pa] are one name (case and separators are ignored): keep one"
        );
        let named = good.replace("n = 0.4", "name = \"Other\"\nn = 0.4");
        let e = materials_from_toml(&named).unwrap_err();
        assert!(
            e.starts_with("material [MyPA]: a material is named by its table"),
            "{e}"
        );
        let same = good.replace("n = 0.4", "name = \"MyPA\"\nn = 0.4");
        assert_eq!(materials_from_toml(&same).unwrap()[0].name, "MyPA");
        // Parameters outside a table, in a person's words.
        let e = materials_from_toml("n = 0.3\n").unwrap_err();
        assert!(
            e.contains("expected a table of a material's parameters"),
            "{e}"
        );
    }

    #[test]
    fn table_1_gate_radii() {
        // The paper's Table 1 prints 1.4, 1.9 and 1.5 mm; the formula gives these unrounded.
        for (name, printed, exact) in [
            ("PP", 1.4, 1.425_445_651),
            ("ABS", 1.9, 1.915_4),
            ("PC", 1.5, 1.461_5),
        ] {
            let r = Material::builtin(name).unwrap().gate_radius_mm();
            assert!((r - exact).abs() < 1e-4, "{name}: {r}");
            assert_eq!((r * 10.0).round() / 10.0, printed, "{name}: {r}");
        }
    }

    #[test]
    fn abs_case_4_viscosity_also_rounds_to_table_1() {
        let mut abs = Material::builtin("abs").unwrap();
        abs.mu_opt = 30.96;
        assert_eq!((abs.gate_radius_mm() * 10.0).round(), 19.0);
    }

    #[test]
    fn invalid_parameters_are_refused() {
        let mut m = Material::builtin("PP").unwrap();
        m.mu_opt = 0.0;
        assert!(matches!(
            m.validate(),
            Err(OptionsError::NonPositiveMaterial {
                parameter: "mu_opt",
                ..
            })
        ));
        let mut m = Material::builtin("PP").unwrap();
        m.t_wall = 240.0;
        assert!(matches!(
            m.validate(),
            Err(OptionsError::MeltNotAboveWall { .. })
        ));
        let mut m = Material::builtin("PP").unwrap();
        m.n = f64::NAN;
        assert!(m.validate().is_err());
        assert!(Material::builtin("PA77").is_none());
    }
}
