//! What kind of file a path names, and opening an input only when it is a regular file (a
//! FIFO or a device given as a mesh would block the run or read forever).

use std::fs::{File, OpenOptions};
use std::path::Path;

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

/// Opens `path` for reading when it is a regular file (following links); the error says what
/// it is otherwise ("is a FIFO, not a mesh file"). The kind is checked before opening, and
/// the file is opened without blocking (`O_NONBLOCK`) and checked again, so a FIFO put in
/// its place between the two cannot hang the run.
pub fn open_regular(path: &Path) -> Result<File, String> {
    let not_a_mesh = |m: &std::fs::Metadata| format!("is {}, not a mesh file", file_kind(m));
    let m = std::fs::metadata(path).map_err(|e| format!("cannot open: {e}"))?;
    if !m.is_file() {
        return Err(not_a_mesh(&m));
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
        return Err(not_a_mesh(&m));
    }
    Ok(file)
}
