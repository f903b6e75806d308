//! The OpenAPI 3.1 document of the service, written by hand (`openapi.json` beside this
//! file) and kept true by tests: every route of [`crate::ROUTES`] is in it and no other,
//! and its examples are what the service answers.

/// The OpenAPI 3.1 document, as served at `GET /v1/openapi.json`.
pub const OPENAPI: &str = include_str!("openapi.json");
