//! Writing files whole or not at all, never over the input and never through a planted
//! link; printing results on stdout.

use std::io::{ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, SystemTime};

use crate::Failure;

/// Refuses an output path that names the input file (also through links or `..`).
pub fn refuse_input(output: &Path, input: Option<&Path>) -> Result<(), Failure> {
    let Some(input) = input else { return Ok(()) };
    // Through links, `..` and hard links.
    if same_file(output, input) {
        return Err(Failure::output(format!(
            "{}: refusing to write the output over the input file",
            moldgate::files::shown(&output)
        )));
    }
    Ok(())
}

/// The files read as inputs (meshes, manifests, materials files), by device and inode:
/// [`write_atomic`] refuses to write over any of them at the moment it writes, whatever
/// name or link leads there (a link planted in an output folder during the run included).
static INPUTS: Mutex<Vec<(u64, u64)>> = Mutex::new(Vec::new());

/// Records `path` (followed through links) as an input file. A path that cannot be read is
/// not recorded: it is not read either.
pub fn register_input(path: &Path) {
    #[cfg(unix)]
    if let Ok(m) = std::fs::metadata(path) {
        use std::os::unix::fs::MetadataExt;
        let id = (m.dev(), m.ino());
        let mut inputs = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
        if !inputs.contains(&id) {
            inputs.push(id);
        }
    }
    #[cfg(not(unix))]
    let _ = path;
}

/// Whether `path` (followed through links) is a file recorded by [`register_input`].
pub fn is_input(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(path).is_ok_and(|m| {
            INPUTS
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .contains(&(m.dev(), m.ino()))
        })
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        false
    }
}

/// Whether two paths name the same file, whether or not it exists yet: two files that are
/// there by their device and inode (hard links too), else their folders compared after
/// resolving links and `..`.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let resolved = |p: &Path| {
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(dir.canonicalize().ok()?.join(p.file_name()?))
    };
    // Two names of one file (hard links) are one file too.
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return (x.dev(), x.ino()) == (y.dev(), y.ino());
        }
    }
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => match (resolved(a), resolved(b)) {
            (Some(x), Some(y)) => x == y,
            _ => a == b,
        },
    }
}

/// The prefix of every temporary file the command makes: `.moldgate-tmp-` and random
/// characters. A file of this prefix left by a run that was killed is removed by the next
/// run that writes in the same folder (see [`sweep_stale`]).
pub const TEMP_PREFIX: &str = ".moldgate-tmp-";

/// The random characters after [`TEMP_PREFIX`] in a temporary file's name.
const TEMP_RANDOM_CHARS: usize = 12;

/// Temporary files older than this are leftovers of a run that was killed.
const STALE_AFTER: Duration = Duration::from_secs(3600);

/// The temporary files being written, removed by [`remove_temporaries`] when a signal ends
/// the process.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Folders already swept of stale temporary files by this process.
static SWEPT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Writes `bytes` to `path`, whole or not at all where the file system allows it:
///
/// - a new file or a regular file: through an exclusively created temporary file of
///   unpredictable name in the same folder ([`TEMP_PREFIX`]), then a rename, so the file is
///   either the old one or the complete new one; a file that is there is replaced only if
///   this user may write it (a read-only file is refused, as a shell's `>` refuses it),
///   and the new one keeps its permissions;
/// - a symbolic link: the same, in the folder of the file it finally points to, which is
///   replaced while the link stays (a link to a special file writes into that file; a link
///   that points nowhere is refused, and so is one another user made in a sticky folder
///   all may write, which may have been planted);
/// - a FIFO or a character device (`/dev/null`, `/dev/stdout`, a terminal): opened and
///   written into as a stream, never replaced;
/// - a folder, a block device or a socket: refused.
///
/// The temporary file is flushed to the disk (`fsync`) before the rename, so that after a
/// power cut or a crash of the system the file is the old one or the complete new one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    let fail = |e: &dyn std::fmt::Display| {
        Failure::output(format!(
            "{}: cannot write: {e}",
            moldgate::files::shown(&path)
        ))
    };
    let target = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == ErrorKind::NotFound => path.to_path_buf(),
        Err(e) => return Err(fail(&e)),
        Ok(m) if m.file_type().is_symlink() && planted(path, &m) => {
            return Err(fail(&"it is a symbolic link another user made in a folder all may write (sticky, as /tmp): not followed"))
        }
        Ok(m) if m.file_type().is_symlink() => match std::fs::metadata(path) {
            Err(e) if e.kind() == ErrorKind::NotFound => {
                return Err(fail(&"it is a symbolic link that points nowhere"))
            }
            Err(e) => return Err(fail(&e)),
            Ok(m) if m.is_file() => path.canonicalize().map_err(|e| fail(&e))?,
            Ok(m) => return write_special(path, &m, bytes),
        },
        Ok(m) if m.is_file() => path.to_path_buf(),
        Ok(m) => return write_special(path, &m, bytes),
    };
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if target.file_name().is_none() {
        return Err(Failure::output(format!(
            "{}: not a file name",
            moldgate::files::shown(&path)
        )));
    }
    let over_input = || {
        Failure::output(format!(
            "{}: refusing to write the output over an input file",
            moldgate::files::shown(&path)
        ))
    };
    if is_input(&target) {
        return Err(over_input());
    }
    // A file that is there is replaced only if this user may write it, as a shell's `>`
    // would (the rename needs only the folder's permission), and keeps its permissions.
    let kept_permissions = match std::fs::metadata(&target) {
        Ok(m) => {
            if let Err(e) = std::fs::OpenOptions::new().write(true).open(&target) {
                return Err(fail(&format_args!(
                    "the file is there and this user may not write it ({e}); nothing was written"
                )));
            }
            Some(m.permissions())
        }
        Err(_) => None,
    };
    sweep_stale(dir);
    // The file is written beside its target first: an error here is the folder's (a
    // read-only folder, or a file system such as /proc that makes no new files).
    let mut tmp = temporary_in(dir).map_err(|e| {
        fail(&format_args!(
            "no file can be created in its folder {} ({e})",
            moldgate::files::shown(&dir)
        ))
    })?;
    let registered = tmp.path().to_path_buf();
    let result = tmp
        .as_file_mut()
        .write_all(bytes)
        .and_then(|_| match &kept_permissions {
            Some(p) => tmp.as_file().set_permissions(p.clone()),
            None => Ok(()),
        })
        .and_then(|_| tmp.as_file().sync_all())
        .and_then(|_| {
            // Asked again at the last moment: the name may have been made an input's since.
            if is_input(&target) {
                return Err(std::io::Error::other(
                    "refusing to write the output over an input file",
                ));
            }
            tmp.persist(&target).map(drop).map_err(|e| e.error)
        });
    // On an error the temporary file is removed when `tmp` is dropped.
    release(&registered);
    result.map_err(|e| fail(&e))
}

/// Whether the symbolic link `path` (its own metadata `link`) may have been planted: it is
/// in a sticky folder that all may write (as /tmp), and neither this user nor the folder's
/// owner made it. Linux's `protected_symlinks` refuses to follow such a link for the same
/// reason; the command resolves links itself, so it asks here.
fn planted(path: &Path, link: &std::fs::Metadata) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let Ok(folder) = std::fs::metadata(dir) else {
            return false;
        };
        let shared = folder.mode() & 0o1002 == 0o1002;
        // SAFETY: geteuid has no preconditions and cannot fail.
        let me = unsafe { libc::geteuid() };
        shared && link.uid() != me && link.uid() != folder.uid()
    }
    #[cfg(not(unix))]
    {
        let _ = (path, link);
        false
    }
}

/// A new temporary file in `dir`: created exclusively (`O_EXCL`, so a link planted under
/// its name is never followed) under a random name of [`TEMP_PREFIX`]. Its name is
/// registered for removal on a signal *before* the file exists, so a signal that arrives
/// while it is being created cannot leave it behind; the caller unregisters it with
/// [`release`] once it is renamed into place or removed.
pub fn temporary_in(dir: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    tempfile::Builder::new()
        .prefix(TEMP_PREFIX)
        .rand_bytes(TEMP_RANDOM_CHARS)
        .make_in(dir, |path| {
            register(path);
            let mut open = std::fs::OpenOptions::new();
            open.write(true).create_new(true);
            // The mode `File::create` gives (0666 less the umask), not tempfile's private
            // 0600: the temporary file becomes the output.
            #[cfg(unix)]
            {
                use std::os::unix::fs::OpenOptionsExt;
                open.mode(0o666);
            }
            open.open(path).inspect_err(|_| unregister(path))
        })
}

/// Forgets a temporary file of [`temporary_in`] (renamed into place, or removed).
pub fn release(tmp: &Path) {
    unregister(tmp);
}

/// Writes into a FIFO or a character device as a stream; refuses the other special files.
fn write_special(path: &Path, m: &std::fs::Metadata, bytes: &[u8]) -> Result<(), Failure> {
    let fail = |e: &dyn std::fmt::Display| {
        Failure::output(format!(
            "{}: cannot write: {e}",
            moldgate::files::shown(&path)
        ))
    };
    let kind = moldgate::files::file_kind(m);
    if !matches!(kind, "a FIFO" | "a character device") {
        return Err(fail(&format_args!("it is {kind}, not a file")));
    }
    // Not `create`: a special file is written into, never made or truncated.
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(|e| fail(&e))?;
    match file.write_all(bytes).and_then(|_| file.flush()) {
        // A reader that has gone away (a FIFO's): the rest is simply not wanted.
        Err(e) if e.kind() == ErrorKind::BrokenPipe => Ok(()),
        r => r.map_err(|e| fail(&e)),
    }
}

fn register(tmp: &Path) {
    let mut list = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    list.push(tmp.to_path_buf());
}

fn unregister(tmp: &Path) {
    let mut list = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(i) = list.iter().position(|p| p == tmp) {
        list.swap_remove(i);
    }
}

/// Removes the temporary files being written (called when a signal ends the process; a
/// file already renamed into place is simply not found).
pub fn remove_temporaries() {
    let list = TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner());
    for p in list.iter() {
        let _ = std::fs::remove_file(p);
    }
}

/// Removes from `dir`, once per process, the temporary files that runs killed by a signal
/// they could not catch (SIGKILL, a power cut) left behind: regular files (not links) of
/// [`TEMP_PREFIX`], owned by this user, last changed more than an hour ago.
pub fn sweep_stale(dir: &Path) {
    let key = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    {
        let mut swept = SWEPT.lock().unwrap_or_else(|e| e.into_inner());
        if swept.contains(&key) {
            return;
        }
        swept.push(key);
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let now = SystemTime::now();
    for entry in entries.flatten() {
        // Only names this command makes: the prefix and 12 random letters or digits.
        let name = entry.file_name();
        let ours = name
            .to_str()
            .and_then(|n| n.strip_prefix(TEMP_PREFIX))
            .is_some_and(|rest| {
                rest.len() == TEMP_RANDOM_CHARS && rest.bytes().all(|b| b.is_ascii_alphanumeric())
            });
        if !ours {
            continue;
        }
        // `DirEntry::metadata` does not follow links.
        let Ok(m) = entry.metadata() else { continue };
        let old = m
            .modified()
            .ok()
            .and_then(|t| now.duration_since(t).ok())
            .is_some_and(|age| age > STALE_AFTER);
        if m.file_type().is_file() && owned_by_me(&m) && old {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

#[cfg(unix)]
fn owned_by_me(m: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    // SAFETY: geteuid has no preconditions and cannot fail.
    m.uid() == unsafe { libc::geteuid() }
}

#[cfg(not(unix))]
fn owned_by_me(_: &std::fs::Metadata) -> bool {
    true
}

/// Removes the temporary files being written when SIGINT, SIGTERM or SIGHUP ends the
/// process, then ends it as the signal would have (same exit status). A thread waits for
/// the signals, so the clean-up runs outside the signal handler.
#[cfg(unix)]
pub fn clean_up_on_signals() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    let spawned = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                remove_temporaries();
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                std::process::exit(128 + signal);
            }
        });
    drop(spawned);
}

#[cfg(not(unix))]
pub fn clean_up_on_signals() {}

/// Writes `text` on stdout. A reader that has gone away (`moldgate ... | head`) is not an
/// error: the rest of the output is simply not wanted.
pub fn print_stdout(text: &str) -> Result<(), Failure> {
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|_| stdout.flush())
    {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(Failure::output(format!("stdout: {e}")))
        }
        _ => Ok(()),
    }
}
