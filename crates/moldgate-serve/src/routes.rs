//! The routes of the service, in one table that both the router and the OpenAPI test read,
//! and the small handlers (materials, samples, health, the document).

use std::path::Path;
use std::sync::Arc;

use axum::extract::rejection::PathRejection;
use axum::extract::{Path as UrlPath, State};
use axum::http::{header, HeaderName, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post, MethodRouter};
use axum::Router;
use serde_json::json;
use tower_http::services::ServeDir;
use tower_http::set_header::SetResponseHeaderLayer;

use crate::error::ApiError;
use crate::App;

/// One route: its method (lower case, as in OpenAPI) and path (OpenAPI's `{name}` form,
/// which is also axum's).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Route {
    /// `get` or `post`.
    pub method: &'static str,
    /// The path.
    pub path: &'static str,
}

/// Every route of the service; the router is built from this table and the OpenAPI
/// document is tested against it.
pub const ROUTES: &[Route] = &[
    Route {
        method: "post",
        path: "/v1/study",
    },
    Route {
        method: "get",
        path: "/v1/materials",
    },
    Route {
        method: "get",
        path: "/v1/samples",
    },
    Route {
        method: "get",
        path: "/v1/samples/{name}",
    },
    Route {
        method: "get",
        path: "/v1/openapi.json",
    },
    Route {
        method: "get",
        path: "/healthz",
    },
];

fn handler_of(route: Route) -> Option<MethodRouter<Arc<App>>> {
    Some(match (route.method, route.path) {
        ("post", "/v1/study") => post(crate::study::handler),
        ("get", "/v1/materials") => get(materials),
        ("get", "/v1/samples") => get(samples),
        ("get", "/v1/samples/{name}") => get(sample),
        ("get", "/v1/openapi.json") => get(openapi),
        ("get", "/healthz") => get(healthz),
        _ => return None,
    })
}

/// The service's router: the routes of [`ROUTES`], JSON errors for unknown routes and
/// methods, the browser app's folder at `/` when given and present, cross-origin
/// isolation headers on every answer, and one log line per request.
pub(crate) fn router(app: Arc<App>, web_dir: Option<&Path>) -> Router {
    let mut r = Router::new();
    for route in ROUTES {
        if let Some(h) = handler_of(*route) {
            r = r.route(route.path, h);
        }
    }
    r = r.method_not_allowed_fallback(|| async {
        ApiError::new(
            StatusCode::METHOD_NOT_ALLOWED,
            "method",
            "this method is not allowed on this path (see /v1/openapi.json)",
        )
    });
    // The folder by its real path, so that a file's real path can be checked to lie in it.
    r = match web_dir
        .and_then(|d| d.canonicalize().ok())
        .filter(|d| d.is_dir())
    {
        Some(root) => {
            let root = Arc::new(root);
            r.fallback(move |req: axum::extract::Request| web_file(root.clone(), req))
        }
        None => r.fallback(|| async { not_found() }),
    };
    r.with_state(app)
        .layer(axum::middleware::from_fn(crate::log::log))
        .layer(SetResponseHeaderLayer::overriding(
            HeaderName::from_static("cross-origin-opener-policy"),
            HeaderValue::from_static("same-origin"),
        ))
        .layer(SetResponseHeaderLayer::overriding(
            HeaderName::from_static("cross-origin-embedder-policy"),
            HeaderValue::from_static("require-corp"),
        ))
}

fn not_found() -> ApiError {
    ApiError::new(
        StatusCode::NOT_FOUND,
        "not_found",
        "no such path (see /v1/openapi.json)",
    )
}

/// A file of the browser app's folder `root` (a real path): only a file whose real path
/// lies in the folder (no link out of it) and none of whose names is hidden (`.git`,
/// `.env`); anything else, and a missing file, is the JSON 404 of an unknown path.
async fn web_file(root: Arc<std::path::PathBuf>, req: axum::extract::Request) -> Response {
    if !servable(&root, req.uri().path()) {
        return not_found().into_response();
    }
    match ServeDir::new(root.as_path()).try_call(req).await {
        Ok(res) if res.status() == StatusCode::NOT_FOUND => not_found().into_response(),
        Ok(res) => res.map(axum::body::Body::new).into_response(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => not_found().into_response(),
        Err(e) => {
            ApiError::internal(format!("the web folder could not be read: {e}")).into_response()
        }
    }
}

/// Whether the URL path `url` names something under `root` (a real path) that may be
/// served: its names decoded as the file server decodes them, none hidden or holding a
/// backslash or NUL, and, when it exists, its real path (links followed) inside `root` and
/// a regular file (not a FIFO, a device or a socket).
fn servable(root: &Path, url: &str) -> bool {
    let Some(decoded) = percent_decoded(url) else {
        return false;
    };
    let mut file = root.to_path_buf();
    for name in decoded.split('/').filter(|n| !n.is_empty()) {
        if name.starts_with('.') || name.contains(['\\', '\0']) {
            return false;
        }
        file.push(name);
    }
    if file.is_dir() {
        file.push("index.html");
    }
    // A missing file is answered 404 by the file server. Only a regular file is served: a
    // FIFO would hold the request (and its thread) until something writes to it.
    file.canonicalize().map_or(true, |real| {
        real.starts_with(root) && std::fs::metadata(&real).is_ok_and(|m| m.is_file())
    })
}

/// `url` with its `%XX` escapes decoded; `None` when the bytes are not UTF-8.
fn percent_decoded(url: &str) -> Option<String> {
    let b = url.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (
            b[i],
            b.get(i + 1).and_then(|&c| hex(c)),
            b.get(i + 2).and_then(|&c| hex(c)),
        ) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (c, ..) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

fn json_response(v: serde_json::Value) -> Response {
    (
        [(header::CONTENT_TYPE, "application/json")],
        serde_json::to_vec_pretty(&v).unwrap_or_default(),
    )
        .into_response()
}

/// `GET /v1/materials`: the built-in library with Eq. 7-8, every value's source and each
/// material's aliases and description (`moldgate materials --json`).
async fn materials() -> Response {
    json_response(serde_json::to_value(moldgate::material::Listing::builtin()).unwrap_or_default())
}

/// `GET /v1/samples`: the built-in sample parts.
async fn samples() -> Response {
    let list: Vec<_> = moldgate::samples::SAMPLES
        .iter()
        .map(|s| {
            json!({
                "name": s.name,
                "description": s.description,
                "href": format!("/v1/samples/{}", s.name),
            })
        })
        .collect();
    json_response(json!({ "samples": list }))
}

/// `GET /v1/samples/{name}`: a sample part as binary STL (mm).
async fn sample(name: Result<UrlPath<String>, PathRejection>) -> Response {
    // A name that is no text (`%FF`) is an unknown sample too, said in JSON like every
    // error (axum's own answer would be plain text).
    let name = match name {
        Ok(UrlPath(name)) => name,
        Err(e) => {
            return ApiError::new(
                StatusCode::NOT_FOUND,
                "not_found",
                format!("unknown sample: {}", e.body_text()),
            )
            .at("name")
            .into_response()
        }
    };
    let Some(mesh) = moldgate::samples::sample(&name) else {
        let known: Vec<&str> = moldgate::samples::SAMPLES.iter().map(|s| s.name).collect();
        return ApiError::new(
            StatusCode::NOT_FOUND,
            "not_found",
            format!("unknown sample '{name}' (known: {})", known.join(", ")),
        )
        .at("name")
        .into_response();
    };
    let mut bytes = Vec::new();
    if let Err(e) = mesh.write_stl(&mut bytes) {
        return ApiError::internal(format!("cannot encode STL: {e}")).into_response();
    }
    (
        [
            (header::CONTENT_TYPE, "model/stl".to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{name}.stl\""),
            ),
        ],
        bytes,
    )
        .into_response()
}

/// `GET /v1/openapi.json`.
async fn openapi() -> Response {
    ([(header::CONTENT_TYPE, "application/json")], crate::OPENAPI).into_response()
}

/// `GET /healthz`: alive, and how busy.
async fn healthz(State(app): State<Arc<App>>) -> Response {
    let (running, waiting) = app.busy();
    json_response(json!({
        "status": "ok",
        "running": running,
        "waiting": waiting,
        "receiving": app.receiving.load(std::sync::atomic::Ordering::Relaxed),
    }))
}
