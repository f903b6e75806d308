//! `locate --png` and `--report`: the picture and the HTML report of an analysis.

use std::path::{Path, PathBuf};
use std::time::Instant;

use moldgate::mesh::LoadedMesh;
use moldgate::render::RenderOptions;
use moldgate::Study;

use crate::analyse::failure;
use crate::args::LocateArgs;
use crate::output::{refuse_input, same_file, write_atomic};
use crate::Failure;

/// Checks every output path before any work: `--png`, `--glb` and `--report` end in their
/// format's extension, none is the input, no two are the same file, and each one's folder
/// exists.
pub fn check_outputs(a: &LocateArgs) -> Result<(), Failure> {
    let outputs: Vec<(&str, &PathBuf)> = [
        ("--output", a.output.as_ref()),
        ("--glb", a.glb.as_ref()),
        ("--png", a.png.as_ref()),
        ("--report", a.report.as_ref()),
    ]
    .into_iter()
    .filter_map(|(flag, p)| p.map(|p| (flag, p)))
    .collect();
    for (i, (flag, path)) in outputs.iter().enumerate() {
        refuse_input(path, a.files.first().map(PathBuf::as_path))?;
        if let Some((other, _)) = outputs[..i].iter().find(|(_, q)| same_file(q, path)) {
            return Err(Failure::usage(format!(
                "{other} and {flag} name the same file {}",
                moldgate::files::shown(&path)
            )));
        }
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            return Err(Failure::output(format!(
                "{}: cannot write: folder {} does not exist",
                moldgate::files::shown(&path),
                moldgate::files::shown(&dir)
            )));
        }
    }
    for (flag, path, extensions) in [
        ("--png", a.png.as_ref(), &["png"][..]),
        ("--glb", a.glb.as_ref(), &["glb"][..]),
        ("--report", a.report.as_ref(), &["html", "htm"][..]),
    ] {
        let Some(path) = path else { continue };
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        // A FIFO or a device (`/dev/null`, `/dev/stdout`) is written into whatever its name.
        let special = std::fs::metadata(path).is_ok_and(|m| !m.is_file());
        if !special && !ext.as_deref().is_some_and(|e| extensions.contains(&e)) {
            return Err(Failure::usage(format!(
                "{flag} {}: the file name must end in .{} (it writes that format only)",
                moldgate::files::shown(&path),
                extensions.join(" or .")
            )));
        }
    }
    Ok(())
}

/// Draws the picture and writes `--png` and `--report` when asked for.
pub fn write(
    a: &LocateArgs,
    study: &Study,
    part: &LoadedMesh,
    title: String,
) -> Result<(), Failure> {
    if a.png.is_none() && a.report.is_none() {
        return Ok(());
    }
    let t = Instant::now();
    let png = study.png(part, title).map_err(|e| failure(&e, ""))?;
    let render_s = t.elapsed().as_secs_f64();
    if let Some(path) = &a.png {
        write_atomic(path, &png)?;
        let options = RenderOptions::default();
        eprintln!(
            "wrote {} ({}x{} pixels, drawn in {:.0} ms)",
            moldgate::files::shown(&path),
            options.width,
            options.height,
            render_s * 1e3
        );
    }
    if let Some(path) = &a.report {
        let page = study.html(Some(&png)).map_err(|e| failure(&e, ""))?;
        write_atomic(path, page.as_bytes())?;
        eprintln!("wrote {}", moldgate::files::shown(&path));
    }
    Ok(())
}
