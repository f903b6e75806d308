//! The HTTP service of moldgate (`moldgate serve`): the study of an uploaded mesh as the
//! same JSON report as `moldgate locate --json` (or its picture, GLB file or HTML page), the
//! materials and sample parts, an OpenAPI 3.1 document of all of it, and the browser app's
//! static files.
//!
//! The service is safe under load by construction:
//! - a request body is refused by its `Content-Length` before it is read when it is over
//!   [`Limits::max_upload`], and a streamed body is cut at that size;
//! - a body must arrive within [`Limits::read_timeout`] (408 otherwise), and a request's
//!   line and headers within [`Limits::header_timeout`] (the connection is closed
//!   otherwise);
//! - at most [`Limits::connections`] connections are open at once; more wait in the
//!   listen queue until one closes;
//! - at most [`Limits::analyses`] studies run at once, on blocking threads (never on the
//!   async workers), with at most [`Limits::queue`] more admitted and waiting; a study is
//!   admitted once its body is read (a slow upload holds no place), and a request that
//!   finds every place taken is refused with 503, before its body is read when they are
//!   taken as it arrives;
//! - the bodies held (being received or admitted) are at most (analyses + queue) x max
//!   upload bytes in all, counted as they arrive (503 past it);
//! - a study past [`Limits::timeout`] is cancelled through [`moldgate::study::Hooks`] and
//!   answered with 504;
//! - bad input is a JSON error with a 4xx status; a panic in a study is caught, logged and
//!   answered with 500 (`"kind": "internal"`).
//!
//! ```no_run
//! let config = moldgate_serve::Config::default();
//! moldgate_serve::run(config).unwrap();
//! ```

#![deny(missing_docs)]

mod body;
mod connection;
mod error;
mod log;
mod openapi;
mod routes;
mod study;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use tokio::sync::Semaphore;

pub use connection::MAX_HEAD_BYTES;
pub use error::ApiError;
pub use openapi::OPENAPI;
pub use routes::{Route, ROUTES};

/// The limits of the service, each with a documented default and a `moldgate serve` flag.
#[derive(Debug, Clone, PartialEq)]
pub struct Limits {
    /// Largest request body, bytes (`--max-upload`). Default 100 MiB.
    pub max_upload: u64,
    /// Studies that run at once (`--analyses`). Default: the number of cores.
    pub analyses: usize,
    /// Studies admitted beyond those, waiting for a free slot (`--queue`). Default 16.
    pub queue: usize,
    /// Time limit of a study, from the end of its upload (`--timeout`). Default 60 s.
    pub timeout: Duration,
    /// Time limit for receiving a request body (`--read-timeout`). Default 60 s.
    pub read_timeout: Duration,
    /// Largest grid a study may ask for, nodes (`--max-nodes`). Default 4,000,000 (the
    /// command line's default `max_nodes`).
    pub max_nodes: usize,
    /// Time limit for receiving a request's line and headers, from the accept or from the
    /// end of the previous answer on a kept-alive connection (`--header-timeout`); past it
    /// the connection is closed without an answer. Default 30 s.
    pub header_timeout: Duration,
    /// Connections open at once (`--connections`); more wait in the listen queue until
    /// one closes. Default 512.
    pub connections: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_upload: 100 << 20,
            analyses: std::thread::available_parallelism().map_or(2, |n| n.get()),
            queue: 16,
            timeout: Duration::from_secs(60),
            read_timeout: Duration::from_secs(60),
            max_nodes: 4_000_000,
            header_timeout: Duration::from_secs(30),
            connections: 512,
        }
    }
}

/// What `moldgate serve` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Address to listen on (`--bind`). Default `127.0.0.1:8080`.
    pub bind: SocketAddr,
    /// The limits.
    pub limits: Limits,
    /// The browser app's built folder, served at `/` (`--web-dir`), when it exists.
    pub web_dir: Option<PathBuf>,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            bind: SocketAddr::from(([127, 0, 0, 1], 8080)),
            limits: Limits::default(),
            web_dir: None,
        }
    }
}

/// Why the service could not run.
#[derive(Debug)]
pub enum ServeError {
    /// A limit of zero where at least one is needed.
    Limit(&'static str),
    /// The address cannot be listened on (in use, not this machine's, no permission).
    Bind(std::io::Error),
    /// The address cannot be bound, or the server failed.
    Io(std::io::Error),
}

impl std::fmt::Display for ServeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ServeError::Limit(what) => write!(f, "{what} must be at least 1"),
            ServeError::Bind(e) => write!(f, "cannot listen: {e}"),
            ServeError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for ServeError {}

/// The state every handler shares.
pub(crate) struct App {
    pub limits: Limits,
    /// Permits for the studies admitted (running or waiting): analyses + queue. A study is
    /// admitted once its body is read.
    pub admitted: Arc<Semaphore>,
    /// Permits for the studies running.
    pub running: Arc<Semaphore>,
    /// The bytes of request bodies the server holds (being received, or admitted), a
    /// permit a byte: [`App::upload_budget`] in all. A body takes its bytes as they
    /// arrive, so a slow upload holds only what it sent.
    pub uploads: Arc<Semaphore>,
    /// Requests whose body is being received.
    pub receiving: std::sync::atomic::AtomicUsize,
}

impl App {
    fn new(limits: Limits) -> App {
        App {
            admitted: Arc::new(Semaphore::new(limits.analyses + limits.queue)),
            running: Arc::new(Semaphore::new(limits.analyses)),
            uploads: Arc::new(Semaphore::new(App::upload_budget(&limits))),
            receiving: Default::default(),
            limits,
        }
    }

    /// The bytes of bodies held at most: a full upload for each study that may be
    /// admitted, (analyses + queue) x max upload, the bound the admission kept when it
    /// came before the upload.
    pub fn upload_budget(limits: &Limits) -> usize {
        let places = (limits.analyses as u64).saturating_add(limits.queue as u64);
        let bytes = places.saturating_mul(limits.max_upload);
        usize::try_from(bytes)
            .unwrap_or(usize::MAX)
            .min(Semaphore::MAX_PERMITS)
    }

    /// Studies running, and admitted and waiting for a slot.
    pub fn busy(&self) -> (usize, usize) {
        let l = &self.limits;
        let running = l.analyses - self.running.available_permits().min(l.analyses);
        let admitted =
            (l.analyses + l.queue) - self.admitted.available_permits().min(l.analyses + l.queue);
        (running, admitted.saturating_sub(running))
    }
}

/// The service as an axum router with these limits, for [`run`] or for serving it inside
/// another program.
pub fn router(limits: Limits, web_dir: Option<&std::path::Path>) -> axum::Router {
    routes::router(Arc::new(App::new(limits)), web_dir)
}

/// Runs the service until SIGTERM or Ctrl-C: binds, prints `moldgate: listening on
/// http://ADDR` on stderr, serves, and on the signal stops accepting, finishes the
/// requests in flight and returns.
pub fn run(config: Config) -> Result<(), ServeError> {
    if config.limits.analyses == 0 {
        return Err(ServeError::Limit("--analyses"));
    }
    if config.limits.max_upload == 0 {
        return Err(ServeError::Limit("--max-upload"));
    }
    if config.limits.connections == 0 {
        return Err(ServeError::Limit("--connections"));
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(ServeError::Io)?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(config.bind)
            .await
            .map_err(ServeError::Bind)?;
        let addr = listener.local_addr().map_err(ServeError::Io)?;
        let app = router(config.limits.clone(), config.web_dir.as_deref());
        eprintln!("moldgate: listening on http://{addr}");
        connection::serve(listener, app, &config.limits, shutdown_signal()).await;
        eprintln!("moldgate: stopped");
        Ok(())
    })
}

/// Resolves on SIGTERM or Ctrl-C.
async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
    eprintln!("moldgate: shutting down: no new connections, finishing the requests in flight");
}
