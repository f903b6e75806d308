//! `POST /v1/study`: admission, the body within the limits, the options from the query (or
//! a multipart `options` part) through the library's serde [`StudyOptions`], the study on a
//! blocking thread with a time limit, and the answer (report, picture, GLB or page).

use std::io::Cursor;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

use axum::body::Bytes;
use axum::extract::{Request, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use moldgate::mesh::{self, LoadedMesh, Units};
use moldgate::report::Input;
use moldgate::study::{Cancel, Hooks, Settings, StudyOptions};
use serde_json::{Map, Value};

use crate::body::{self, BytesIn};
use crate::error::ApiError;
use crate::App;

/// A mesh format the service reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Binary or ASCII STL.
    Stl,
    /// Wavefront OBJ.
    Obj,
    /// PLY, ASCII or binary.
    Ply,
}

const FORMATS: &str = "stl, obj, ply";

impl Format {
    /// The format of a `format` value (`stl`, `obj`, `ply`, any case).
    fn by_name(name: &str) -> Option<Format> {
        match name.trim().to_ascii_lowercase().as_str() {
            "stl" => Some(Format::Stl),
            "obj" => Some(Format::Obj),
            "ply" => Some(Format::Ply),
            _ => None,
        }
    }

    /// The format of a media type; `None` for `application/octet-stream` and every type
    /// that does not name one.
    fn by_media_type(media: &str) -> Option<Format> {
        let essence = media.split(';').next().unwrap_or("").trim();
        match essence.to_ascii_lowercase().as_str() {
            "model/stl" | "model/x.stl-binary" | "model/x.stl-ascii" | "application/sla" => {
                Some(Format::Stl)
            }
            "model/obj" => Some(Format::Obj),
            "application/x-ply" | "model/x-ply" => Some(Format::Ply),
            _ => None,
        }
    }

    /// The format of a file name's extension.
    fn by_file_name(name: &str) -> Option<Format> {
        let (_, ext) = name.rsplit_once('.')?;
        Format::by_name(ext)
    }
}

/// What the answer is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Output {
    Json,
    Png,
    Glb,
    Html,
}

impl Output {
    fn by_name(name: &str) -> Result<Output, ApiError> {
        match name {
            "json" => Ok(Output::Json),
            "png" => Ok(Output::Png),
            "glb" => Ok(Output::Glb),
            "html" => Ok(Output::Html),
            _ => Err(ApiError::options(format!(
                "output must be one of json, png, glb, html, got '{name}'"
            ))
            .at("output")),
        }
    }
}

/// The query parameters that are not study options.
struct Controls {
    format: Option<String>,
    output: Output,
    units: Units,
}

/// Splits the query into the service's own parameters and the study options (as a JSON
/// object, see [`options_object`]).
fn parse_query(query: &str) -> Result<(Controls, Vec<(String, String)>), ApiError> {
    // A name or value whose percent-encoded bytes are not UTF-8 would be read with
    // replacement characters: refused, by its parameter, before that.
    for pair in query.split('&') {
        let (name, value) = pair.split_once('=').unwrap_or((pair, ""));
        // `+` is a space to the form decoding, which makes no byte out of UTF-8.
        let utf8 = |text| percent_encoding::percent_decode_str(text).decode_utf8();
        match (utf8(name), utf8(value)) {
            (Ok(_), Ok(_)) => {}
            (Ok(name), Err(_)) => {
                let name = name.into_owned();
                return Err(ApiError::options(format!(
                    "the value of {name} is not UTF-8 text (its percent-encoded bytes make no characters: '{value}')"
                ))
                .at(name))
            }
            (Err(_), _) => {
                return Err(ApiError::options(format!(
                    "the query parameter name '{name}' is not UTF-8 text (its percent-encoded bytes make no characters)"
                ))
                .at("query"))
            }
        }
    }
    let pairs: Vec<(String, String)> = serde_urlencoded::from_str(query)
        .map_err(|e| ApiError::options(format!("the query cannot be read: {e}")).at("query"))?;
    let mut controls = Controls {
        format: None,
        output: Output::Json,
        units: Units::Mm,
    };
    let mut seen = std::collections::HashSet::new();
    let mut rest = Vec::new();
    for (k, v) in pairs {
        if k.is_empty() {
            return Err(ApiError::options(format!(
                "a query parameter has no name (before '={}'); parameters are name=value, joined by &",
                moldgate::error::excerpt(v.as_bytes())
            ))
            .at("query"));
        }
        let own = matches!(k.as_str(), "format" | "output" | "units");
        if own && !seen.insert(k.clone()) {
            return Err(ApiError::options(format!("{k} is given more than once")).at(k));
        }
        match k.as_str() {
            "format" => controls.format = Some(v),
            "output" => controls.output = Output::by_name(&v)?,
            "units" => {
                controls.units = v
                    .parse()
                    .map_err(|e: String| ApiError::options(format!("units: {e}")).at("units"))?
            }
            _ => rest.push((k, v)),
        }
    }
    Ok((controls, rest))
}

/// The query's option pairs as a JSON object for [`StudyOptions`]'s serde: a list field
/// (`keep_out`) takes every value of its repeated key, a text field its text, and any other
/// value is read as JSON when it is a number, `true`, `false` or an object, else as text,
/// so a wrong type is refused by serde with its message.
pub fn options_object(pairs: Vec<(String, String)>) -> Result<Map<String, Value>, ApiError> {
    let defaults = serde_json::to_value(StudyOptions::default()).unwrap_or(Value::Null);
    let mut out = Map::new();
    for (k, v) in pairs {
        let default = defaults.get(&k);
        if let Some(Value::Array(_)) = default {
            if let Value::Array(list) = out.entry(k).or_insert_with(|| Value::Array(Vec::new())) {
                list.push(Value::String(v));
            }
            continue;
        }
        if out.contains_key(&k) {
            return Err(ApiError::options(format!("{k} is given more than once")).at(k));
        }
        let value = match default {
            Some(Value::String(_)) => Value::String(v),
            _ => {
                // A number beyond a double (`1e400`), or NaN or infinity, would be refused
                // as text ("expected a number"): said as what it is.
                if v.trim().parse::<f64>().is_ok_and(|x| !x.is_finite()) {
                    return Err(ApiError::options(format!(
                        "{k} must be a finite number, got {}",
                        moldgate::error::excerpt(v.trim().as_bytes())
                    ))
                    .at(k));
                }
                scalar(&v)
            }
        };
        out.insert(k, value);
    }
    Ok(out)
}

/// A query value as JSON: a number, a boolean or an object when it reads as one, text
/// otherwise.
fn scalar(v: &str) -> Value {
    let t = v.trim();
    let looks_json = t == "true"
        || t == "false"
        || t.starts_with('{')
        || t.starts_with(|c: char| c.is_ascii_digit() || c == '-' || c == '.');
    match looks_json.then(|| serde_json::from_str::<Value>(t)) {
        Some(Ok(v @ (Value::Number(_) | Value::Bool(_) | Value::Object(_)))) => v,
        _ => Value::String(v.to_string()),
    }
}

/// The study options of a JSON object: serde's message on failure, and the option it is
/// about when it can be found.
pub fn study_options(object: Map<String, Value>) -> Result<StudyOptions, ApiError> {
    StudyOptions::from_json_object(object).map_err(|e| {
        let err = ApiError::options(e.message);
        match e.field {
            Some(field) => err.at(field),
            None => err,
        }
    })
}

/// The mesh bytes, their format and a title, from a plain or a multipart body.
struct Upload {
    bytes: Bytes,
    format: Format,
    title: String,
}

fn unknown_format(what: String) -> ApiError {
    ApiError::new(StatusCode::UNSUPPORTED_MEDIA_TYPE, "format", what)
}

fn format_by_name(name: &str) -> Result<Format, ApiError> {
    Format::by_name(name).ok_or_else(|| {
        unknown_format(format!("unknown mesh format '{name}' (known: {FORMATS})")).at("format")
    })
}

/// The format of a plain body: the `format` parameter, else the Content-Type.
fn plain_format(query_format: Option<&str>, headers: &HeaderMap) -> Result<Format, ApiError> {
    if let Some(name) = query_format {
        return format_by_name(name);
    }
    let media = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("");
    Format::by_media_type(media).ok_or_else(|| {
        let said = if media.is_empty() {
            "no Content-Type".to_string()
        } else {
            format!("Content-Type '{media}'")
        };
        unknown_format(format!(
            "{said}: the mesh's format is not named; send model/stl, model/obj or application/x-ply, or give format={{{}}}",
            FORMATS.replace(", ", ",")
        ))
        .at("Content-Type")
    })
}

/// The boundary of a `multipart/form-data` body; `None` for any other body. A multipart
/// body without a boundary cannot be read: 400.
fn multipart_boundary(headers: &HeaderMap) -> Result<Option<String>, ApiError> {
    let Some(media) = headers
        .get(header::CONTENT_TYPE)
        .and_then(|m| m.to_str().ok())
    else {
        return Ok(None);
    };
    if !media
        .trim_start()
        .to_ascii_lowercase()
        .starts_with("multipart/form-data")
    {
        return Ok(None);
    }
    multer::parse_boundary(media).map(Some).map_err(|_| {
        ApiError::new(
            StatusCode::BAD_REQUEST,
            "body",
            "a multipart/form-data body needs a boundary parameter in its Content-Type (multipart/form-data; boundary=...)",
        )
        .at("Content-Type")
    })
}

/// The options part: a JSON object whose keys are each given once (a key given twice would
/// silently take its last value, as a repeated query parameter is refused).
struct OptionsObject(Map<String, Value>);

impl<'de> serde::Deserialize<'de> for OptionsObject {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Keys;
        impl<'de> serde::de::Visitor<'de> for Keys {
            type Value = OptionsObject;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a JSON object of options")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut a: A,
            ) -> Result<Self::Value, A::Error> {
                let mut map = Map::new();
                while let Some(key) = a.next_key::<String>()? {
                    if map.contains_key(&key) {
                        return Err(serde::de::Error::custom(format!(
                            "the option '{key}' is given more than once"
                        )));
                    }
                    let value: Value = a.next_value()?;
                    map.insert(key, value);
                }
                Ok(OptionsObject(map))
            }
        }
        d.deserialize_map(Keys)
    }
}

/// Reads the `options` (JSON object) and `mesh` parts of a multipart body.
async fn multipart(
    bytes: Bytes,
    boundary: String,
    query_format: Option<&str>,
) -> Result<(Upload, Map<String, Value>), ApiError> {
    let bad = |m: String| ApiError::new(StatusCode::BAD_REQUEST, "body", m).at("multipart");
    let stream = futures_util::stream::once(async move { Ok::<Bytes, std::io::Error>(bytes) });
    let mut parts = multer::Multipart::new(stream, boundary);
    let mut options = None;
    let mut mesh = None;
    while let Some(field) = parts
        .next_field()
        .await
        .map_err(|e| bad(format!("the multipart body cannot be read: {e}")))?
    {
        let name = field.name().unwrap_or("").to_string();
        // A second part of a name would silently replace the first: one study, one of each.
        let twice = match name.as_str() {
            "options" => options.is_some(),
            "mesh" => mesh.is_some(),
            _ => false,
        };
        if twice {
            return Err(bad(format!(
                "the '{name}' part is given more than once (a study takes one mesh and one options object; send several parts as several requests)"
            )));
        }
        match name.as_str() {
            "options" => {
                let text = field
                    .bytes()
                    .await
                    .map_err(|e| bad(format!("the options part cannot be read: {e}")))?;
                let fail = |m: String| ApiError::options(m).at("options");
                // A number beyond a double (1e400) is not finite, as the query form says.
                let v: Value = serde_json::from_slice(&text).map_err(|e| {
                    let e = e.to_string().replace(
                        "number out of range",
                        "a number too large to be finite (beyond 1.8e308)",
                    );
                    fail(format!("the options part is not JSON: {e}"))
                })?;
                if !v.is_object() {
                    return Err(fail("the options part must be a JSON object".into()));
                }
                // Read again for what a Value hides: a key given twice.
                let OptionsObject(map) = serde_json::from_slice(&text)
                    .map_err(|e| fail(format!("the options part: {e}")))?;
                // The request's own parameters are not study options: say where they go.
                if let Some(k) = ["units", "format", "output"]
                    .into_iter()
                    .find(|k| map.contains_key(*k))
                {
                    return Err(ApiError::options(format!(
                        "{k} is a parameter of the request's query (POST /v1/study?{k}=...), not a study option of the options part"
                    ))
                    .at(k));
                }
                options = Some(map);
            }
            "mesh" => {
                let media = field.content_type().map(|m| m.to_string());
                let file = field.file_name().map(str::to_string);
                let data = field
                    .bytes()
                    .await
                    .map_err(|e| bad(format!("the mesh part cannot be read: {e}")))?;
                mesh = Some((data, media, file));
            }
            other => {
                return Err(bad(format!(
                    "unknown part '{other}' (the parts are 'options' and 'mesh')"
                )))
            }
        }
    }
    let Some((data, media, file)) = mesh else {
        return Err(bad("no 'mesh' part".into()));
    };
    let format = match query_format {
        Some(name) => format_by_name(name)?,
        None => media
            .as_deref()
            .and_then(Format::by_media_type)
            .or_else(|| file.as_deref().and_then(Format::by_file_name))
            .ok_or_else(|| {
                unknown_format(format!(
                    "the mesh part names no format: give it the Content-Type model/stl, model/obj or application/x-ply, a file name ending in .stl, .obj or .ply, or format={{{}}}",
                    FORMATS.replace(", ", ",")
                ))
                .at("mesh")
            })?,
    };
    let title = file.unwrap_or_else(|| "uploaded part".into());
    Ok((
        Upload {
            bytes: data,
            format,
            title,
        },
        options.unwrap_or_default(),
    ))
}

/// What a finished request answers.
enum Answer {
    Json(String),
    Png(Vec<u8>),
    Glb(Vec<u8>),
    Html(String),
}

impl IntoResponse for Answer {
    fn into_response(self) -> Response {
        let (ct, body) = match self {
            Answer::Json(s) => ("application/json", s.into_bytes()),
            Answer::Png(b) => ("image/png", b),
            Answer::Glb(b) => ("model/gltf-binary", b),
            Answer::Html(s) => ("text/html; charset=utf-8", s.into_bytes()),
        };
        ([(header::CONTENT_TYPE, ct)], body).into_response()
    }
}

/// Runs `f`, turning a panic into a 500 answer (logged on stderr by the panic hook and here).
pub fn guarded<T>(f: impl FnOnce() -> Result<T, ApiError>) -> Result<T, ApiError> {
    match std::panic::catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic".into());
            eprintln!("moldgate: internal error in a study: {what}");
            Err(ApiError::internal(format!(
                "internal error, please report it: {what}"
            )))
        }
    }
}

fn load(upload: &Upload, units: Units) -> Result<LoadedMesh, ApiError> {
    let bytes = &upload.bytes[..];
    let reader = Cursor::new(bytes);
    match upload.format {
        // Through cursors of its own per reading thread, a large binary STL is read and
        // welded in parallel runs, as the command line reads a file.
        Format::Stl => {
            mesh::read_stl_reopen(|| Ok(Cursor::new(bytes)), upload.bytes.len() as u64, units)
        }
        Format::Obj => mesh::read_obj(reader, units),
        Format::Ply => mesh::read_ply(reader, units),
    }
    .map_err(|e| ApiError::mesh(&e))
}

/// Loads and studies the upload, and makes the answer (on a blocking thread).
fn work(
    upload: Upload,
    units: Units,
    settings: &Settings,
    output: Output,
    cancel: &Cancel,
) -> Result<Answer, ApiError> {
    let t = Instant::now();
    let part = load(&upload, units)?;
    let load_s = t.elapsed().as_secs_f64();
    let hooks = Hooks {
        progress: None,
        cancel: Some(cancel),
    };
    let mut study =
        moldgate::study_with(&part, settings, &hooks).map_err(|e| ApiError::study(&e))?;
    study.set_input(
        Input {
            path: None,
            sample: None,
            bytes: upload.bytes.len() as u64,
        },
        load_s,
    );
    drop(upload.bytes);
    let report = study.report();
    if let (None, Some(reason)) = (&report.gate, &report.no_gate_reason) {
        let mut e = ApiError::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            "no_gate",
            // The reason says it ("no node qualifies for a gate: ...").
            moldgate::study::keyword_words(reason, "true"),
        );
        e.report = serde_json::to_value(report.in_keyword_words("true")).ok();
        return Err(e);
    }
    let fail = |e: moldgate::StudyError| ApiError::study(&e);
    Ok(match output {
        Output::Json => Answer::Json(study.report_json_in_keywords("true").map_err(fail)?),
        Output::Png => Answer::Png(study.png(&part, upload.title).map_err(fail)?),
        Output::Glb => Answer::Glb(study.glb(&part, upload.title).map_err(fail)?),
        Output::Html => {
            let png = study.png(&part, upload.title).map_err(fail)?;
            Answer::Html(study.html_in_keywords(Some(&png), "true").map_err(fail)?)
        }
    })
}

/// The validated settings of an options part's object and the query's option pairs (an
/// option in both is refused), within the server's `max_nodes` (which a request that does
/// not give its own takes when it is below the options' default).
fn settings(
    mut object: Map<String, Value>,
    pairs: Vec<(String, String)>,
    max_nodes: usize,
) -> Result<Settings, ApiError> {
    for (k, v) in options_object(pairs)? {
        if object.contains_key(&k) {
            return Err(ApiError::options(format!(
                "{k} is given both in the query and in the options part"
            ))
            .at(k));
        }
        object.insert(k, v);
    }
    // A request that does not ask for a grid size gets the server's: the options' default
    // (the command line's) may be above it.
    let asked_nodes = object.contains_key("max_nodes");
    let mut options = study_options(object)?;
    if !asked_nodes {
        options.max_nodes = options.max_nodes.min(max_nodes);
    }
    if options.max_nodes > max_nodes {
        return Err(ApiError::options(format!(
            "max_nodes must be at most {max_nodes} on this server (its operator sets it: moldgate serve --max-nodes), got {}",
            options.max_nodes
        ))
        .at("max_nodes"));
    }
    options.validate().map_err(|e| ApiError::study(&e))
}

/// One request counted among those whose body is being received, until dropped.
struct Receiving<'a>(&'a AtomicUsize);

impl<'a> Receiving<'a> {
    fn new(count: &'a AtomicUsize) -> Self {
        count.fetch_add(1, Ordering::Relaxed);
        Receiving(count)
    }
}

impl Drop for Receiving<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

/// `POST /v1/study`.
pub async fn handler(State(app): State<Arc<App>>, req: Request) -> Response {
    match handle(app, req).await {
        Ok(a) => a.into_response(),
        Err(e) => e.into_response(),
    }
}

async fn handle(app: Arc<App>, req: Request) -> Result<Answer, ApiError> {
    let limits = &app.limits;
    // A study is admitted once its body is read, so that a slow upload holds no place; a
    // request that finds every place taken as it arrives is refused before a byte of its
    // body is read.
    let busy = |app: &App| {
        let (running, waiting) = app.busy();
        ApiError::busy(format!(
            "the server is busy: {running} {} running and {waiting} waiting, as many as it takes (--analyses {}, --queue {}); try again later",
            if running == 1 { "study" } else { "studies" },
            limits.analyses,
            limits.queue
        ))
    };
    if app.admitted.available_permits() == 0 {
        return Err(busy(&app));
    }
    let declared = body::check_length(req.headers(), limits.max_upload)?;
    let (controls, pairs) = parse_query(req.uri().query().unwrap_or(""))?;
    let counter = req
        .extensions()
        .get::<BytesIn>()
        .cloned()
        .unwrap_or_default();
    let boundary = multipart_boundary(req.headers())?;
    // A plain body's format and options are checked before a byte of it is read.
    let early = match &boundary {
        None => Some((
            plain_format(controls.format.as_deref(), req.headers())?,
            settings(Map::new(), pairs.clone(), limits.max_nodes)?,
        )),
        Some(_) => None,
    };
    let (_, body) = req.into_parts();
    let budget = (&app.uploads, App::upload_budget(limits), &app.receiving);
    let (bytes, held) = {
        // Counted while it is read, however the reading ends (a client gone drops it).
        let _receiving = Receiving::new(&app.receiving);
        body::read(
            body,
            declared,
            (limits.max_upload, limits.read_timeout),
            budget,
            &counter,
        )
        .await?
    };
    let admitted = app
        .admitted
        .clone()
        .try_acquire_owned()
        .map_err(|_| busy(&app))?;
    let (upload, settings) = match (boundary, early) {
        (Some(boundary), _) => {
            let (upload, object) = multipart(bytes, boundary, controls.format.as_deref()).await?;
            (upload, settings(object, pairs, limits.max_nodes)?)
        }
        (None, Some((format, settings))) => {
            let upload = Upload {
                bytes,
                format,
                title: "uploaded part".into(),
            };
            (upload, settings)
        }
        (None, None) => return Err(ApiError::internal("no options for a plain body")),
    };
    if upload.bytes.is_empty() {
        return Err(ApiError::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            "mesh",
            "the mesh is empty",
        )
        .at("body"));
    }

    let deadline = tokio::time::Instant::now() + limits.timeout;
    let timed_out = || {
        ApiError::new(
            StatusCode::GATEWAY_TIMEOUT,
            "timeout",
            format!(
                "the study did not finish within {} s (--timeout); it stops within a step of the fill analysis (a step of its cells, a facet of its walls, a march), a facet of the wall map or a block of triangles of the gate's rays, or at the end of any other step it is in, and its analysis slot is free then",
                limits.timeout.as_secs_f64()
            ),
        )
    };
    // A study that waits for a slot past the time limit never starts: said so.
    let never_started = || {
        ApiError::new(
            StatusCode::GATEWAY_TIMEOUT,
            "timeout",
            format!(
                "the study waited {} s (--timeout) for an analysis slot and did not start: the server's {} (--analyses) {} taken by other studies all that time; try again later",
                limits.timeout.as_secs_f64(),
                match limits.analyses {
                    1 => "one slot".to_string(),
                    n => format!("{n} slots"),
                },
                if limits.analyses == 1 { "was" } else { "were" }
            ),
        )
    };
    let running = tokio::time::timeout_at(deadline, app.running.clone().acquire_owned())
        .await
        .map_err(|_| never_started())?
        .map_err(|_| ApiError::internal("the service is shutting down"))?;
    let cancel = Cancel::new();
    let flag = cancel.clone();
    // Whether the study was stopped for its client's going (else for its time): set before
    // its token, read by its last line.
    let hung_up = Arc::new(AtomicBool::new(false));
    let stopped_why = hung_up.clone();
    // The client that hangs up drops this future, and with it the wait below: the guard
    // stops the study then, so that nobody's study holds a slot and its memory to the end
    // (a study of minutes, past --timeout). Once the wait has ended it stops nothing.
    let mut hang_up = StopOnDrop {
        cancel: Some(cancel.clone()),
        hung_up,
    };
    let units = controls.units;
    let output = controls.output;
    let task = tokio::task::spawn_blocking(move || {
        // The permits (and the body's bytes) live until the study really ends, even after
        // a 504 was answered.
        let _permits = (admitted, running, held);
        let started = Instant::now();
        let result = guarded(|| work(upload, units, &settings, output, &flag));
        // After its 504, or its client's going, how long the study held its slot, and
        // where it stopped.
        if flag.is_cancelled() {
            let how = match &result {
                Ok(_) => "finished".to_string(),
                // Where it stopped, without the answer's words for a client that waited.
                Err(e) if e.kind == "timeout" => e
                    .message
                    .strip_prefix("the study took longer than the time limit and was ")
                    .unwrap_or(&e.message)
                    .to_string(),
                Err(e) => e.message.clone(),
            };
            let whose = match stopped_why.load(Ordering::Relaxed) {
                true => "a study whose client hung up",
                false => "a study past --timeout",
            };
            eprintln!(
                "moldgate: {whose} ended {:.2} s after it started: {how}",
                started.elapsed().as_secs_f64()
            );
        }
        result
    });
    let waited = tokio::time::timeout_at(deadline, task).await;
    hang_up.cancel = None;
    match waited {
        Ok(Ok(result)) => result,
        Ok(Err(join)) => Err(ApiError::internal(format!("the study failed: {join}"))),
        Err(_) => {
            cancel.cancel();
            Err(timed_out())
        }
    }
}

/// Stops a study when the request's future is dropped while it waits for the study (its
/// client hung up), setting `hung_up` first; `cancel` is taken away once the wait ended.
struct StopOnDrop {
    cancel: Option<Cancel>,
    hung_up: Arc<AtomicBool>,
}

impl Drop for StopOnDrop {
    fn drop(&mut self) {
        if let Some(cancel) = self.cancel.take() {
            self.hung_up.store(true, Ordering::Relaxed);
            cancel.cancel();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_text_is_decoded_as_the_form_decoding_reads_it() {
        // Every query the form decoding reads as UTF-8 passes; one that is not is refused
        // by its parameter.
        assert!(parse_query("demold=%2By&material=P%C3%A9").is_ok());
        let Err(e) = parse_query("gates=2&demold=%C3") else {
            panic!("a value that is not UTF-8 was read");
        };
        assert_eq!(e.place.as_deref(), Some("demold"));
    }

    #[test]
    fn a_panic_in_a_study_is_a_500_internal_error() {
        let e = guarded::<()>(|| panic!("boom")).unwrap_err();
        assert_eq!(e.status, StatusCode::INTERNAL_SERVER_ERROR);
        assert_eq!(e.kind, "internal");
        assert!(e.message.contains("boom"));
        assert!(guarded(|| Ok(3)).is_ok_and(|v| v == 3));
    }

    fn pairs(q: &[(&str, &str)]) -> Vec<(String, String)> {
        q.iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn query_pairs_become_typed_options() {
        let o = options_object(pairs(&[
            ("gates", "2"),
            ("fill", "true"),
            ("demold", "-1,0,0"),
            ("material", "ABS"),
            ("keep_out", "sphere:0,0,0,1"),
            ("keep_out", "box:0,0,0,1,1,1"),
            ("gate_radius", "1.5"),
            ("cosmetic", "-z"),
            ("gate_at", "10,0,5"),
            ("gate_at", "-3,2,1e1"),
        ]))
        .unwrap();
        let o = study_options(o).unwrap();
        assert_eq!(o.gate_at, ["10,0,5", "-3,2,1e1"]);
        assert_eq!(o.gates, 2);
        assert!(o.fill);
        assert_eq!(o.demold, "-1,0,0");
        assert_eq!(o.keep_out.len(), 2);
        assert_eq!(o.gate_radius, Some(1.5));
        assert_eq!(o.cosmetic.as_deref(), Some("-z"));
        // Text fields stay text even when they read as numbers.
        let o = study_options(options_object(pairs(&[("demold", "1")])).unwrap()).unwrap();
        assert_eq!(o.demold, "1");
        let e = study_options(options_object(pairs(&[("spacing", "wide")])).unwrap()).unwrap_err();
        assert_eq!(e.place.as_deref(), Some("spacing"));
        // Numbers no double holds are said to be so, not refused as text.
        for (k, v) in [("n", "1e400"), ("gate_radius", "NaN"), ("spacing", "-inf")] {
            let e = options_object(pairs(&[(k, v)])).unwrap_err();
            assert_eq!(e.place.as_deref(), Some(k));
            assert_eq!(e.message, format!("{k} must be a finite number, got {v}"));
        }
        // A text option keeps such text as text (a material may be named anything).
        let o = options_object(pairs(&[("material", "inf")])).unwrap();
        assert_eq!(o["material"], "inf");
    }
}
