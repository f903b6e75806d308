//! Reading the command line's TOML files (user materials, batch manifests).

use std::path::Path;

use crate::Failure;

/// Reads and parses a TOML file: an unreadable file is an input error (exit 3), a syntax
/// error or a bad value an error of the command line (exit 2) naming the line.
pub fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, Failure> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Failure::input(format!("{}: cannot read: {e}", path.display())))?;
    toml::from_str(&text).map_err(|e| {
        let place = e
            .span()
            .map(|s| format!("line {}: ", 1 + text[..s.start].matches('\n').count()))
            .unwrap_or_default();
        Failure::usage(format!(
            "{}: {place}{}",
            path.display(),
            e.message().trim_end_matches('.')
        ))
    })
}
