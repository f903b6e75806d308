//! The browser app's folder (`--web-dir`): its files are served, nothing through a link out
//! of it, no hidden file, and a missing one is the JSON 404 of an unknown path.

use std::path::Path;

use axum::body::Body;
use axum::http::{Request, StatusCode};
use http_body_util::BodyExt;
use moldgate_serve::Limits;
use tower::ServiceExt;

async fn get(dir: &Path, uri: &str) -> (StatusCode, Vec<u8>) {
    let app = moldgate_serve::router(Limits::default(), Some(dir));
    let req = Request::builder().uri(uri).body(Body::empty()).unwrap();
    let res = app.oneshot(req).await.unwrap();
    let status = res.status();
    (
        status,
        res.into_body().collect().await.unwrap().to_bytes().to_vec(),
    )
}

#[tokio::test]
async fn the_web_folder_serves_its_own_files_only() {
    let base = std::env::temp_dir().join(format!("moldgate-web-dir-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let web = base.join("web");
    std::fs::create_dir_all(web.join("assets")).unwrap();
    std::fs::create_dir_all(base.join("outside")).unwrap();
    std::fs::write(web.join("index.html"), "<p>app</p>").unwrap();
    std::fs::write(web.join("assets/app.js"), "let x = 1;").unwrap();
    std::fs::write(web.join(".env"), "SECRET=1").unwrap();
    std::fs::write(base.join("secret.txt"), "secret").unwrap();
    std::fs::write(base.join("outside/secret.txt"), "secret").unwrap();
    // Links out of the folder, to a file and to a folder; a link inside it is served.
    std::os::unix::fs::symlink(base.join("secret.txt"), web.join("leak.txt")).unwrap();
    std::os::unix::fs::symlink(base.join("outside"), web.join("out")).unwrap();
    std::os::unix::fs::symlink(web.join("assets/app.js"), web.join("same.js")).unwrap();
    // A FIFO in the folder: opening it would wait for a writer, holding the request.
    let fifo = web.join("fifo.txt");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success());

    for (uri, body) in [
        ("/", "<p>app</p>"),
        ("/index.html", "<p>app</p>"),
        ("/assets/app.js", "let x = 1;"),
        ("/assets%2Fapp.js", "let x = 1;"),
        ("/same.js", "let x = 1;"),
    ] {
        let (status, got) = get(&web, uri).await;
        assert_eq!(status, StatusCode::OK, "{uri}");
        assert_eq!(got, body.as_bytes(), "{uri}");
    }
    for uri in [
        "/leak.txt",
        "/out/secret.txt",
        "/.env",
        "/%2Eenv",
        "/../secret.txt",
        "/%2e%2e/secret.txt",
        "/assets/..%2F..%2Fsecret.txt",
        "/missing.js",
        "/fifo.txt",
    ] {
        if uri == "/fifo.txt" && !made {
            println!("no mkfifo here: the FIFO's case is skipped");
            continue;
        }
        let (status, got) = get(&web, uri).await;
        assert_eq!(
            status,
            StatusCode::NOT_FOUND,
            "{uri}: {}",
            String::from_utf8_lossy(&got)
        );
        let v: serde_json::Value = serde_json::from_slice(&got).unwrap_or_else(|_| panic!("{uri}"));
        assert_eq!(v["error"]["kind"], "not_found", "{uri}");
    }
    std::fs::remove_dir_all(&base).unwrap();
}
