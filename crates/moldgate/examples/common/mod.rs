//! What the examples that time a part's outputs share: from the command line
//! `PART [DIRECTION] [RUNS]` (a sample's name or a file of any format read in mm, `+z` and
//! 5 by default, at least one run), the part loaded and located.

use moldgate::mesh::{self, Units};
use moldgate::{locate, Analysis, Direction, LoadedMesh, LocateOptions};

/// A part named on the command line, loaded and located.
pub struct Located {
    /// The sample's name or the file's path, as given.
    pub name: String,
    pub loaded: LoadedMesh,
    pub analysis: Analysis,
    /// Runs asked for, at least one.
    pub runs: usize,
}

/// The part, direction and count of runs of the command line, the part loaded and located.
pub fn located_from_args() -> Located {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "cover".into());
    let direction: Direction = args
        .next()
        .unwrap_or_else(|| "+z".into())
        .parse()
        .expect("a direction");
    let runs: usize = args
        .next()
        .map(|s| s.parse().expect("a count"))
        .unwrap_or(5)
        .max(1);
    let loaded = match moldgate::samples::sample(&name) {
        Some(m) => mesh::from_generated(m),
        None => {
            moldgate::files::read_mesh_file(std::path::Path::new(&name), Units::Mm)
                .expect("the part reads")
                .0
        }
    };
    let options = LocateOptions {
        direction,
        ..LocateOptions::default()
    };
    let analysis = locate(&loaded, &options).expect("the analysis runs");
    Located {
        name,
        loaded,
        analysis,
        runs,
    }
}
