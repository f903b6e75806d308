//! Inputs that are not regular files, and outputs that must touch nothing but the file asked
//! for: FIFOs and folders named like meshes, device and FIFO outputs, symbolic links,
//! temporary files under planted links, and temporary files left by a killed run.
#![cfg(unix)]

use std::os::unix::fs::{symlink, FileTypeExt};
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant, SystemTime};

use crate::common::*;

const TEMP_PREFIX: &str = ".moldgate-tmp-";

fn mkfifo(path: &Path) {
    let status = Command::new("mkfifo")
        .arg(path)
        .status()
        .expect("mkfifo runs");
    assert!(status.success(), "mkfifo {}", path.display());
}

fn spawn(dir: &Path, args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_moldgate"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the moldgate binary runs")
}

/// Waits for `child` at most `limit`; kills it and fails the test if it is still running.
fn finish_within(mut child: Child, limit: Duration, what: &str) -> std::process::Output {
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn sample(dir: &Path, name: &str, file: &str) {
    let out = moldgate(dir, &["sample", name, "-o", file]);
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
}

fn temporaries(dir: &Path) -> Vec<String> {
    listing(dir)
        .into_iter()
        .filter(|n| n.starts_with(TEMP_PREFIX))
        .collect()
}

#[test]
fn fifo_input_is_refused_without_waiting() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("part.stl"));
    let child = spawn(dir.path(), &["locate", "part.stl"]);
    let out = finish_within(child, Duration::from_secs(60), "locate on a FIFO");
    assert_eq!(out.status.code(), Some(INPUT));
    assert!(
        stderr(&out).contains("part.stl: is a FIFO, not a mesh file"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_fifo_or_device_as_a_materials_file_or_manifest_is_refused_without_reading() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("pipe.toml"));
    for (args, said) in [
        (
            &[
                "locate",
                "--sample",
                "plate",
                "--materials-file",
                "pipe.toml",
            ][..],
            "pipe.toml: is a FIFO, not a TOML file",
        ),
        (
            &["locate", "--manifest", "pipe.toml"],
            "pipe.toml: is a FIFO, not a TOML file",
        ),
        // Endless zeros: refused by what the file is, not read until memory runs out.
        (
            &[
                "locate",
                "--sample",
                "plate",
                "--materials-file",
                "/dev/zero",
            ],
            "/dev/zero: is a character device, not a TOML file",
        ),
        (
            &["materials", "--materials-file", "/dev/zero"],
            "/dev/zero: is a character device, not a TOML file",
        ),
    ] {
        let child = spawn(dir.path(), args);
        let out = finish_within(child, Duration::from_secs(60), said);
        assert_eq!(out.status.code(), Some(INPUT), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).contains(said), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn a_materials_file_over_its_size_limit_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    // A sparse file of 3 GiB: its size, not its bytes, refuses it.
    let big = std::fs::File::create(dir.path().join("big.toml")).unwrap();
    big.set_len(3 << 30).unwrap();
    let out = moldgate(
        dir.path(),
        &[
            "locate",
            "--sample",
            "plate",
            "--materials-file",
            "big.toml",
        ],
    );
    assert_fails(
        &out,
        INPUT,
        &["big.toml: is over the limit of 1 MiB for a TOML file (3 GiB)"],
    );
}

#[test]
fn fifo_input_in_a_batch_fails_its_row_and_the_summary_is_written() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "good.stl");
    mkfifo(&dir.path().join("pipe.stl"));
    let child = spawn(
        dir.path(),
        &["locate", "pipe.stl", "good.stl", "--summary", "s.jsonl"],
    );
    let out = finish_within(child, Duration::from_secs(120), "a batch with a FIFO");
    assert_eq!(out.status.code(), Some(INPUT), "{}", stderr(&out));
    let summary = std::fs::read_to_string(dir.path().join("s.jsonl")).unwrap();
    let rows: Vec<serde_json::Value> = summary
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0]["status"], "input_error");
    assert_eq!(rows[0]["error"], "is a FIFO, not a mesh file");
    assert_eq!(rows[1]["status"], "ok");
}

#[test]
fn folder_entries_that_are_not_regular_files_are_skipped_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let parts = dir.path().join("parts");
    std::fs::create_dir(&parts).unwrap();
    sample(&parts, "plate", "a.stl");
    mkfifo(&parts.join("b.stl"));
    std::fs::create_dir(parts.join("c.stl")).unwrap();
    symlink("nowhere.stl", parts.join("d.ply")).unwrap();
    symlink("a.stl", parts.join("e.stl")).unwrap(); // a link to a file is a part
    let child = spawn(dir.path(), &["locate", "parts", "--summary", "s.csv"]);
    let out = finish_within(child, Duration::from_secs(120), "a folder with a FIFO");
    // Skipped entries do not change the exit code.
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    let err = stderr(&out);
    for line in [
        "moldgate: skipped parts/b.stl: is a FIFO, not a mesh file",
        "moldgate: skipped parts/c.stl: is a folder, not a mesh file",
        "moldgate: skipped parts/d.ply: is a symbolic link that points nowhere",
    ] {
        assert!(err.contains(line), "{line} not in {err}");
    }
    assert!(
        stdout(&out).contains("2 parts: 2 with a gate, 0 without, 0 failed, 3 skipped"),
        "{}",
        stdout(&out)
    );
    let csv = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    let statuses: Vec<(&str, &str)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let mut f = l.split(',');
            (f.next().unwrap(), f.next().unwrap())
        })
        .collect();
    assert_eq!(
        statuses,
        [
            ("parts/a.stl", "ok"),
            ("parts/b.stl", "skipped"),
            ("parts/c.stl", "skipped"),
            ("parts/d.ply", "skipped"),
            ("parts/e.stl", "ok"),
        ]
    );
}

#[test]
fn folder_of_only_special_entries_is_an_error_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    mkfifo(&dir.path().join("b.stl"));
    let child = spawn(dir.path(), &["locate", "."]);
    let out = finish_within(child, Duration::from_secs(60), "a folder of a FIFO");
    assert_eq!(out.status.code(), Some(INPUT));
    assert!(
        stderr(&out).contains("holding no .stl, .obj or .ply file (skipped: ./b.stl is a FIFO"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn output_to_dev_null_writes_into_it_and_keeps_the_device() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    for args in [
        &["locate", "part.stl", "-o", "/dev/null"][..],
        &["locate", "part.stl", "--glb", "/dev/null"][..],
    ] {
        let out = moldgate(dir.path(), args);
        assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
        let m = std::fs::symlink_metadata("/dev/null").unwrap();
        assert!(m.file_type().is_char_device(), "/dev/null was replaced");
    }
    let out = moldgate(dir.path(), &["sample", "plate", "-o", "/dev/null"]);
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    assert!(std::fs::symlink_metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());
}

#[test]
fn output_to_dev_stdout_is_streamed() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    let out = moldgate(
        dir.path(),
        &["locate", "part.stl", "--json", "-o", "/dev/stdout"],
    );
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("\"schema_version\""), "{text}");
}

#[test]
fn output_to_a_fifo_is_streamed_into_it() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    let fifo = dir.path().join("out.json");
    mkfifo(&fifo);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    let child = spawn(dir.path(), &["locate", "part.stl", "-o", "out.json"]);
    let out = finish_within(child, Duration::from_secs(60), "-o FIFO");
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    let bytes = reader.join().unwrap();
    let report: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
    assert!(report["gate"].is_object());
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn output_through_a_symlink_replaces_its_target_and_keeps_the_link() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    let elsewhere = dir.path().join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("report.json"), "old").unwrap();
    symlink("elsewhere/report.json", dir.path().join("out.json")).unwrap();
    let out = moldgate(dir.path(), &["locate", "part.stl", "-o", "out.json"]);
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    let link = std::fs::symlink_metadata(dir.path().join("out.json")).unwrap();
    assert!(link.file_type().is_symlink(), "the link was replaced");
    let text = std::fs::read_to_string(elsewhere.join("report.json")).unwrap();
    assert!(text.contains("\"schema_version\""));
    assert!(temporaries(dir.path()).is_empty() && temporaries(&elsewhere).is_empty());
}

/// A file that is there keeps its permissions when it is replaced, and one this user may
/// not write is not replaced (the rename needs only the folder's permission): as a
/// shell's `>` would.
#[test]
fn an_output_file_keeps_its_permissions_and_a_read_only_one_is_refused() {
    use std::os::unix::fs::PermissionsExt;
    let test = "an_output_file_keeps_its_permissions_and_a_read_only_one_is_refused";
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    let mode = |p: &Path, m: u32| std::fs::set_permissions(p, std::fs::Permissions::from_mode(m));
    let mode_of = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    // A private file stays private.
    let private = dir.path().join("private.json");
    std::fs::write(&private, "old").unwrap();
    mode(&private, 0o600).unwrap();
    let out = moldgate(dir.path(), &["locate", "part.stl", "-o", "private.json"]);
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    assert!(std::fs::read_to_string(&private)
        .unwrap()
        .contains("schema_version"));
    assert_eq!(mode_of(&private), 0o600);
    // A read-only file in a folder anyone may write: not replaced. Permissions do not stop
    // the superuser, so as root the binary runs as `nobody` through setpriv.
    mode(dir.path(), 0o777).unwrap();
    mode(&dir.path().join("part.stl"), 0o644).unwrap();
    let locked = dir.path().join("locked.json");
    std::fs::write(&locked, "keep").unwrap();
    mode(&locked, 0o444).unwrap();
    let args = [
        "locate",
        "part.stl",
        "-o",
        "locked.json",
        "--png",
        "locked.png",
    ];
    let root = std::fs::OpenOptions::new()
        .write(true)
        .open(&locked)
        .is_ok();
    let out = if !root {
        moldgate(dir.path(), &args)
    } else {
        let Some(out) = moldgate_as_nobody(dir.path(), &args, test) else {
            return;
        };
        out
    };
    assert_eq!(out.status.code(), Some(OUTPUT), "{}", stderr(&out));
    assert!(
        stderr(&out).contains(
            "locked.json: cannot write: the file is there and this user may not write it"
        ),
        "{}",
        stderr(&out)
    );
    assert_eq!(std::fs::read_to_string(&locked).unwrap(), "keep");
    assert_eq!(mode_of(&locked), 0o444);
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn output_to_a_dangling_symlink_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    symlink("missing/report.json", dir.path().join("out.json")).unwrap();
    let out = moldgate(dir.path(), &["locate", "part.stl", "-o", "out.json"]);
    assert_eq!(out.status.code(), Some(OUTPUT));
    assert!(
        stderr(&out).contains("out.json: cannot write: it is a symbolic link that points nowhere"),
        "{}",
        stderr(&out)
    );
}

/// Plants links at the temporary names the command used to take (`.NAME.PID.tmp`,
/// `.moldgate-probe.PID.tmp`) as soon as the process exists, and checks that the file they
/// point to is untouched.
#[test]
fn temporary_files_never_follow_a_planted_link() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    let victim = dir.path().join("victim.txt");
    std::fs::write(&victim, "precious").unwrap();
    let outs = dir.path().join("outs");
    std::fs::create_dir(&outs).unwrap();
    for args in [
        &["locate", "part.stl", "-o", "out.json"][..],
        &[
            "locate",
            "part.stl",
            "--out-dir",
            "outs",
            "--summary",
            "outs/s.csv",
        ][..],
    ] {
        let child = spawn(dir.path(), args);
        let pid = child.id();
        for (folder, name) in [
            (dir.path(), format!(".out.json.{pid}.tmp")),
            (outs.as_path(), format!(".moldgate-probe.{pid}.tmp")),
            (outs.as_path(), format!(".part.json.{pid}.tmp")),
            (outs.as_path(), format!(".s.csv.{pid}.tmp")),
        ] {
            let _ = symlink(&victim, folder.join(name));
        }
        let out = finish_within(child, Duration::from_secs(60), "locate");
        assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious");
    }
    assert!(std::fs::read_to_string(dir.path().join("out.json"))
        .unwrap()
        .contains("\"gate\""));
    assert!(outs.join("part.json").is_file());
}

#[test]
fn stale_temporary_files_are_swept_by_the_next_write() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    let old = SystemTime::now() - Duration::from_secs(2 * 3600);
    let age = |name: &str, when: SystemTime| {
        let f = std::fs::File::options()
            .write(true)
            .open(dir.path().join(name))
            .unwrap();
        f.set_modified(when).unwrap();
    };
    // Names of the command's own make (12 random letters or digits), and one of the prefix
    // that it does not make, which is left alone however old.
    for name in [
        ".moldgate-tmp-oldAAAAAAAAA",
        ".moldgate-tmp-freshAAAAAAA",
        ".other-old.tmp",
        ".moldgate-tmp-users-own",
    ] {
        std::fs::write(dir.path().join(name), "x").unwrap();
    }
    age(".moldgate-tmp-oldAAAAAAAAA", old);
    age(".other-old.tmp", old);
    age(".moldgate-tmp-users-own", old);
    // A link of the prefix is never followed nor removed, whatever its target's age.
    std::fs::write(dir.path().join("victim"), "precious").unwrap();
    age("victim", old);
    symlink("victim", dir.path().join(".moldgate-tmp-link")).unwrap();
    let out = moldgate(dir.path(), &["locate", "part.stl", "-o", "out.json"]);
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    assert_eq!(
        temporaries(dir.path()),
        [
            ".moldgate-tmp-freshAAAAAAA",
            ".moldgate-tmp-link",
            ".moldgate-tmp-users-own"
        ]
    );
    assert!(dir.path().join(".other-old.tmp").exists());
    assert_eq!(
        std::fs::read_to_string(dir.path().join("victim")).unwrap(),
        "precious"
    );
}

/// A real kill during a large write: the GLB of a part of half a million triangles, the
/// signal sent as soon as the temporary file appears. SIGINT, SIGTERM and SIGHUP each
/// remove it and end the process as the signal would.
#[test]
fn killed_during_a_large_write_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = moldgate::samples::sample("cover")
        .unwrap()
        .subdivided()
        .subdivided()
        .subdivided();
    let mut stl = Vec::new();
    mesh.write_stl(&mut stl).unwrap();
    std::fs::write(dir.path().join("big.stl"), stl).unwrap();
    for signal in [libc::SIGTERM, libc::SIGINT, libc::SIGHUP] {
        let mut landed = false;
        for _try in 0..6 {
            let mut child = spawn(dir.path(), &["locate", "big.stl", "--glb", "big.glb"]);
            let mut seen = false;
            while child.try_wait().unwrap().is_none() {
                if !temporaries(dir.path()).is_empty() {
                    seen = true;
                    // SAFETY: kill(2) on the pid of our own child.
                    unsafe { libc::kill(child.id() as i32, signal) };
                    break;
                }
                std::thread::sleep(Duration::from_micros(200));
            }
            let status = child.wait().unwrap();
            assert!(
                temporaries(dir.path()).is_empty(),
                "signal {signal}: left {:?}",
                temporaries(dir.path())
            );
            if seen && status.signal() == Some(signal) {
                landed = true;
                break;
            }
        }
        assert!(
            landed,
            "signal {signal}: no kill landed during the write in 6 tries"
        );
        let _ = std::fs::remove_file(dir.path().join("big.glb"));
    }
}

/// A manifest and a materials file are inputs too: no output is written over them, by
/// any name or link, and they are left as they were.
#[test]
fn no_output_is_written_over_a_manifest_or_a_materials_file() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    let manifest = "[[part]]\nfile = \"part.stl\"\n";
    std::fs::write(dir.path().join("m.toml"), manifest).unwrap();
    // A manifest is read whatever its name: one named as a summary may be given as one.
    std::fs::write(dir.path().join("m.csv"), manifest).unwrap();
    symlink("m.toml", dir.path().join("link.jsonl")).unwrap();
    for (read, summary) in [("m.csv", "m.csv"), ("m.toml", "link.jsonl")] {
        let out = moldgate(
            dir.path(),
            &["locate", "--manifest", read, "--summary", summary],
        );
        assert_eq!(out.status.code(), Some(OUTPUT), "{}", stderr(&out));
        assert!(
            stderr(&out).contains("refusing to write the output over an input file"),
            "{}",
            stderr(&out)
        );
        assert_eq!(
            std::fs::read_to_string(dir.path().join("m.toml")).unwrap(),
            manifest
        );
    }
    let materials =
        "[MyPP]\nn = 0.3\nt_melt = 230\nt_wall = 40\ngamma_opt = 1000\nmu_opt = 200\nk = 0.15\n";
    std::fs::write(dir.path().join("mats.toml"), materials).unwrap();
    symlink("mats.toml", dir.path().join("mats.png")).unwrap();
    for args in [&["-o", "mats.toml"][..], &["--png", "mats.png"][..]] {
        let all = [
            &["locate", "part.stl", "--materials-file", "mats.toml"][..],
            args,
        ]
        .concat();
        let out = moldgate(dir.path(), &all);
        assert_eq!(
            out.status.code(),
            Some(OUTPUT),
            "{args:?}: {}",
            stderr(&out)
        );
        assert_eq!(
            std::fs::read_to_string(dir.path().join("mats.toml")).unwrap(),
            materials
        );
    }
    assert!(temporaries(dir.path()).is_empty());
}

/// A file name with a line break prints as one line: a part named to look like a message
/// of its own cannot make one.
#[test]
fn a_name_with_a_line_break_prints_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("in")).unwrap();
    std::fs::write(
        dir.path().join("in").join("bad\nmoldgate: error: fake.stl"),
        b"junk",
    )
    .unwrap();
    let out = moldgate(dir.path(), &["locate", "in"]);
    assert_eq!(out.status.code(), Some(INPUT), "{}", stderr(&out));
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("moldgate: error: in/bad\\nmoldgate: error: fake.stl: "),
        "{err}"
    );
}

/// A link another user made in a sticky folder all may write (as /tmp) is not followed: it
/// may have been planted to lead an output over someone's file. One of this user's is.
#[test]
fn a_link_planted_by_another_user_in_a_shared_folder_is_not_followed() {
    use std::os::unix::fs::{lchown, MetadataExt, PermissionsExt};
    let test = "a_link_planted_by_another_user_in_a_shared_folder_is_not_followed";
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "part.stl");
    let shared = dir.path().join("shared");
    std::fs::create_dir(&shared).unwrap();
    std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o1777)).unwrap();
    std::fs::write(dir.path().join("important.conf"), "keep").unwrap();
    let link = shared.join("report.json");
    symlink("../important.conf", &link).unwrap();
    let me = std::fs::symlink_metadata(&link).unwrap().uid();
    // Another user's link: only the superuser can give a link away.
    let other = if me == 65534 { 65533 } else { 65534 };
    if lchown(&link, Some(other), None).is_err() {
        let why = "not running as root, so no link of another user can be made";
        eprintln!("{test}: skipped: {why}");
        println!("{test}: skipped: {why}");
        return;
    }
    let out = moldgate(
        dir.path(),
        &["locate", "part.stl", "-o", "shared/report.json"],
    );
    assert_eq!(out.status.code(), Some(OUTPUT), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("a symbolic link another user made"),
        "{}",
        stderr(&out)
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("important.conf")).unwrap(),
        "keep"
    );
    // This user's own link is followed.
    lchown(&link, Some(me), None).unwrap();
    let out = moldgate(
        dir.path(),
        &["locate", "part.stl", "-o", "shared/report.json"],
    );
    assert_eq!(out.status.code(), Some(OK), "{}", stderr(&out));
    assert!(std::fs::read_to_string(dir.path().join("important.conf"))
        .unwrap()
        .contains("schema_version"));
}

/// A hard link to an input is that input: a batch whose report would go over one is refused
/// before any part is studied (no other report written), and so is a single part's output.
#[test]
fn an_output_hard_linked_to_an_input_is_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    sample(dir.path(), "plate", "a.stl");
    sample(dir.path(), "cap", "b.stl");
    std::fs::create_dir(dir.path().join("out")).unwrap();
    std::fs::hard_link(dir.path().join("a.stl"), dir.path().join("out/a.json")).unwrap();
    let before = std::fs::read(dir.path().join("a.stl")).unwrap();
    let out = moldgate(
        dir.path(),
        &["locate", "a.stl", "b.stl", "--out-dir", "out"],
    );
    assert_eq!(out.status.code(), Some(OUTPUT), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("out/a.json: refusing to write the output over an input file"),
        "{}",
        stderr(&out)
    );
    assert!(
        !dir.path().join("out/b.json").exists(),
        "no part was studied"
    );
    std::fs::hard_link(dir.path().join("a.stl"), dir.path().join("a.json")).unwrap();
    let out = moldgate(dir.path(), &["locate", "a.stl", "-o", "a.json"]);
    assert_eq!(out.status.code(), Some(OUTPUT), "{}", stderr(&out));
    assert!(stderr(&out).contains("refusing to write the output over the input file"));
    assert_eq!(std::fs::read(dir.path().join("a.stl")).unwrap(), before);
}

/// A file name that is not UTF-8 is named byte for byte in messages, the batch's table and
/// the picture's title, not with a replacement character that makes two names alike.
#[test]
fn names_that_are_not_utf8_are_shown_byte_for_byte() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let bad = OsStr::from_bytes(b"bad\xe9.stl");
    std::fs::write(dir.path().join(bad), "xx").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_moldgate"))
        .arg("locate")
        .arg(bad)
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let err = assert_fails(&out, INPUT, &["bad\\xe9.stl: this is a short text file"]);
    assert!(!err.contains('\u{fffd}'), "{err}");
    // A good part beside it: the batch names both, each by its own bytes.
    sample(dir.path(), "cover", "cover.stl");
    std::fs::rename(
        dir.path().join("cover.stl"),
        dir.path().join(OsStr::from_bytes(b"caf\xe8.stl")),
    )
    .unwrap();
    let out = moldgate(dir.path(), &["locate", ".", "--demold", "+z"]);
    let table = stdout(&out);
    assert!(table.contains("caf\\xe8.stl  ok"), "{table}");
    assert!(stderr(&out).contains("bad\\xe9.stl:"), "{}", stderr(&out));
}
