//! `moldgate sample`: the built-in sample parts, listed or written as binary STL.

use moldgate::samples::SAMPLES;

use crate::args::SampleArgs;
use crate::output::{print_stdout, write_atomic};
use crate::Failure;

/// The error of a sample name that is not built in, with the known names.
pub fn unknown_sample(name: &str) -> Failure {
    let names: Vec<&str> = SAMPLES.iter().map(|s| s.name).collect();
    Failure::usage(format!(
        "unknown sample '{name}' (known: {})",
        names.join(", ")
    ))
}

/// Lists the samples, or writes one.
pub fn run_sample(a: SampleArgs) -> Result<(), Failure> {
    if a.list {
        let mut out = String::new();
        for s in SAMPLES {
            out += &format!("{:10} {}\n", s.name, s.description);
        }
        return print_stdout(&out);
    }
    let (Some(name), Some(path)) = (a.name, a.output) else {
        return Err(Failure::usage("give a sample name and -o FILE.stl"));
    };
    let mesh = moldgate::samples::sample(&name).ok_or_else(|| unknown_sample(&name))?;
    let mut bytes = Vec::new();
    mesh.write_stl(&mut bytes)
        .map_err(|e| Failure::output(format!("cannot encode STL: {e}")))?;
    write_atomic(&path, &bytes)?;
    eprintln!(
        "wrote {} ({} triangles, mm)",
        moldgate::files::shown(&path),
        mesh.triangles.len()
    );
    Ok(())
}
