//! Reading a request body within the limits: refused by its `Content-Length` before any
//! byte is read when it is too large, cut at the limit when it streams, and given a
//! deadline so a client that sends a byte a second cannot hold a slot; the bytes held are
//! taken from the server's upload budget as they arrive.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use axum::body::{Body, Bytes};
use axum::http::{header, HeaderMap, StatusCode};
use http_body_util::BodyExt;
use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use crate::error::ApiError;

/// Bytes received of one request, shared with the request log line.
#[derive(Debug, Clone, Default)]
pub struct BytesIn(pub Arc<AtomicU64>);

/// The 413 error of a body over `max` bytes.
fn too_large(max: u64, place: &str) -> ApiError {
    ApiError::new(
        StatusCode::PAYLOAD_TOO_LARGE,
        "too_large",
        format!(
            "the request body is larger than this server's limit of {max} bytes (--max-upload)"
        ),
    )
    .at(place)
}

/// Refuses a request whose declared `Content-Length` is over `max`, before its body is
/// read; gives the declared length.
pub fn check_length(headers: &HeaderMap, max: u64) -> Result<Option<u64>, ApiError> {
    let Some(v) = headers.get(header::CONTENT_LENGTH) else {
        return Ok(None);
    };
    let declared = v
        .to_str()
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok())
        .ok_or_else(|| {
            ApiError::new(
                StatusCode::BAD_REQUEST,
                "body",
                "Content-Length is not a number",
            )
            .at("Content-Length")
        })?;
    if declared > max {
        return Err(too_large(max, "Content-Length"));
    }
    Ok(Some(declared))
}

/// The body bytes a request holds of the server's upload budget (a permit a byte), taken
/// as they arrive and given back when dropped.
pub struct Held(Option<OwnedSemaphorePermit>);

impl Held {
    /// Takes `n` more bytes of `budget`, or says the server is busy.
    fn take(
        &mut self,
        (budget, total, receiving): (&Arc<Semaphore>, usize, &AtomicUsize),
        n: usize,
    ) -> Result<(), ApiError> {
        if n == 0 {
            return Ok(());
        }
        let more = u32::try_from(n)
            .ok()
            .and_then(|n| budget.clone().try_acquire_many_owned(n).ok())
            .ok_or_else(|| {
                // This request is among those being received.
                let others = receiving.load(Ordering::Relaxed).saturating_sub(1);
                ApiError::busy(format!(
                    "the server is busy: the bodies it holds ({others} other {} being received, and those of the studies admitted) fill its upload memory of {} MiB ((--analyses + --queue) x --max-upload); try again later",
                    if others == 1 { "upload" } else { "uploads" },
                    total >> 20
                ))
            })?;
        match &mut self.0 {
            Some(held) => held.merge(more),
            none => *none = Some(more),
        }
        Ok(())
    }
}

/// Reads the whole body: at most `max` bytes, all of it within `timeout`, each chunk's
/// bytes taken from `budget` (its semaphore, its bytes in all, and the count of requests
/// being received, which this one is among) as it arrives. `declared` (the checked
/// `Content-Length`) sizes the buffer once, so a large upload is not copied as it grows
/// (its pages are the system's only once written).
pub async fn read(
    body: Body,
    declared: Option<u64>,
    (max, timeout): (u64, Duration),
    budget: (&Arc<Semaphore>, usize, &AtomicUsize),
    counter: &BytesIn,
) -> Result<(Bytes, Held), ApiError> {
    let deadline = tokio::time::Instant::now() + timeout;
    let mut body = body;
    let mut held = Held(None);
    let mut out = Vec::with_capacity(declared.unwrap_or(0).min(max) as usize);
    loop {
        let frame = match tokio::time::timeout_at(deadline, body.frame()).await {
            Err(_) => {
                return Err(ApiError::new(
                    StatusCode::REQUEST_TIMEOUT,
                    "body_timeout",
                    format!(
                        "the request body did not arrive within {} s (--read-timeout); {} bytes were received",
                        timeout.as_secs_f64(),
                        out.len()
                    ),
                )
                .at("body"))
            }
            Ok(None) => break,
            Ok(Some(Err(e))) => {
                return Err(ApiError::new(
                    StatusCode::BAD_REQUEST,
                    "body",
                    format!(
                        "the request body could not be read after {} bytes: {e}",
                        out.len()
                    ),
                )
                .at("body"))
            }
            Ok(Some(Ok(frame))) => frame,
        };
        if let Ok(data) = frame.into_data() {
            counter.0.fetch_add(data.len() as u64, Ordering::Relaxed);
            if out.len() as u64 + data.len() as u64 > max {
                return Err(too_large(max, "body"));
            }
            held.take(budget, data.len())?;
            out.extend_from_slice(&data);
        }
    }
    Ok((Bytes::from(out), held))
}
