//! Reading the command line's TOML files (user materials, batch manifests).

use std::path::Path;

use moldgate::files::{toml_message, TextError};

use crate::Failure;

/// The text of a TOML file of at most `limit` bytes (`moldgate::files::MAX_TOML_BYTES` for
/// a manifest, `MAX_MATERIALS_BYTES` for materials). A file that cannot be read (missing,
/// not a regular file, over the limit, or one that could take more memory to parse than the
/// process may use) is an input error (exit code 3); text that
/// is not UTF-8 is an error of the command line's file (exit code 2), naming the line and
/// byte. Every message names the file.
pub fn read_toml_text(path: &Path, limit: u64) -> Result<String, Failure> {
    crate::output::register_input(path);
    moldgate::files::read_toml_text(path, limit).map_err(|e| {
        let message = format!("{}: {e}", moldgate::files::shown(&path));
        match e {
            TextError::Unreadable(_) => Failure::input(message),
            TextError::NotUtf8 { .. } => Failure::usage(message),
        }
    })
}

/// Reads and parses a TOML file ([`read_toml_text`]), and gives its text too (for the lines
/// of values read as `toml::Spanned`); a syntax error or a bad value is an error of the
/// command line (exit code 2) naming the line.
pub fn read_toml<T: serde::de::DeserializeOwned>(
    path: &Path,
    limit: u64,
) -> Result<(T, String), Failure> {
    let text = read_toml_text(path, limit)?;
    let value = toml::from_str(&text).map_err(|e| {
        Failure::usage(format!(
            "{}: {}",
            moldgate::files::shown(&path),
            toml_message(&text, &e)
        ))
    })?;
    Ok((value, text))
}
