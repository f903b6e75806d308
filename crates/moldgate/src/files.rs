//! Reading the files a user names, for every front end that reads them (the command line,
//! the Python package): only regular files, a FIFO or a device named as a mesh or a TOML
//! file would block the run or read forever; and text files only up to a size checked
//! before they are read.
//!
//! The analysis itself reads nothing (every reader of [`crate::mesh`] takes a reader):
//! these are the front ends' shared first step.

use std::fs::{File, OpenOptions};
use std::io::{BufReader, Read};
use std::path::Path;

use crate::mesh::{self, LoadedMesh, Units};

/// The largest TOML file read by [`read_toml_text`] for a batch manifest (one of the
/// command line's 100,000 parts, about 100 bytes a part, is about half of it).
pub const MAX_TOML_BYTES: u64 = 16 << 20;

/// The largest materials file ([`crate::material::materials_from_toml`], the command line's
/// `--materials-file`, Python's `materials_file`, the browser app's upload): its 1000
/// materials at most of a few hundred bytes each take a third of it. Parsing a TOML text
/// may take up to [`TOML_MEMORY_PER_BYTE`] times its size, so a hostile file of this size
/// takes under 100 MB.
pub const MAX_MATERIALS_BYTES: u64 = 1 << 20;

/// The most memory parsing a TOML text may take, per byte of the text: the shapes measured
/// to take the most are an array of 8 million one-digit numbers, 16 MiB of text and a peak
/// of 1.27 GB (76 times), and arrays of empty arrays or tables (66 times); tables of a
/// key each take 37 times.
pub const TOML_MEMORY_PER_BYTE: u64 = 80;

/// What a file is, for messages: "a regular file", "a folder", "a FIFO", ...
pub fn file_kind(m: &std::fs::Metadata) -> &'static str {
    let t = m.file_type();
    if t.is_file() {
        return "a regular file";
    }
    if t.is_dir() {
        return "a folder";
    }
    if t.is_symlink() {
        return "a symbolic link";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// A path as messages and reports show it: bytes that are not UTF-8 as `\xe9` (a
/// replacement character would make `caf\xe9.stl` and `caf\xe8.stl` read alike) and
/// control characters escaped (a newline in a name would break a message's line), as
/// [`crate::error::excerpt`] shows the bytes inside a file.
pub fn shown(path: &(impl AsRef<Path> + ?Sized)) -> String {
    let path = path.as_ref();
    #[cfg(unix)]
    let bytes = std::os::unix::ffi::OsStrExt::as_bytes(path.as_os_str());
    #[cfg(not(unix))]
    let lossy = path.to_string_lossy();
    #[cfg(not(unix))]
    let bytes = lossy.as_bytes();
    let mut out = String::with_capacity(bytes.len());
    for chunk in bytes.utf8_chunks() {
        for c in chunk.valid().chars() {
            if c.is_control() {
                out.extend(c.escape_default());
            } else {
                out.push(c);
            }
        }
        for b in chunk.invalid() {
            out += &format!("\\x{b:02x}");
        }
    }
    out
}

/// Opens `path` for reading when it is a regular file (following links); the error says what
/// it is otherwise, with `noun` ("is a FIFO, not a mesh file"). The kind is checked before
/// opening, and the file is opened without blocking (`O_NONBLOCK`) and checked again, so a
/// FIFO put in its place between the two cannot hang the run.
pub fn open_regular(path: &Path, noun: &str) -> Result<File, String> {
    let not_one = |m: &std::fs::Metadata| format!("is {}, not {noun}", file_kind(m));
    let m = std::fs::metadata(path).map_err(|e| format!("cannot open: {e}"))?;
    if !m.is_file() {
        return Err(not_one(&m));
    }
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options
        .open(path)
        .map_err(|e| format!("cannot open: {e}"))?;
    let m = file.metadata().map_err(|e| format!("cannot read: {e}"))?;
    if !m.is_file() {
        return Err(not_one(&m));
    }
    Ok(file)
}

/// A size in bytes for messages: `16 MiB`, `3.0 GiB`, `512 bytes`.
pub(crate) fn size_text(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = "bytes";
    for u in UNITS {
        if value < 1024.0 {
            break;
        }
        value /= 1024.0;
        unit = u;
    }
    match unit {
        "bytes" => format!("{bytes} bytes"),
        _ if value.fract() == 0.0 => format!("{value} {unit}"),
        _ => format!("{value:.1} {unit}"),
    }
}

/// Why [`read_text`] gave no text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TextError {
    /// The file cannot be read: missing, not a regular file, over the limit, a read error.
    Unreadable(String),
    /// It was read, but is not UTF-8 text from this byte on (on this line, from 1).
    NotUtf8 {
        /// The line of the first byte that is not UTF-8.
        line: usize,
        /// Its offset in the file.
        byte: usize,
    },
}

impl std::fmt::Display for TextError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TextError::Unreadable(why) => f.write_str(why),
            TextError::NotUtf8 { line, byte } => {
                write!(f, "line {line}: not UTF-8 text (byte {byte} of the file)")
            }
        }
    }
}

/// The text of the regular file `path` (`noun` names what it should be, for messages), at
/// most `limit` bytes: a larger file is refused by its size before it is read, and one that
/// grows past the limit while it is read (or reports no size, as the files of `/proc` do)
/// when it passes it. Text that is not UTF-8 is refused with the byte and line where it
/// stops being so.
pub fn read_text(path: &Path, noun: &str, limit: u64) -> Result<String, TextError> {
    let file = open_regular(path, noun).map_err(TextError::Unreadable)?;
    let len = file
        .metadata()
        .map_err(|e| TextError::Unreadable(format!("cannot read: {e}")))?
        .len();
    let over = || format!("is over the limit of {} for {noun}", size_text(limit));
    if len > limit {
        return Err(TextError::Unreadable(format!(
            "{} ({})",
            over(),
            size_text(len)
        )));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| TextError::Unreadable(format!("cannot read: {e}")))?;
    if bytes.len() as u64 > limit {
        return Err(TextError::Unreadable(over()));
    }
    String::from_utf8(bytes).map_err(|e| {
        let byte = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..byte].iter().filter(|&&b| b == b'\n').count();
        TextError::NotUtf8 { line, byte }
    })
}

/// The text of the TOML file `path` ([`read_text`] with `limit`, as "a TOML file"), refused
/// before it is read when parsing it could take more memory than this process may use
/// ([`TOML_MEMORY_PER_BYTE`] times its size, against [`memory_limit`]).
pub fn read_toml_text(path: &Path, limit: u64) -> Result<String, TextError> {
    let noun = "a TOML file";
    if let Ok(len) = std::fs::metadata(path).map(|m| m.len()) {
        if len <= limit {
            check_memory_of(
                len,
                (TOML_MEMORY_PER_BYTE, noun),
                "a smaller file",
                memory_limit(),
            )
            .map_err(TextError::Unreadable)?;
        }
    }
    read_text(path, noun, limit)
}

/// A TOML parser's error as the front ends say it: `line N: what` (the line of the error's
/// first byte, from 1), without the parser's own excerpt of the text, and with a value's
/// type in plain words (`expected a number`, not `expected f64`).
pub fn toml_message(text: &str, e: &toml::de::Error) -> String {
    bounded(toml_message_whole(text, e))
}

/// The longest text a message quotes of a value, in characters.
const QUOTED_CHARS: usize = 60;

/// `message` with each quoted text (between double quotes) longer than [`QUOTED_CHARS`]
/// cut to its start and its length: a value of megabytes is not copied into a message.
fn bounded(message: String) -> String {
    let parts: Vec<&str> = message.split('"').collect();
    if parts
        .iter()
        .skip(1)
        .step_by(2)
        .all(|q| q.chars().count() <= QUOTED_CHARS)
    {
        return message;
    }
    parts
        .iter()
        .enumerate()
        .map(|(i, part)| {
            let n = part.chars().count();
            if i % 2 == 1 && n > QUOTED_CHARS && i + 1 < parts.len() {
                let start: String = part.chars().take(QUOTED_CHARS).collect();
                format!("{start}... ({n} characters)")
            } else {
                part.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\"")
}

fn toml_message_whole(text: &str, e: &toml::de::Error) -> String {
    let mut what = plain_words(e.message().trim_end_matches('.'));
    let Some(span) = e.span().filter(|s| text.get(s.start..s.end).is_some()) else {
        return what;
    };
    let line_no = 1 + text[..span.start].matches('\n').count();
    let line_start = text[..span.start].rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next().unwrap_or_default().trim();
    let value = &text[span.start..span.end];
    // What serde calls a table, named as the TOML that made it: a date (a table to
    // serde), a dotted key, a list of tables.
    let is_date = |v: &str| {
        let b = v.as_bytes();
        (b.len() >= 10 && b[..4].iter().all(u8::is_ascii_digit) && b[4] == b'-')
            || (b.len() >= 5 && b[..2].iter().all(u8::is_ascii_digit) && b[2] == b':')
    };
    let mut key = key_before(text, span.start).map(str::to_string);
    // A key whose value is missing from its line: the parser reads on (a bare word, or the
    // next line as a key of its own), and says so in its words.
    const NO_VALUE: &str = "no value after `=` (a value goes on its key's own line)";
    let rest_of_line = text[span.start..].lines().next().unwrap_or_default().trim();
    if key.is_some() && (rest_of_line.is_empty() || rest_of_line.starts_with('#')) {
        return format!("line {line_no}: {}: {NO_VALUE}", key.unwrap_or_default());
    }
    if what.starts_with("key with no value") {
        let before = &text[..line_start];
        let previous = before
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
            .last();
        if let Some((i, key)) = previous.and_then(|(i, l)| Some((i, assigned_key(l)?))) {
            return format!("line {}: {key}: {NO_VALUE}", i + 1);
        }
    }
    // A value a person wrote as a number in another way: a decimal comma (`20,5`), or a
    // word left bare; the parser's words ("expected newline", "string values must be
    // quoted") say what it expected, not what was wrong.
    if let Some((k, raw)) = line.split_once('=') {
        let (k, raw) = (k.trim(), raw.split('#').next().unwrap_or_default().trim());
        let digits = |t: &str| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
        let decimal_comma = raw
            .trim_start_matches(['-', '+'])
            .split_once(',')
            .is_some_and(|(a, b)| digits(a) && digits(b));
        if decimal_comma {
            return format!(
                "line {line_no}: {k}: {raw} is not a number: write a decimal point ({})",
                raw.replace(',', ".")
            );
        }
        if what.starts_with("string values must be quoted") {
            return format!(
                "line {line_no}: {k}: {raw} is neither a number nor quoted text (numbers as 230 or 0.32; a name in quotes)"
            );
        }
    }
    // The error's line as a table's header: its name, and whether it opens a list of
    // tables (`[[X]]`) or one (`[X]`).
    let header = match line.strip_prefix("[[").and_then(|l| l.strip_suffix("]]")) {
        Some(inner) => Some((inner.trim(), true)),
        None => line
            .strip_prefix('[')
            .and_then(|l| l.strip_suffix(']'))
            .map(|inner| (inner.trim(), false)),
    };
    if is_date(value) {
        what = what.replace("got a table", "got a date");
    } else if let (Some((inner, true)), false) = (header, what.starts_with("missing field")) {
        key.get_or_insert_with(|| inner.to_string());
        what = format!("got a list of tables ([[{inner}]]), expected one table ([{inner}])");
    } else if let (Some((inner, false)), true) = (header, what.contains("expected a sequence")) {
        key.get_or_insert_with(|| inner.to_string());
        what = what.replace(
            "expected a sequence",
            &format!("expected a list of tables ([[{inner}]])"),
        );
    } else if key.is_none() {
        // `gamma_opt.value = 1000`: the dotted key makes gamma_opt a table.
        let bare = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        let first: String = text[span.start..]
            .chars()
            .take_while(|&c| bare(c))
            .collect();
        if !first.is_empty() && text[span.start + first.len()..].starts_with('.') {
            if what.contains("got a table") {
                what = format!("{what} (a dotted key, {first}.…, makes a table)");
            }
            key = Some(first);
        } else if what.starts_with("duplicate key") && !first.is_empty() {
            // The key given twice: the error is at its second place.
            key = Some(first);
        } else if let Some((inner, false)) = header {
            // A table's own fault (a field missing): the table by its name.
            key = Some(inner.trim_matches('"').to_string());
        }
    }
    // A number in quotes is text to TOML.
    if let Some(quoted) = what
        .strip_prefix("got the text \"")
        .and_then(|rest| rest.split_once("\", expected a number"))
        .map(|(q, _)| q.to_string())
        .filter(|q| q.trim().parse::<f64>().is_ok())
    {
        what = format!("{what} (a number goes without quotes: {})", quoted.trim());
    }
    match key {
        Some(key) => format!("line {line_no}: {key}: {what}"),
        None => format!("line {line_no}: {what}"),
    }
}

/// The key whose value starts at byte `at` of a TOML text (`k` of `k = "hot"` or of
/// `{ n = 1, k = "hot" }`), if the text before it on its line ends in `key =`.
fn key_before(text: &str, at: usize) -> Option<&str> {
    let before = text.get(..at)?;
    assigned_key(&before[before.rfind('\n').map_or(0, |i| i + 1)..])
}

/// The key of a line's text that ends in `key =`: a whole key, bare (`t_melt`, `a.b`) or
/// quoted without a quote inside, at the line's start or after an inline table's `{` or
/// `,`. Not a key: text inside a string that ends in `=` (`a = "b =`).
fn assigned_key(line: &str) -> Option<&str> {
    let head = line.trim_end().strip_suffix('=')?.trim_end();
    let is_key = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | '"');
    let start = head
        .char_indices()
        .rev()
        .find(|&(_, c)| !is_key(c))
        .map_or(0, |(i, c)| i + c.len_utf8());
    let raw = &head[start..];
    let whole_before = head[..start].trim_end();
    let opens =
        whole_before.is_empty() || whole_before.ends_with('{') || whole_before.ends_with(',');
    let quoted = raw.starts_with('"') || raw.ends_with('"');
    let well_quoted = !quoted
        || (raw.len() >= 2
            && raw.starts_with('"')
            && raw.ends_with('"')
            && !raw[1..raw.len() - 1].contains('"'));
    let key = raw.trim_matches('"');
    (opens && well_quoted && !key.is_empty()).then_some(key)
}

/// serde's words for a value's type as a person says them (the study options' JSON and
/// the TOML files alike).
pub(crate) fn plain_words(message: &str) -> String {
    let mut m = message.to_string();
    for (rust, plain) in [
        ("expected usize", "expected a whole number of 0 or more"),
        ("expected u64", "expected a whole number of 0 or more"),
        ("expected u32", "expected a whole number of 0 or more"),
        ("expected u16", "expected a whole number of 0 or more"),
        ("expected f64", "expected a number"),
        ("expected path string", "expected a file path in quotes"),
        // A whole number beyond 64 bits, which serde names by its type.
        ("` as i128,", "`,"),
        ("` as u128,", "`,"),
        ("expected f32", "expected a number"),
        ("expected i64", "expected a whole number"),
        (
            "expected struct Material",
            "expected a table of a material's parameters ([NAME], then n, t_melt, t_wall, gamma_opt, mu_opt, k)",
        ),
        (
            "data did not match any variant of untagged enum MaterialChoice",
            "expected a material name or a table of its parameters (n, t_melt, t_wall, gamma_opt, mu_opt, k)",
        ),
    ] {
        m = m.replace(rust, plain);
    }
    got_words(&m)
}

/// serde's "invalid type: floating point `1e23`, expected ..." as "got 1e23 (not a whole
/// number as written), expected ...": what was given, in the words a person uses for it.
fn got_words(message: &str) -> String {
    // serde's words for what it got, each before ", expected": (its prefix, ours, and
    // whether the value follows between backticks or quotes).
    const GOT: [(&str, &str); 8] = [
        ("invalid type: floating point `", "got the decimal number "),
        ("invalid value: integer `", "got "),
        ("invalid type: integer `", "got the number "),
        ("invalid type: boolean `", "got "),
        ("invalid type: string \"", "got the text \""),
        ("invalid type: null", "got no value (null)"),
        ("invalid type: map", "got a table"),
        ("invalid type: sequence", "got a list"),
    ];
    let Some((prefix, ours)) = GOT.iter().find(|(p, _)| message.contains(p)) else {
        return message.to_string();
    };
    let start = message.find(prefix).expect("found above");
    let after = &message[start + prefix.len()..];
    let (value, rest) = match prefix.chars().last() {
        // The value runs to its closing backtick (a string's quote is kept in ours).
        Some('`') => match after.find('`') {
            Some(end) => (&after[..end], &after[end + 1..]),
            None => return message.to_string(),
        },
        Some('"') => match after.find("\", expected") {
            Some(end) => (&after[..=end], &after[end + 1..]),
            None => return message.to_string(),
        },
        _ => ("", after),
    };
    format!("{}{ours}{value}{rest}", &message[..start])
}

/// A mesh reader, by the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshKind {
    /// Binary or ASCII STL (also the choice for an unknown extension).
    Stl,
    /// Wavefront OBJ.
    Obj,
    /// PLY, ASCII or binary.
    Ply,
}

/// The reader for `path`: `.obj` and `.ply` (any case) by name, STL otherwise.
pub fn mesh_kind(path: &Path) -> MeshKind {
    let ext = path.extension().unwrap_or_default();
    if ext.eq_ignore_ascii_case("obj") {
        MeshKind::Obj
    } else if ext.eq_ignore_ascii_case("ply") {
        MeshKind::Ply
    } else {
        MeshKind::Stl
    }
}

/// The most memory reading a mesh file may take, in bytes per byte of the file, from the
/// files measured to take the most: binary STL 127 bytes a 50-byte facet (2.5 times the
/// file); an OBJ of small fans 14 times the file (bare vertex lines about 3 times); binary
/// PLY, whose records are the smallest, taken as twice STL's.
fn memory_per_file_byte(kind: MeshKind) -> u64 {
    match kind {
        MeshKind::Stl => 3,
        MeshKind::Obj => 16,
        MeshKind::Ply => 8,
    }
}

/// Refuses a file whose reading could take more memory than `limit` bytes (when known)
/// before a byte of it is read: [`memory_per_file_byte`] times its size.
fn check_memory(kind: MeshKind, len: u64, limit: Option<u64>) -> Result<(), String> {
    check_memory_of(
        len,
        (memory_per_file_byte(kind), "this format"),
        "a coarser mesh",
        limit,
    )
}

/// Refuses a file of `len` bytes that may take `per_byte` times its size to read (`what`
/// names its kind in the message, `advice` what to use instead) when that is more than
/// `limit` bytes (when known).
fn check_memory_of(
    len: u64,
    (per_byte, what): (u64, &str),
    advice: &str,
    limit: Option<u64>,
) -> Result<(), String> {
    let need = len.saturating_mul(per_byte);
    match limit {
        Some(limit) if need > limit => {
            let gib = |b: u64| b as f64 / f64::from(1u32 << 30);
            Err(format!(
                "a file of {:.1} MiB may take up to {:.1} GiB of memory to read ({per_byte} times its size for {what}), more than the {:.1} GiB this process may use (the memory available, or its limit): use a machine with more memory or {advice}",
                len as f64 / f64::from(1u32 << 20),
                gib(need),
                gib(limit)
            ))
        }
        _ => Ok(()),
    }
}

/// The memory this process may still take, in bytes, when the system says (Linux): the
/// least of the memory available (`MemAvailable`), the process's soft limits on its address
/// space and data (`ulimit -v`, `ulimit -d`, from `/proc/self/limits`) and its control
/// group's limit less its use (cgroup v2). The limits on address space and data are less
/// what the process has mapped already (`VmSize`, `VmData`: its threads' stacks and the
/// allocator's arenas count against them before a byte is used).
pub fn memory_limit() -> Option<u64> {
    let mut least: Option<u64> = None;
    let mut take = |v: u64| least = Some(least.map_or(v, |l| l.min(v)));
    let read = |path: &str| std::fs::read_to_string(path).ok();
    if let Some(text) = read("/proc/meminfo") {
        if let Some(kib) = text
            .lines()
            .find_map(|l| l.strip_prefix("MemAvailable:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        {
            take(kib.saturating_mul(1024));
        }
    }
    if let Some(text) = read("/proc/self/limits") {
        // What the process has mapped already counts against its limits on address space
        // and data (its threads' stacks and allocator arenas are reserved, not used, yet
        // count): the room left is the limit less that.
        let status = read("/proc/self/status").unwrap_or_default();
        let mapped = |field: &str| {
            status
                .lines()
                .find_map(|l| l.strip_prefix(field))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
                .map_or(0, |kib| kib.saturating_mul(1024))
        };
        for (name, field) in [
            ("Max address space", "VmSize:"),
            ("Max data size", "VmData:"),
        ] {
            // "Max address space   4096000000   unlimited   bytes": the soft limit.
            if let Some(soft) = text
                .lines()
                .find_map(|l| l.strip_prefix(name))
                .and_then(|rest| rest.split_whitespace().next())
                .and_then(|v| v.parse::<u64>().ok())
            {
                take(soft.saturating_sub(mapped(field)));
            }
        }
    }
    if let (Some(max), Some(current)) = (
        read("/sys/fs/cgroup/memory.max").and_then(|t| t.trim().parse::<u64>().ok()),
        read("/sys/fs/cgroup/memory.current").and_then(|t| t.trim().parse::<u64>().ok()),
    ) {
        take(max.saturating_sub(current));
    }
    least
}

/// Reads the mesh file `path` (STL, OBJ or PLY by its extension; STL for any other) in
/// `units`, and gives its size in bytes. A path that is not a regular file is refused before
/// it is opened for reading ("is a FIFO, not a mesh file"); the messages do not name the
/// file (the caller does).
pub fn read_mesh_file(path: &Path, units: Units) -> Result<(LoadedMesh, u64), String> {
    let file = open_regular(path, "a mesh file")?;
    let len = file
        .metadata()
        .map_err(|e| format!("cannot read: {e}"))?
        .len();
    if len == 0 && file.take(1).read(&mut [0u8]).is_ok_and(|n| n > 0) {
        // The files of /proc and /sys report no size but hold text.
        return Err(
            "reports a size of 0 but holds data (a file of /proc or /sys?): not a mesh file".into(),
        );
    }
    check_memory(mesh_kind(path), len, memory_limit())?;
    // Opened once per reading thread for large binary files, each time checked again.
    let open = || {
        open_regular(path, "a mesh file")
            .map(|f| BufReader::with_capacity(1 << 16, f))
            .map_err(std::io::Error::other)
    };
    let part = match mesh_kind(path) {
        MeshKind::Stl => mesh::read_stl_reopen(open, len, units),
        MeshKind::Obj => open()
            .map_err(Into::into)
            .and_then(|r| mesh::read_obj(r, units)),
        MeshKind::Ply => open()
            .map_err(Into::into)
            .and_then(|r| mesh::read_ply(r, units)),
    }
    .map_err(|e| e.to_string())?;
    Ok((part, len))
}

#[cfg(test)]
mod tests {
    #[cfg(unix)]
    #[test]
    fn paths_are_shown_byte_for_byte() {
        use std::os::unix::ffi::OsStrExt;
        let path = |b: &[u8]| std::path::PathBuf::from(std::ffi::OsStr::from_bytes(b));
        assert_eq!(shown(&path(b"/parts/caf\xe9.stl")), "/parts/caf\\xe9.stl");
        assert_ne!(
            shown(&path(b"caf\xe9.stl")),
            shown(&path(b"caf\xe8.stl")),
            "two names that differ by a byte read alike"
        );
        assert_eq!(shown(&path(b"two\nlines.stl")), "two\\nlines.stl");
        assert_eq!(
            shown(Path::new("d\u{e9}j\u{e0}/part.stl")),
            "d\u{e9}j\u{e0}/part.stl"
        );
    }

    use super::*;

    #[test]
    fn a_toml_file_that_could_take_more_memory_to_parse_than_the_limit_is_refused() {
        // 16 MiB of TOML may take 1.25 GiB to parse: refused under 1 GiB, read under 2.
        let mib = 1u64 << 20;
        let toml = (TOML_MEMORY_PER_BYTE, "a TOML file");
        let e = check_memory_of(16 * mib, toml, "a smaller file", Some(1024 * mib)).unwrap_err();
        assert_eq!(
            e,
            "a file of 16.0 MiB may take up to 1.2 GiB of memory to read (80 times its size for a TOML file), more than the 1.0 GiB this process may use (the memory available, or its limit): use a machine with more memory or a smaller file"
        );
        assert!(check_memory_of(16 * mib, toml, "", Some(2048 * mib)).is_ok());
        // Through the reader, before a byte is read: a sparse file within the size limit.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        std::fs::File::create(&path)
            .unwrap()
            .set_len(MAX_MATERIALS_BYTES)
            .unwrap();
        assert!(read_toml_text(&path, MAX_MATERIALS_BYTES).is_ok_and(|t| t.len() == 1 << 20));
        let over = std::fs::File::create(dir.path().join("over.toml")).unwrap();
        over.set_len(MAX_MATERIALS_BYTES + 1).unwrap();
        let e = read_toml_text(&dir.path().join("over.toml"), MAX_MATERIALS_BYTES).unwrap_err();
        assert_eq!(
            e.to_string(),
            "is over the limit of 1 MiB for a TOML file (1.0 MiB)"
        );
    }

    #[test]
    fn a_file_that_could_take_more_memory_than_the_limit_is_refused_before_reading() {
        // 100 MiB of binary STL may take 300 MiB: refused under 256 MiB, read under 512.
        let mib = 1u64 << 20;
        let e = check_memory(MeshKind::Stl, 100 * mib, Some(256 * mib)).unwrap_err();
        assert!(
            e.starts_with("a file of 100.0 MiB may take up to 0.3 GiB of memory to read (3 times its size for this format), more than the 0.2 GiB"),
            "{e}"
        );
        assert!(check_memory(MeshKind::Stl, 100 * mib, Some(512 * mib)).is_ok());
        assert!(check_memory(MeshKind::Obj, 100 * mib, Some(1500 * mib)).is_err());
        assert!(check_memory(MeshKind::Obj, 100 * mib, None).is_ok());
        assert!(check_memory(MeshKind::Ply, u64::MAX, Some(u64::MAX - 1)).is_err());
        // This machine says how much it has.
        #[cfg(target_os = "linux")]
        assert!(memory_limit().is_some_and(|m| m > 0));
    }

    /// A number written another way is said so, with the way to write it: a decimal
    /// comma, a bare word, a number in quotes (the parser said "expected newline", "string
    /// values must be quoted", and "got the text").
    #[test]
    fn numbers_written_another_way_are_said_so() {
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct M {
            #[serde(rename = "X")]
            x: N,
        }
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct N {
            mu_opt: f64,
        }
        for (value, said) in [
            ("20,5", "line 2: mu_opt: 20,5 is not a number: write a decimal point (20.5)"),
            ("bad", "line 2: mu_opt: bad is neither a number nor quoted text"),
            (
                "\"20\"",
                "line 2: mu_opt: got the text \"20\", expected a number (a number goes without quotes: 20)",
            ),
        ] {
            let text = format!("[X]\nmu_opt = {value}\n");
            let e = toml::from_str::<M>(&text).unwrap_err();
            let got = toml_message(&text, &e);
            assert!(got.starts_with(said), "{value}: {got}");
        }
    }

    #[test]
    fn a_long_value_is_quoted_by_its_start_and_length() {
        let text = format!("[X]\nn = \"{}\"\n", "a".repeat(100_000));
        let e = toml::from_str::<toml::Table>(&text).map(drop).err();
        // Read as a table it parses; as a number it does not.
        assert!(e.is_none());
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct M {
            #[serde(rename = "X")]
            x: N,
        }
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct N {
            n: f64,
        }
        let e = toml::from_str::<M>(&text).unwrap_err();
        let said = toml_message(&text, &e);
        assert!(said.len() < 200, "{} bytes", said.len());
        assert!(
            said.contains(&format!("\"{}... (100000 characters)\"", "a".repeat(60))),
            "{said}"
        );
        // Short values are quoted whole.
        assert_eq!(
            bounded("got the text \"abc\", expected".into()),
            "got the text \"abc\", expected"
        );
    }

    #[test]
    fn sizes_read_as_a_person_writes_them() {
        assert_eq!(size_text(512), "512 bytes");
        assert_eq!(size_text(16 << 20), "16 MiB");
        assert_eq!(size_text(3 << 30), "3 GiB");
        assert_eq!(size_text(1536), "1.5 KiB");
    }

    #[test]
    fn what_serde_got_is_said_in_plain_words() {
        for (serde, plain) in [
            (
                "invalid type: floating point `1e23`, expected usize",
                "got the decimal number 1e23, expected a whole number of 0 or more",
            ),
            (
                "invalid value: integer `-1`, expected u32",
                "got -1, expected a whole number of 0 or more",
            ),
            (
                "invalid type: string \"3, expected\", expected f64",
                "got the text \"3, expected\", expected a number",
            ),
            (
                "invalid type: null, expected a boolean",
                "got no value (null), expected a boolean",
            ),
            (
                "invalid type: boolean `true`, expected f64",
                "got true, expected a number",
            ),
            (
                "invalid type: map, expected f64",
                "got a table, expected a number",
            ),
            // Anything else, and a message cut short, as it was.
            ("unknown field `x`", "unknown field `x`"),
            (
                "invalid type: floating point `1.5",
                "invalid type: floating point `1.5",
            ),
        ] {
            assert_eq!(plain_words(serde), plain, "{serde}");
        }
    }

    #[test]
    fn text_over_its_limit_or_not_utf8_is_refused_with_where() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.toml");
        std::fs::write(&path, b"a = 1\nb = \"\xff\"\n").unwrap();
        let e = read_text(&path, "a TOML file", 1 << 10).unwrap_err();
        assert_eq!(e, TextError::NotUtf8 { line: 2, byte: 11 });
        assert_eq!(
            e.to_string(),
            "line 2: not UTF-8 text (byte 11 of the file)"
        );
        std::fs::write(&path, vec![b'#'; 2048]).unwrap();
        let e = read_text(&path, "a TOML file", 1 << 10).unwrap_err();
        assert_eq!(
            e.to_string(),
            "is over the limit of 1 KiB for a TOML file (2 KiB)"
        );
        std::fs::write(&path, b"a = 1\n").unwrap();
        assert_eq!(read_text(&path, "a TOML file", 1 << 10).unwrap(), "a = 1\n");
        let e = read_text(dir.path(), "a TOML file", 1 << 10).unwrap_err();
        assert_eq!(e.to_string(), "is a folder, not a TOML file");
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn special_files_are_refused_before_they_are_read() {
        // A character device of endless zeros, and a file of /proc that reports no size.
        let e = read_text(Path::new("/dev/zero"), "a TOML file", 1 << 10).unwrap_err();
        assert_eq!(e.to_string(), "is a character device, not a TOML file");
        let e = read_mesh_file(Path::new("/proc/self/status"), Units::Mm).unwrap_err();
        assert!(e.starts_with("reports a size of 0 but holds data"), "{e}");
        // /proc's text is read up to the limit, then refused by it.
        let e = read_text(Path::new("/proc/self/status"), "a TOML file", 16).unwrap_err();
        assert_eq!(
            e.to_string(),
            "is over the limit of 16 bytes for a TOML file"
        );
    }
}
