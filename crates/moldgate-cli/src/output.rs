//! Writing files whole or not at all, and never over the input; printing results on stdout.

use std::io::Write;
use std::path::Path;

use crate::Failure;

/// Refuses an output path that names the input file (also through links or `..`).
pub fn refuse_input(output: &Path, input: Option<&Path>) -> Result<(), Failure> {
    let Some(input) = input else { return Ok(()) };
    let same = match (output.canonicalize(), input.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => output == input,
    };
    if same {
        return Err(Failure::output(format!(
            "{}: refusing to write the output over the input file",
            output.display()
        )));
    }
    Ok(())
}

/// Whether two paths name the same file, whether or not it exists yet: their folders are
/// compared after resolving links and `..`.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let resolved = |p: &Path| {
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(dir.canonicalize().ok()?.join(p.file_name()?))
    };
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => match (resolved(a), resolved(b)) {
            (Some(x), Some(y)) => x == y,
            _ => a == b,
        },
    }
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so the
/// file is either the old one or the complete new one, never a half-written one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    let fail =
        |e: std::io::Error| Failure::output(format!("{}: cannot write: {e}", path.display()));
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if path.is_dir() {
        return Err(Failure::output(format!(
            "{}: is a folder, not a file",
            path.display()
        )));
    }
    let name = path
        .file_name()
        .ok_or_else(|| Failure::output(format!("{}: not a file name", path.display())))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(fail(e));
    }
    Ok(())
}

/// Writes `text` on stdout. A reader that has gone away (`moldgate ... | head`) is not an
/// error: the rest of the output is simply not wanted.
pub fn print_stdout(text: &str) -> Result<(), Failure> {
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|_| stdout.flush())
    {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(Failure::output(format!("stdout: {e}")))
        }
        _ => Ok(()),
    }
}
