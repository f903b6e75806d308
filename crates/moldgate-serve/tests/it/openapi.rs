//! The OpenAPI document is true: its operations are exactly the router's routes, each route
//! answers, and its examples and the service's real answers validate against its schemas
//! (a validator of the JSON Schema subset the document uses: type, required, properties,
//! items, enum, const, additionalProperties, $ref).

use std::collections::BTreeSet;

use axum::body::Body;
use axum::http::{Request, StatusCode};
use http_body_util::BodyExt;
use moldgate_serve::{Limits, OPENAPI, ROUTES};
use serde_json::Value;
use tower::ServiceExt;

fn doc() -> Value {
    serde_json::from_str(OPENAPI).expect("the document is JSON")
}

fn resolve<'a>(doc: &'a Value, schema: &'a Value) -> &'a Value {
    match schema.get("$ref").and_then(Value::as_str) {
        Some(r) => {
            let name = r
                .strip_prefix("#/components/schemas/")
                .expect("a local $ref");
            &doc["components"]["schemas"][name]
        }
        None => schema,
    }
}

fn type_matches(t: &str, v: &Value) -> bool {
    match t {
        "object" => v.is_object(),
        "array" => v.is_array(),
        "string" => v.is_string(),
        "integer" => v.is_i64() || v.is_u64(),
        "number" => v.is_number(),
        "boolean" => v.is_boolean(),
        "null" => v.is_null(),
        _ => panic!("unknown type {t}"),
    }
}

/// The problems of `v` against `schema`, with their JSON path.
fn validate(doc: &Value, schema: &Value, v: &Value, path: &str, out: &mut Vec<String>) {
    let schema = resolve(doc, schema);
    match schema.get("type") {
        Some(Value::String(t)) if !type_matches(t, v) => {
            out.push(format!("{path}: {v} is not {t}"));
            return;
        }
        Some(Value::Array(ts)) if !ts.iter().any(|t| type_matches(t.as_str().unwrap(), v)) => {
            out.push(format!("{path}: {v} is none of {ts:?}"));
            return;
        }
        _ => {}
    }
    if let Some(e) = schema.get("enum").and_then(Value::as_array) {
        if !e.contains(v) {
            out.push(format!("{path}: {v} is not one of {e:?}"));
        }
    }
    if let Some(c) = schema.get("const") {
        if c != v {
            out.push(format!("{path}: {v} is not {c}"));
        }
    }
    if let Some(obj) = v.as_object() {
        for r in schema
            .get("required")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            if !obj.contains_key(r.as_str().unwrap()) {
                out.push(format!("{path}: missing {r}"));
            }
        }
        let props = schema.get("properties").and_then(Value::as_object);
        for (k, x) in obj {
            match props.and_then(|p| p.get(k)) {
                Some(s) => validate(doc, s, x, &format!("{path}.{k}"), out),
                None if schema.get("additionalProperties") == Some(&Value::Bool(false)) => {
                    out.push(format!("{path}: unexpected {k}"))
                }
                None => {}
            }
        }
    }
    if let (Some(items), Some(list)) = (schema.get("items"), v.as_array()) {
        for (i, x) in list.iter().enumerate() {
            validate(doc, items, x, &format!("{path}[{i}]"), out);
        }
    }
}

fn assert_valid(doc: &Value, schema: &Value, v: &Value, what: &str) {
    let mut problems = Vec::new();
    validate(doc, schema, v, "$", &mut problems);
    assert!(problems.is_empty(), "{what}: {problems:#?}");
}

async fn call(method: &str, uri: &str, content_type: &str, body: Vec<u8>) -> (StatusCode, Value) {
    let app = moldgate_serve::router(Limits::default(), None);
    let req = Request::builder()
        .method(method)
        .uri(uri)
        .header("content-type", content_type)
        .body(Body::from(body))
        .unwrap();
    let res = app.oneshot(req).await.unwrap();
    let status = res.status();
    let bytes = res.into_body().collect().await.unwrap().to_bytes();
    let v = serde_json::from_slice(&bytes).unwrap_or(Value::Null);
    (status, v)
}

#[test]
fn the_documents_operations_are_the_routers_routes() {
    let doc = doc();
    assert_eq!(doc["openapi"], "3.1.0");
    let documented: BTreeSet<(String, String)> = doc["paths"]
        .as_object()
        .unwrap()
        .iter()
        .flat_map(|(path, ops)| {
            ops.as_object()
                .unwrap()
                .keys()
                .map(move |m| (m.clone(), path.clone()))
        })
        .collect();
    let routed: BTreeSet<(String, String)> = ROUTES
        .iter()
        .map(|r| (r.method.to_string(), r.path.to_string()))
        .collect();
    assert_eq!(documented, routed);
}

#[tokio::test]
async fn every_route_answers_and_its_answers_validate() {
    let doc = doc();
    for route in ROUTES {
        let uri = route.path.replace("{name}", "cover");
        let op = &doc["paths"][route.path][route.method];
        let (status, body) = match route.method {
            "get" => call("GET", &uri, "", Vec::new()).await,
            _ => {
                let mut stl = Vec::new();
                moldgate::samples::sample("plate")
                    .unwrap()
                    .write_stl(&mut stl)
                    .unwrap();
                call("POST", &uri, "model/stl", stl).await
            }
        };
        assert_eq!(status, StatusCode::OK, "{} {uri}", route.method);
        let content = &op["responses"]["200"]["content"];
        if let Some(json) = content.get("application/json") {
            assert_valid(&doc, &json["schema"], &body, &uri);
        }
    }
}

#[tokio::test]
async fn error_answers_validate() {
    let doc = doc();
    let study = &doc["paths"]["/v1/study"]["post"]["responses"];
    let cases = [
        ("/v1/study?colour=red", "model/stl", b"x".to_vec(), "400"),
        ("/v1/study", "text/csv", b"x".to_vec(), "415"),
        (
            "/v1/study",
            "model/stl",
            b"solid\nfacet x\n".to_vec(),
            "422",
        ),
    ];
    for (uri, ct, body, code) in cases {
        let (status, v) = call("POST", uri, ct, body).await;
        assert_eq!(status.as_str(), code, "{uri}: {v}");
        let schema = &study[code]["content"]["application/json"]["schema"];
        assert_valid(&doc, schema, &v, uri);
    }
    let (status, v) = call("GET", "/v1/samples/nope", "", Vec::new()).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let schema = &doc["paths"]["/v1/samples/{name}"]["get"]["responses"]["404"]["content"]
        ["application/json"]["schema"];
    assert_valid(&doc, schema, &v, "unknown sample");
}

#[test]
fn the_documents_examples_validate() {
    let doc = doc();
    let mut seen = 0;
    for (name, schema) in doc["components"]["schemas"].as_object().unwrap() {
        for example in schema
            .get("examples")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            assert_valid(&doc, schema, example, name);
            seen += 1;
        }
    }
    assert!(seen >= 2);
}

#[test]
fn every_study_option_is_a_documented_parameter() {
    let doc = doc();
    let params: BTreeSet<String> = doc["paths"]["/v1/study"]["post"]["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    let options = serde_json::to_value(moldgate::StudyOptions::default()).unwrap();
    let mut fields: BTreeSet<String> = options.as_object().unwrap().keys().cloned().collect();
    fields.extend(["format", "output", "units"].map(String::from));
    assert_eq!(params, fields);
}

/// `GET /v1/materials` lists the whole library a study takes (not only the paper's Table 1),
/// each entry as `moldgate materials --json` gives it.
#[tokio::test]
async fn the_materials_are_the_whole_library_with_their_sources() {
    let (status, body) = call("GET", "/v1/materials", "", Vec::new()).await;
    assert_eq!(status, StatusCode::OK);
    // Through text, as the answer came (serde_json's parse of a float may differ from the
    // float by its last bit).
    let listing = serde_json::to_string(&moldgate::material::Listing::builtin()).unwrap();
    assert_eq!(body, serde_json::from_str::<Value>(&listing).unwrap());
    let names: Vec<&str> = body["materials"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names.len(), moldgate::material::library().len());
    assert_eq!(names[..3], ["PP", "ABS", "PC"]);
    assert!(names.contains(&"PA66-GF30"), "{names:?}");
    let pe = &body["materials"][names.iter().position(|&n| n == "PE-HD").unwrap()];
    assert!(pe["aliases"].as_array().unwrap().contains(&"HDPE".into()));
    assert_eq!(body["materials"][0]["sources"]["n"], "the paper, Table 1");
}
