//! Lines of a text mesh file, read with a bounded buffer.
//!
//! Every text reader (ASCII STL, OBJ, the PLY header and ASCII body) takes its lines from
//! [`Lines`]: a line ends at `\n`, `\r\n` or a lone `\r` (old Mac files), a UTF-8 byte-order
//! mark before the first line is dropped, and a line longer than [`MAX_LINE_BYTES`] is an
//! error naming it, so one enormous line can neither fill the memory nor be echoed whole.

use std::io::BufRead;

use crate::error::{LoadError, Place};

/// The longest line a text mesh file may have: 1 MiB, far more than any statement of a
/// real file needs (a face of [`super::MAX_POLYGON_CORNERS`] corners written `i/j/k` with
/// 9-digit indices is about 120 KB).
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// The UTF-8 byte-order mark some Windows tools write before text.
const BOM: &[u8] = b"\xEF\xBB\xBF";

/// A reader of bounded lines that counts them and the bytes they took.
pub struct Lines<R> {
    reader: R,
    /// The 1-based number of the last line read (0 before the first).
    pub line_no: u64,
    /// Bytes consumed so far, line ends included.
    pub bytes: u64,
}

impl<R: BufRead> Lines<R> {
    /// Lines of `reader`, which is at the start of a file.
    pub fn new(reader: R) -> Lines<R> {
        Lines {
            reader,
            line_no: 0,
            bytes: 0,
        }
    }

    /// The reader, positioned just after the last line read.
    pub fn into_inner(self) -> R {
        self.reader
    }

    /// Reads the next line into `line` (without its end). `false` at the end of the file.
    pub fn next_into(&mut self, line: &mut Vec<u8>) -> Result<bool, LoadError> {
        line.clear();
        let mut any = false;
        loop {
            let buf = self.reader.fill_buf()?;
            if buf.is_empty() {
                break;
            }
            any = true;
            let end = buf.iter().position(|&b| b == b'\n' || b == b'\r');
            let take = end.unwrap_or(buf.len());
            if line.len() + take > MAX_LINE_BYTES {
                return Err(LoadError::Syntax {
                    place: Place::Line(self.line_no + 1),
                    message: format!(
                        "the line is longer than {} bytes, the limit of a line (a file of one enormous line or statement)",
                        MAX_LINE_BYTES
                    ),
                });
            }
            line.extend_from_slice(&buf[..take]);
            match end {
                None => {
                    self.reader.consume(take);
                    self.bytes += take as u64;
                }
                Some(at) => {
                    let cr = buf[at] == b'\r';
                    self.reader.consume(at + 1);
                    self.bytes += at as u64 + 1;
                    if cr && self.reader.fill_buf()?.first() == Some(&b'\n') {
                        self.reader.consume(1);
                        self.bytes += 1;
                    }
                    break;
                }
            }
        }
        if !any {
            return Ok(false);
        }
        self.line_no += 1;
        if self.line_no == 1 && line.starts_with(BOM) {
            line.drain(..BOM.len());
        }
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(bytes: &[u8]) -> Result<Vec<String>, LoadError> {
        let mut lines = Lines::new(bytes);
        let mut out = Vec::new();
        let mut line = Vec::new();
        while lines.next_into(&mut line)? {
            out.push(String::from_utf8(line.clone()).unwrap());
        }
        assert_eq!(lines.line_no as usize, out.len());
        assert_eq!(lines.bytes as usize, bytes.len());
        Ok(out)
    }

    #[test]
    fn cr_only_crlf_and_lf_line_ends_are_one_line_end_each() {
        assert_eq!(all(b"a\rb\r\nc\n\nd").unwrap(), ["a", "b", "c", "", "d"]);
        assert_eq!(all(b"a\r\r").unwrap(), ["a", ""]);
        assert_eq!(all(b"").unwrap(), Vec::<String>::new());
    }

    #[test]
    fn byte_order_mark_before_the_first_line_is_dropped() {
        assert_eq!(
            all(b"\xEF\xBB\xBFsolid x\nfacet").unwrap(),
            ["solid x", "facet"]
        );
    }

    #[test]
    fn line_longer_than_the_limit_is_an_error_naming_it() {
        let mut text = b"ok\n".to_vec();
        text.extend(std::iter::repeat_n(b'1', MAX_LINE_BYTES + 1));
        let err = all(&text).unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::Syntax {
                    place: Place::Line(2),
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().len() < 200);
    }
}
