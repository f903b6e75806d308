//! One line per request on stderr: method, path, status, bytes in and out, time in ms.

use std::sync::atomic::Ordering;
use std::time::Instant;

use axum::body::HttpBody as _;
use axum::extract::Request;
use axum::http::header;
use axum::middleware::Next;
use axum::response::Response;

use crate::body::BytesIn;

/// The logging middleware: counts the body bytes the handler reads (through [`BytesIn`])
/// and the answer's size.
pub async fn log(mut req: Request, next: Next) -> Response {
    let t = Instant::now();
    let method = req.method().clone();
    let path = req.uri().path().to_string();
    let bytes_in = BytesIn::default();
    req.extensions_mut().insert(bytes_in.clone());
    let response = next.run(req).await;
    let out = response
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok()?.parse::<u64>().ok())
        .or_else(|| response.body().size_hint().exact())
        .map_or_else(|| "?".to_string(), |n| n.to_string());
    eprintln!(
        "moldgate: {method} {path} {} in={} out={out} {:.1}ms",
        response.status().as_u16(),
        bytes_in.0.load(Ordering::Relaxed),
        t.elapsed().as_secs_f64() * 1e3
    );
    response
}
