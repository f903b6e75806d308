//! Load and memory figures of `moldgate serve`, over loopback only, bounded in count and
//! time. Starts the given binary on a free port, then measures:
//!
//! 1. throughput on the `cover` sample and on a shared part of 4,396 triangles
//!    (framework_expansion_card_shell.stl, demold +y): 16 connections, 2,000 requests each,
//!    requests/s, p50, p99, errors; against the library's own time per part
//!    (load + study, in this process) and one connection's latency, so the service's
//!    overhead is a measured figure;
//! 2. the 352k-triangle shared part (demold +y): one request against the whole command
//!    `moldgate locate FILE --demold +y --json` and the library in this process, reading
//!    in one pass and in parallel runs, interleaved, medians of 9;
//! 3. resident memory after 1,000 and after 10,000 requests (cover, 16 connections);
//! 4. a flood of 64 concurrent 100 MB uploads (a generated 2M-triangle binary STL):
//!    the answers by status, and the server's peak resident memory (sampled from /proc
//!    every 20 ms) against the bound (analyses + queue) x max upload + the studies.
//!
//! ```text
//! cargo build --release -p moldgate-cli
//! cargo run --release -p moldgate-cli --example load_serve -- target/release/moldgate [PARTS_DIR]
//! ```
//!
//! `LOAD_ONLY=throughput,large,memory,flood` runs only the phases named.

#[path = "../tests/it/common/http.rs"]
mod http;

use std::io::{BufReader, Write};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use http::{connect, head, read_response, Server};

/// Sends `total` POSTs of `body` to `path` over `conns` keep-alive connections: the
/// latencies in seconds, the count of answers that were not 200, the wall time.
fn run_load(
    addr: SocketAddr,
    path: &str,
    body: &[u8],
    conns: usize,
    total: usize,
) -> (Vec<f64>, usize, f64) {
    let next = AtomicUsize::new(0);
    let errors = AtomicUsize::new(0);
    let lat = Mutex::new(Vec::with_capacity(total));
    let t0 = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..conns {
            s.spawn(|| {
                let mut c = connect(addr);
                let mut r = BufReader::new(c.try_clone().unwrap());
                let h = head(
                    "POST",
                    path,
                    &[("content-type", "model/stl")],
                    Some(body.len()),
                );
                let mut mine = Vec::new();
                while next.fetch_add(1, Ordering::Relaxed) < total {
                    let t = Instant::now();
                    let ok = c
                        .write_all(h.as_bytes())
                        .and_then(|_| c.write_all(body))
                        .is_ok()
                        && matches!(read_response(&mut r), Ok(resp) if resp.status == 200);
                    mine.push(t.elapsed().as_secs_f64());
                    if !ok {
                        errors.fetch_add(1, Ordering::Relaxed);
                        c = connect(addr);
                        r = BufReader::new(c.try_clone().unwrap());
                    }
                }
                lat.lock().unwrap().extend(mine);
            });
        }
    });
    let wall = t0.elapsed().as_secs_f64();
    (lat.into_inner().unwrap(), errors.into_inner(), wall)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() as f64 - 1.0) * p).round() as usize]
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The library's own time for one part: load from bytes and study, median of `n`.
fn library_time(stl: &[u8], demold: &str, n: usize) -> f64 {
    let options: moldgate::StudyOptions =
        serde_json::from_value(serde_json::json!({ "demold": demold })).unwrap();
    let times = (0..n)
        .map(|_| {
            let t = Instant::now();
            let part = moldgate::mesh::read_stl(
                std::io::Cursor::new(stl),
                stl.len() as u64,
                moldgate::mesh::Units::Mm,
            )
            .unwrap();
            let s = moldgate::study(&part, &options).unwrap();
            let json = s.report_json().unwrap();
            std::hint::black_box(json.len());
            t.elapsed().as_secs_f64()
        })
        .collect();
    median(times)
}

fn throughput(server: &Server, name: &str, stl: &[u8], demold: &str) {
    let path = format!("/v1/study?demold={}", demold.replace('+', "%2B"));
    let lib = library_time(stl, demold, 30);
    let (one, _, _) = run_load(server.addr, &path, stl, 1, 100);
    let (mut lat, errors, wall) = run_load(server.addr, &path, stl, 16, 2000);
    lat.sort_by(f64::total_cmp);
    let one = median(one);
    println!(
        "| {name} | {} | {:.0} | {:.1} | {:.1} | {errors} | {:.2} | {:.2} | {:.2} |",
        lat.len(),
        lat.len() as f64 / wall,
        percentile(&lat, 0.5) * 1e3,
        percentile(&lat, 0.99) * 1e3,
        lib * 1e3,
        one * 1e3,
        (one - lib) * 1e3,
    );
}

/// The library in this process on the bytes of a file (demold +y): load, study, JSON; read
/// in one pass (`read_stl`) or, as the service and the command line read, in parallel runs
/// (`read_stl_reopen`).
fn library_once(stl: &[u8], parallel: bool) -> f64 {
    let options: moldgate::StudyOptions =
        serde_json::from_value(serde_json::json!({ "demold": "+y" })).unwrap();
    let t = Instant::now();
    let len = stl.len() as u64;
    let units = moldgate::mesh::Units::Mm;
    let part = if parallel {
        moldgate::mesh::read_stl_reopen(|| Ok(std::io::Cursor::new(stl)), len, units)
    } else {
        moldgate::mesh::read_stl(std::io::Cursor::new(stl), len, units)
    }
    .unwrap();
    let json = moldgate::study(&part, &options)
        .unwrap()
        .report_json()
        .unwrap();
    std::hint::black_box(json.len());
    t.elapsed().as_secs_f64()
}

/// The server's own time for its last request, ms, from its log line ("... 812.3ms").
fn last_logged_ms(server: &Server) -> f64 {
    let log = server.log.lock().unwrap();
    log.iter()
        .rev()
        .find_map(|l| {
            l.strip_prefix("moldgate: POST /v1/study 200 ")?
                .rsplit(' ')
                .next()
        })
        .and_then(|ms| ms.strip_suffix("ms")?.parse().ok())
        .unwrap_or(f64::NAN)
}

/// The 352k part, 9 rounds, each running in turn (so a phase of the machine touches all
/// alike): one request, the whole command, the library reading in one pass and in
/// parallel runs. Medians, and the server's own time (its log line: from the request's head
/// to its answer, upload included).
fn large_part(server: &Server, binary: &str, file: &Path) {
    let stl = std::fs::read(file).unwrap();
    let path = "/v1/study?demold=%2By";
    let (mut service, mut logged, mut cli, mut one_pass, mut runs) =
        (vec![], vec![], vec![], vec![], vec![]);
    for _ in 0..9 {
        let (l, e, _) = run_load(server.addr, path, &stl, 1, 1);
        assert_eq!(e, 0);
        service.push(l[0]);
        std::thread::sleep(Duration::from_millis(50));
        logged.push(last_logged_ms(server) / 1e3);
        let t = Instant::now();
        let out = std::process::Command::new(binary)
            .args(["locate", file.to_str().unwrap(), "--demold", "+y", "--json"])
            .output()
            .unwrap();
        assert!(out.status.success());
        cli.push(t.elapsed().as_secs_f64());
        one_pass.push(library_once(&stl, false));
        runs.push(library_once(&stl, true));
    }
    println!(
        "352k part (medians of 9, interleaved): one request (upload + study + answer) {:.0} ms, of which the server's own {:.0} ms; the whole command `locate --demold +y --json` {:.0} ms; the library in this process on the bytes (load + study + JSON) {:.0} ms reading in parallel runs, {:.0} ms in one pass",
        median(service) * 1e3,
        median(logged) * 1e3,
        median(cli) * 1e3,
        median(runs) * 1e3,
        median(one_pass) * 1e3,
    );
}

fn memory(server: &Server, stl: &[u8]) {
    let path = "/v1/study";
    let (_, e1, _) = run_load(server.addr, path, stl, 16, 1000);
    let after_1k = server.rss_kib();
    let (_, e2, _) = run_load(server.addr, path, stl, 16, 9000);
    let after_10k = server.rss_kib();
    println!(
        "resident memory after 1,000 requests: {:.1} MiB; after 10,000: {:.1} MiB ({:+.1} %); errors {}",
        after_1k as f64 / 1024.0,
        after_10k as f64 / 1024.0,
        (after_10k as f64 / after_1k as f64 - 1.0) * 100.0,
        e1 + e2
    );
}

/// A binary STL of at most `bytes` bytes: a flat grid of triangles (an open sheet).
fn big_stl(bytes: usize) -> Vec<u8> {
    let n = (bytes - 84) / 50;
    let side = ((n / 2) as f64).sqrt() as usize + 1;
    let mut out = Vec::with_capacity(84 + 50 * n);
    out.extend_from_slice(&[0u8; 80]);
    out.extend_from_slice(&(n as u32).to_le_bytes());
    for t in 0..n {
        let (cell, half) = (t / 2, t % 2);
        let (x, y) = ((cell / side) as f32 * 0.1, (cell % side) as f32 * 0.1);
        let c: [[f32; 3]; 3] = if half == 0 {
            [[x, y, 0.0], [x + 0.1, y, 0.0], [x + 0.1, y + 0.1, 0.0]]
        } else {
            [[x, y, 0.0], [x + 0.1, y + 0.1, 0.0], [x, y + 0.1, 0.0]]
        };
        for v in [[0.0f32, 0.0, 1.0]].iter().chain(c.iter()) {
            for f in v {
                out.extend_from_slice(&f.to_le_bytes());
            }
        }
        out.extend_from_slice(&[0, 0]);
    }
    out
}

fn rss_of(pid: u32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    s.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
}

fn flood(binary: &str) {
    let (analyses, queue) = (2, 16);
    let server = Server::start(
        binary,
        &[
            "--analyses",
            &analyses.to_string(),
            "--queue",
            &queue.to_string(),
            "--timeout",
            "120",
            "--read-timeout",
            "120",
        ],
    );
    let body = big_stl(100_000_000);
    let base = server.rss_kib();
    let peak = Arc::new(AtomicU64::new(base));
    let done = Arc::new(AtomicBool::new(false));
    let pid = server.child.id();
    let sampler = {
        let (peak, done) = (peak.clone(), done.clone());
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                if let Some(kib) = rss_of(pid) {
                    peak.fetch_max(kib, Ordering::Relaxed);
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        })
    };
    let t = Instant::now();
    let statuses = Mutex::new(std::collections::BTreeMap::<String, usize>::new());
    std::thread::scope(|s| {
        for _ in 0..64 {
            s.spawn(|| {
                let mut c = connect(server.addr);
                c.set_read_timeout(Some(Duration::from_secs(300))).unwrap();
                let h = head(
                    "POST",
                    "/v1/study",
                    &[("content-type", "model/stl")],
                    Some(body.len()),
                );
                let sent = c.write_all(h.as_bytes()).is_ok()
                    && body.chunks(1 << 20).all(|chunk| c.write_all(chunk).is_ok());
                let status = match read_response(&mut BufReader::new(c)) {
                    Ok(r) if r.status == 200 => "200".to_string(),
                    Ok(r) => format!("{} {}", r.status, r.kind()),
                    Err(_) if !sent => "closed by the server while sending".into(),
                    Err(e) => format!("no answer: {e}"),
                };
                *statuses.lock().unwrap().entry(status).or_default() += 1;
            });
        }
    });
    done.store(true, Ordering::Relaxed);
    sampler.join().unwrap();
    let after = server.rss_kib();
    let mib = |k: u64| k as f64 / 1024.0;
    println!(
        "flood of 64 x {:.1} MB uploads ({:.1} s): answers {:?}",
        body.len() as f64 / 1e6,
        t.elapsed().as_secs_f64(),
        statuses.into_inner().unwrap()
    );
    println!(
        "  resident memory: {:.0} MiB before, peak {:.0} MiB, {:.0} MiB after; bound (analyses + queue) x max upload = {} x 100 MiB = {} MiB, plus the running studies' meshes",
        mib(base),
        mib(peak.load(Ordering::Relaxed)),
        mib(after),
        analyses + queue,
        (analyses + queue) * 100
    );
    let alive = http::get(server.addr, "/healthz");
    println!("  /healthz after the flood: {}", alive.status);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let binary = args
        .get(1)
        .cloned()
        .unwrap_or_else(|| "target/release/moldgate".into());
    let parts = args
        .get(2)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../shared/data/parts"));
    let only = std::env::var("LOAD_ONLY").unwrap_or_default();
    let want = |phase: &str| only.is_empty() || only.split(',').any(|p| p == phase);

    let server = Server::start(&binary, &[]);
    let cover = http::get(server.addr, "/v1/samples/cover").body;
    if want("throughput") {
        println!("| part | requests | requests/s | p50 ms | p99 ms | errors | library ms/part | 1 connection ms | overhead ms |");
        println!("|---|---|---|---|---|---|---|---|---|");
        throughput(&server, "cover (2,044 triangles)", &cover, "+z");
        let card = parts.join("framework_expansion_card_shell.stl");
        match std::fs::read(&card) {
            Ok(stl) => throughput(
                &server,
                "framework_expansion_card_shell (4,396 triangles, +y)",
                &stl,
                "+y",
            ),
            Err(e) => println!("skipped the shared part: {}: {e}", card.display()),
        }
    }
    if want("large") {
        let big = parts.join("esp32s3box_bottom_housing_352k.stl");
        if big.is_file() {
            large_part(&server, &binary, &big);
        } else {
            println!("skipped the 352k part: {} is missing", big.display());
        }
    }
    if want("memory") {
        memory(&server, &cover);
    }
    drop(server);
    if want("flood") {
        flood(&binary);
    }
}
