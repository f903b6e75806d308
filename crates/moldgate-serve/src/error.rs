//! Errors as the service answers them: `{"error": {"kind", "message", "where"}}` with the
//! status of their kind.

use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use moldgate::flow::FillError;
use moldgate::render::RenderError;
use moldgate::study::StudyError;
use moldgate::{LoadError, OptionsError};
use serde_json::{json, Value};

/// The seconds a busy server's 503 asks the client to wait before it tries again.
pub const RETRY_AFTER_S: &str = "5";

/// An error answer: its status, a kind (one word, stable), a message for people, and
/// where the problem is (an option, a line or byte of the mesh, a header) when known.
#[derive(Debug, Clone)]
pub struct ApiError {
    /// HTTP status.
    pub status: StatusCode,
    /// `options`, `too_large`, `format`, `body`, `body_timeout`, `mesh`, `no_gate`, `busy`,
    /// `timeout`, `not_found`, `method`, `internal`.
    pub kind: &'static str,
    /// What is wrong.
    pub message: String,
    /// Where: an option name, `line 12` / `byte 84` of the mesh, a header; or none.
    pub place: Option<String>,
    /// The report of a study that found no gate (`no_gate`), so the counts are not lost.
    pub report: Option<Value>,
}

impl ApiError {
    /// An error of `kind` with `status`.
    pub fn new(status: StatusCode, kind: &'static str, message: impl Into<String>) -> ApiError {
        ApiError {
            status,
            kind,
            message: message.into(),
            place: None,
            report: None,
        }
    }

    /// The same error, saying where.
    pub fn at(mut self, place: impl Into<String>) -> ApiError {
        self.place = Some(place.into());
        self
    }

    /// 503: the server is busy; the answer asks the client to come back in a few
    /// seconds (`Retry-After`).
    pub fn busy(message: impl Into<String>) -> ApiError {
        ApiError::new(StatusCode::SERVICE_UNAVAILABLE, "busy", message)
    }

    /// 400: an option that cannot be read or is out of range.
    pub fn options(message: impl Into<String>) -> ApiError {
        ApiError::new(StatusCode::BAD_REQUEST, "options", message)
    }

    /// 422: the mesh cannot be read.
    pub fn mesh(e: &LoadError) -> ApiError {
        let message = match e {
            // A file read as STL that is an OBJ or a PLY: here its format is named by the
            // request, not by a file name's extension.
            LoadError::NotAMesh { what, advice } if advice.contains("extension") => {
                let (media, format) = if what.contains("PLY") {
                    ("application/x-ply", "ply")
                } else if what.contains("STL") {
                    ("model/stl", "stl")
                } else {
                    ("model/obj", "obj")
                };
                let not = if format == "stl" {
                    "not the format asked for"
                } else {
                    "not an STL"
                };
                format!("this is {what}, {not}: send it as {media}, or give format={format}")
            }
            _ => e.to_string(),
        };
        let e422 = ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "mesh", message);
        match e {
            LoadError::Syntax { place, .. }
            | LoadError::NonFinite { place, .. }
            | LoadError::OutOfRange { place, .. }
            | LoadError::TooMuchMemory { place, .. } => e422.at(place.to_string()),
            LoadError::Truncated { offset, .. } => e422.at(format!("byte {offset}")),
            LoadError::CountMismatch { expected, .. } => e422.at(format!("byte {expected}")),
            LoadError::TruncatedHeader { .. } => e422.at("byte 0"),
            // No place in the mesh: the body as a whole (an empty or unreadable mesh, another
            // kind of file, no facet with area), as the OpenAPI document says.
            _ => e422.at("body"),
        }
    }

    /// 500: a bug.
    pub fn internal(message: impl Into<String>) -> ApiError {
        ApiError::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", message)
    }

    /// The error of a study that could not be made.
    pub fn study(e: &StudyError) -> ApiError {
        // The options named as this service's query parameters, not the command line's flags.
        let message = moldgate::study::keyword_words(&e.to_string(), "true");
        match e {
            StudyError::Invalid { field, .. }
            | StudyError::Parse { field, .. }
            | StudyError::Conflict { first: field, .. } => ApiError::options(message).at(*field),
            // A parameter at fault is named as the query parameter that sets it (`n=0`).
            StudyError::Material(
                OptionsError::NonPositiveMaterial { parameter, .. }
                | OptionsError::MaterialOutOfRange { parameter, .. },
            ) => ApiError::options(message).at(*parameter),
            StudyError::UnknownMaterial { .. } | StudyError::Material(_) => {
                ApiError::options(message).at("material")
            }
            // The part's fault, not an option's (as the command line's exit code 3).
            StudyError::Locate(l) if l.is_the_parts() => {
                ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "mesh", message)
            }
            // An option over its limit or budget, or a grid over max_nodes for the spacing.
            StudyError::Locate(l) => match l.field() {
                Some(field) => ApiError::options(message).at(field),
                None => ApiError::options(message),
            },
            StudyError::Fill(FillError::TooFewCandidates { .. }) => {
                ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "no_gate", message)
            }
            StudyError::Fill(FillError::GateOffPart(..)) => {
                ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "mesh", message)
            }
            StudyError::Fill(f) => match f.field() {
                Some(field) => ApiError::options(message).at(field),
                None => ApiError::options(message),
            },
            StudyError::Demold(_) => {
                ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "mesh", message).at("demold")
            }
            StudyError::Render(RenderError::EmptyMesh) => {
                ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "mesh", message)
            }
            StudyError::Cancelled { .. } => ApiError::new(
                StatusCode::GATEWAY_TIMEOUT,
                "timeout",
                format!("the study took longer than the time limit and was stopped ({message})"),
            ),
            _ => ApiError::internal(message),
        }
    }

    /// The JSON body.
    pub fn body(&self) -> Value {
        let mut v = json!({
            "error": { "kind": self.kind, "message": self.message, "where": self.place }
        });
        if let Some(r) = &self.report {
            v["report"] = r.clone();
        }
        v
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = serde_json::to_vec(&self.body()).unwrap_or_default();
        let mut response = (
            self.status,
            [(axum::http::header::CONTENT_TYPE, "application/json")],
            body,
        )
            .into_response();
        if self.status == StatusCode::SERVICE_UNAVAILABLE {
            response.headers_mut().insert(
                axum::http::header::RETRY_AFTER,
                axum::http::HeaderValue::from_static(RETRY_AFTER_S),
            );
        }
        response
    }
}
