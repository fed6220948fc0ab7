//! A byte cursor shared by the readers: whitespace-separated tokens with line numbers, plus raw
//! little/big-endian binary reads for the formats that mix text headers with binary payloads
//! (Gmsh binary, legacy VTK binary). Every failure is an [`Error::Parse`] naming the file and the
//! line (or, inside binary data, the byte offset), never a panic.

use std::path::Path;
use std::str::FromStr;

use crate::error::{Error, Result};

/// A position in a file's bytes.
pub(crate) struct Cursor<'a> {
    path: &'a Path,
    data: &'a [u8],
    pos: usize,
    /// 1-based line of `pos`, counted over text only.
    line: usize,
    /// Comment character that hides the rest of a line (TetGen, MEDIT: `#`).
    comment: Option<u8>,
    /// Set once binary data has been read: lines no longer mean anything, errors give offsets.
    binary: bool,
}

impl<'a> Cursor<'a> {
    /// A cursor at the start of `data`, which came from `path`.
    pub fn new(path: &'a Path, data: &'a [u8]) -> Self {
        Cursor {
            path,
            data,
            pos: 0,
            line: 1,
            comment: None,
            binary: false,
        }
    }

    /// Treat `c` as the start of a comment running to the end of the line.
    pub fn with_comment(mut self, c: u8) -> Self {
        self.comment = Some(c);
        self
    }

    /// 1-based line of the next token (after skipping blanks). Inside binary data nothing is
    /// skipped: bytes that look like blanks may be data.
    pub fn line(&mut self) -> usize {
        if !self.binary {
            self.skip_blank();
        }
        self.line
    }

    /// The file being read, for errors raised after parsing.
    pub fn path(&self) -> &'a Path {
        self.path
    }

    /// 1-based line of the cursor, skipping nothing.
    pub fn line_here(&self) -> usize {
        self.line
    }

    /// A parse error at the current position.
    pub fn error(&self, message: impl Into<String>) -> Error {
        let message = message.into();
        if self.binary {
            Error::parse(self.path, None, format!("byte {}: {message}", self.pos))
        } else {
            // At the end of a file that ends with a newline, name the last line, not the
            // empty one after it.
            let at_end = self.pos >= self.data.len() && self.data.last() == Some(&b'\n');
            let line = if at_end { self.line - 1 } else { self.line };
            Error::parse(self.path, Some(line.max(1)), message)
        }
    }

    /// A parse error at a given line.
    pub fn error_at(&self, line: usize, message: impl Into<String>) -> Error {
        Error::parse(self.path, Some(line), message)
    }

    fn skip_blank(&mut self) {
        while let Some(&c) = self.data.get(self.pos) {
            if c == b'\n' {
                self.line += 1;
                self.pos += 1;
            } else if c.is_ascii_whitespace() {
                self.pos += 1;
            } else if Some(c) == self.comment {
                while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
                    self.pos += 1;
                }
            } else {
                break;
            }
        }
    }

    /// The next token, or `None` at the end of the file.
    pub fn next_token(&mut self) -> Option<&'a str> {
        self.skip_blank();
        let start = self.pos;
        while let Some(&c) = self.data.get(self.pos) {
            if c.is_ascii_whitespace() || Some(c) == self.comment {
                break;
            }
            self.pos += 1;
        }
        if start == self.pos {
            return None;
        }
        // Non-UTF-8 bytes cannot be a number or a keyword; show them lossily in errors.
        Some(std::str::from_utf8(&self.data[start..self.pos]).unwrap_or("\u{fffd}"))
    }

    /// The next token without consuming it.
    pub fn peek_token(&mut self) -> Option<&'a str> {
        let (pos, line) = (self.pos, self.line);
        let token = self.next_token();
        self.pos = pos;
        self.line = line;
        token
    }

    /// The next token; `what` names the expected item for the end-of-file error.
    pub fn token(&mut self, what: &str) -> Result<&'a str> {
        self.next_token()
            .ok_or_else(|| self.error(format!("unexpected end of file: expected {what}")))
    }

    /// The next token parsed as `T`; `what` names it in the error.
    pub fn parse<T: FromStr>(&mut self, what: &str) -> Result<T> {
        let token = self.token(what)?;
        token
            .parse()
            .map_err(|_| self.error(format!("expected {what}, found `{}`", shorten(token))))
    }

    /// A count (non-negative integer) that must not exceed `limit`, so that a corrupt header
    /// cannot make us allocate without bound.
    pub fn count(&mut self, what: &str, limit: usize) -> Result<usize> {
        let n: usize = self.parse(what)?;
        if n > limit {
            return Err(self.error(format!(
                "{what} is {n}, but the file ends too soon to hold that many (truncated?)"
            )));
        }
        Ok(n)
    }

    /// Consume `keyword` exactly, or fail saying what was found instead.
    pub fn expect(&mut self, keyword: &str) -> Result<()> {
        match self.next_token() {
            Some(t) if t == keyword => Ok(()),
            Some(t) => Err(self.error(format!("expected `{keyword}`, found `{}`", shorten(t)))),
            None => Err(self.error(format!("unexpected end of file: expected `{keyword}`"))),
        }
    }

    /// The rest of the current line (without the newline), consumed.
    pub fn rest_of_line(&mut self) -> &'a str {
        let start = self.pos;
        while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
            self.pos += 1;
        }
        let text = &self.data[start..self.pos];
        if self.pos < self.data.len() {
            self.pos += 1;
            self.line += 1;
        }
        std::str::from_utf8(text).unwrap_or("\u{fffd}").trim()
    }

    /// Skip to the start of the next line: binary payloads begin right after their header's
    /// newline, and may start with bytes that look like blanks.
    pub fn skip_line(&mut self) {
        self.rest_of_line();
    }

    /// The bytes remaining from the cursor on (for formats that scan, not tokenise).
    pub fn remaining(&self) -> &'a [u8] {
        &self.data[self.pos.min(self.data.len())..]
    }

    /// Advance by `n` raw bytes (binary data); `what` names it in the error.
    pub fn bytes(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        self.binary = true;
        let end = self.pos.checked_add(n).filter(|&e| e <= self.data.len());
        match end {
            Some(end) => {
                let out = &self.data[self.pos..end];
                self.pos = end;
                Ok(out)
            }
            None => Err(self.error(format!(
                "unexpected end of file in binary data: expected {what} ({n} bytes, {} left)",
                self.data.len() - self.pos
            ))),
        }
    }

    /// Move to byte offset `pos` and the given line (used to skip a section found by search).
    pub fn seek(&mut self, pos: usize, newlines: usize) {
        self.pos = pos.min(self.data.len());
        self.line += newlines;
    }

    /// Byte offset of the cursor.
    pub fn pos(&self) -> usize {
        self.pos
    }
}

/// Byte order of binary payloads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Endian {
    Little,
    Big,
}

/// Scalar types that binary readers decode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    /// Size in bytes.
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    /// Whether values are integers (indices must be).
    pub fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// Decode one value of type `ty` from exactly `ty.size()` bytes, widened to f64 for floats and
/// to i128 for integers (so that u64 and i64 both fit).
pub(crate) fn decode(bytes: &[u8], ty: Scalar, endian: Endian) -> Value {
    let mut b = [0u8; 8];
    let n = ty.size();
    b[..n].copy_from_slice(&bytes[..n]);
    if endian == Endian::Big {
        b[..n].reverse();
    }
    match ty {
        Scalar::I8 => Value::Int(b[0] as i8 as i128),
        Scalar::U8 => Value::Int(b[0] as i128),
        Scalar::I16 => Value::Int(i16::from_le_bytes([b[0], b[1]]) as i128),
        Scalar::U16 => Value::Int(u16::from_le_bytes([b[0], b[1]]) as i128),
        Scalar::I32 => Value::Int(i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as i128),
        Scalar::U32 => Value::Int(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as i128),
        Scalar::I64 => Value::Int(i64::from_le_bytes(b) as i128),
        Scalar::U64 => Value::Int(u64::from_le_bytes(b) as i128),
        Scalar::F32 => Value::Float(f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64),
        Scalar::F64 => Value::Float(f64::from_le_bytes(b)),
    }
}

/// A decoded binary value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Value {
    Int(i128),
    Float(f64),
}

impl Value {
    /// As a float (integers convert).
    pub fn as_f64(self) -> f64 {
        match self {
            Value::Int(i) => i as f64,
            Value::Float(f) => f,
        }
    }
}

/// Decode a whole array of `ty` values into f64 (floats) or i128 (integers) lists.
pub(crate) fn decode_all(bytes: &[u8], ty: Scalar, endian: Endian) -> Vec<Value> {
    bytes
        .chunks_exact(ty.size())
        .map(|c| decode(c, ty, endian))
        .collect()
}

/// At most 40 characters of a token, for error messages about garbage input.
pub(crate) fn shorten(s: &str) -> String {
    if s.chars().count() <= 40 {
        s.to_string()
    } else {
        format!("{}…", s.chars().take(40).collect::<String>())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_carry_lines_and_skip_comments() {
        let path = Path::new("x");
        let mut c = Cursor::new(path, b"a # b c\n\n  d 12\n").with_comment(b'#');
        assert_eq!(c.token("a").unwrap(), "a");
        assert_eq!(c.line(), 3);
        assert_eq!(c.token("d").unwrap(), "d");
        assert_eq!(c.parse::<u32>("n").unwrap(), 12);
        let err = c.parse::<u32>("count").unwrap_err().to_string();
        assert_eq!(err, "x:3: unexpected end of file: expected count");
    }

    #[test]
    fn bad_number_names_the_token_and_line() {
        let path = Path::new("f.node");
        let mut c = Cursor::new(path, b"1\n2 zz\n");
        c.token("a").unwrap();
        c.token("b").unwrap();
        let err = c.parse::<f64>("x coordinate").unwrap_err().to_string();
        assert_eq!(err, "f.node:2: expected x coordinate, found `zz`");
    }

    #[test]
    fn binary_reads_are_bounded() {
        let path = Path::new("b");
        let mut c = Cursor::new(path, b"hdr\n\x01\x00\x00\x00");
        c.skip_line();
        let b = c.bytes(4, "an int").unwrap();
        assert_eq!(decode(b, Scalar::I32, Endian::Little), Value::Int(1));
        assert_eq!(decode(b, Scalar::I32, Endian::Big), Value::Int(1 << 24));
        assert!(
            c.bytes(1, "more")
                .unwrap_err()
                .to_string()
                .contains("byte 8")
        );
    }
}
