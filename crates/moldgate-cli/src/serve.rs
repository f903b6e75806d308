//! `moldgate serve`: the flags checked and handed to [`moldgate_serve::run`].

use std::path::PathBuf;
use std::time::Duration;

use moldgate_serve::{Config, Limits};

use crate::args::ServeArgs;
use crate::Failure;

fn seconds(flag: &str, s: f64) -> Result<Duration, Failure> {
    moldgate::study::time_limit(flag, s).map_err(Failure::usage)
}

/// Runs the service until SIGTERM or Ctrl-C.
pub fn run_serve(a: ServeArgs) -> Result<(), Failure> {
    let defaults = Limits::default();
    if a.max_upload == 0 || a.max_upload > 1 << 20 {
        return Err(Failure::usage(format!(
            "--max-upload must be between 1 and 1048576 MiB, got {}",
            a.max_upload
        )));
    }
    let analyses = a.analyses.unwrap_or(defaults.analyses);
    if analyses == 0 || analyses > 1024 {
        return Err(Failure::usage(format!(
            "--analyses must be between 1 and 1024, got {analyses}"
        )));
    }
    if a.queue > 1 << 16 {
        return Err(Failure::usage(format!(
            "--queue must be at most 65536, got {}",
            a.queue
        )));
    }
    if a.max_nodes == 0 || a.max_nodes > moldgate::study::MAX_NODES_LIMIT {
        return Err(Failure::usage(format!(
            "--max-nodes must be between 1 and {}, got {}",
            moldgate::study::MAX_NODES_LIMIT,
            a.max_nodes
        )));
    }
    if a.connections == 0 || a.connections > 1 << 16 {
        return Err(Failure::usage(format!(
            "--connections must be between 1 and 65536, got {}",
            a.connections
        )));
    }
    let web_dir = match a.web_dir {
        Some(d) if !d.is_dir() => {
            return Err(Failure::input(format!(
                "--web-dir {}: {}",
                moldgate::files::shown(&d),
                match d.exists() {
                    true => "not a folder",
                    false => "no such folder",
                }
            )))
        }
        Some(d) => Some(d),
        None => Some(PathBuf::from("web/dist")).filter(|d| d.is_dir()),
    };
    let config = Config {
        bind: a.bind,
        limits: Limits {
            max_upload: a.max_upload << 20,
            analyses,
            queue: a.queue,
            timeout: seconds("--timeout", a.timeout)?,
            read_timeout: seconds("--read-timeout", a.read_timeout)?,
            max_nodes: a.max_nodes,
            header_timeout: seconds("--header-timeout", a.header_timeout)?,
            connections: a.connections,
        },
        web_dir,
    };
    moldgate_serve::run(config).map_err(|e| match e {
        moldgate_serve::ServeError::Bind(_) | moldgate_serve::ServeError::Limit(_) => {
            Failure::usage(format!("serve on {}: {e}", a.bind))
        }
        moldgate_serve::ServeError::Io(_) => Failure::new(1, format!("serve on {}: {e}", a.bind)),
    })
}
