//! Connections: the accept loop of [`crate::run`], with what `axum::serve` does not offer.
//!
//! - **A slot per connection.** At most [`Limits::connections`] are open at once; the loop
//!   takes a slot before it accepts, so a connection over the bound waits in the kernel's
//!   listen queue (it costs no file descriptor and no memory of ours) until one closes. A
//!   flood of idle sockets cannot exhaust the process's descriptors or memory.
//! - **A time limit on the request head.** hyper's HTTP/1 `header_read_timeout`: a
//!   connection whose request line and headers have not all arrived within
//!   [`Limits::header_timeout`] of the moment the server started waiting for them (its
//!   accept, or the end of its previous answer on a kept-alive connection) is closed
//!   without an answer. So a client that sends a header byte a second holds its slot for at
//!   most that long, and so does an idle kept-alive connection. A head is also at most
//!   [`MAX_HEAD_BYTES`] (431 past it), which bounds the memory of a connection waiting for
//!   its head.
//! - **Graceful shutdown.** On the signal the loop stops accepting (the listener is
//!   closed), every connection is told to finish: an idle one closes at once, one with a
//!   request in flight closes after its answer; the loop returns when all have.

use std::future::Future;
use std::io;
use std::sync::Arc;
use std::time::Duration;

use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::server::graceful::GracefulShutdown;
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio::sync::Semaphore;

use crate::Limits;

/// Largest request line and headers, bytes: 64 KiB (a browser's are under 8 KiB).
pub const MAX_HEAD_BYTES: usize = 64 << 10;

/// Serves `app` on `listener` until `shutdown` resolves, then finishes the requests in
/// flight and returns.
pub(crate) async fn serve(
    listener: TcpListener,
    app: axum::Router,
    limits: &Limits,
    shutdown: impl Future<Output = ()>,
) {
    let slots = Arc::new(Semaphore::new(limits.connections));
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(limits.header_timeout)
        .max_header_size(MAX_HEAD_BYTES);
    let header_timeout = limits.header_timeout;
    let graceful = GracefulShutdown::new();
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        // The slot first: over the bound, connections wait in the listen queue.
        let slot = tokio::select! {
            slot = slots.clone().acquire_owned() => slot.expect("the semaphore is never closed"),
            () = &mut shutdown => break,
        };
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(a) => a,
                Err(e) => {
                    accept_failed(e).await;
                    continue;
                }
            },
            () = &mut shutdown => break,
        };
        let service = TowerToHyperService::new(app.clone());
        let connection = http.serve_connection(TokioIo::new(stream), service);
        let connection = graceful.watch(connection);
        tokio::spawn(async move {
            if let Err(e) = connection.await {
                if e.is_timeout() {
                    eprintln!(
                        "moldgate: {peer}: connection closed: its request head did not arrive within {} s (--header-timeout)",
                        header_timeout.as_secs_f64()
                    );
                }
            }
            drop(slot);
        });
    }
    drop(listener);
    graceful.shutdown().await;
}

/// After a failed accept: nothing for a connection that went before it was accepted; for
/// anything else (out of file descriptors) a line on stderr and a second's pause, so the
/// loop does not spin while the process cannot take more.
async fn accept_failed(e: io::Error) {
    if matches!(
        e.kind(),
        io::ErrorKind::ConnectionRefused
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::ConnectionReset
    ) {
        return;
    }
    eprintln!("moldgate: cannot accept a connection: {e}; trying again in 1 s");
    tokio::time::sleep(Duration::from_secs(1)).await;
}
