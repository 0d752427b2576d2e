//! A byte cursor shared by the text and binary readers.
//!
//! Mesh formats mix whitespace-separated text with raw binary blocks (legacy
//! VTK BINARY, Gmsh binary), so one cursor tracks both the byte offset and the
//! line number; errors carry whichever is meaningful.

use std::path::Path;
use std::str::FromStr;

use crate::error::{Error, Location};

#[derive(Clone)]
pub(crate) struct Cursor<'a> {
    pub path: &'a Path,
    data: &'a [u8],
    pos: usize,
    /// Line of `pos` (1-based).
    line: usize,
    /// Line of the last token returned, for error messages.
    tok_line: usize,
    /// Medit allows `#` comments running to the end of the line.
    pub hash_comments: bool,
    /// What the read may still allocate.
    pub budget: Option<&'a super::limits::Budget>,
}

fn is_ws(b: u8) -> bool {
    b.is_ascii_whitespace()
}

impl<'a> Cursor<'a> {
    pub fn new(path: &'a Path, data: &'a [u8]) -> Self {
        Cursor {
            path,
            data,
            pos: 0,
            line: 1,
            tok_line: 1,
            hash_comments: false,
            budget: None,
        }
    }

    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Line of the last token returned (1-based).
    pub fn token_line(&self) -> usize {
        self.tok_line
    }

    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// Capacity for `n` items of at least `min_bytes` each: a header count can
    /// never make us allocate more than the file could hold.
    pub fn cap(&self, n: usize, min_bytes: usize) -> usize {
        n.min(self.remaining() / min_bytes.max(1) + 1)
    }

    /// Capacity for `n` items of at least `min_bytes` each in the file, as
    /// [`cap`](Self::cap), taking `n` items of `each` bytes from the budget
    /// first (what the section will hold when the file is whole): a declared
    /// count past the budget is refused, naming `what`.
    pub fn reserve(&self, what: &str, n: usize, min_bytes: usize, each: usize) -> crate::Result<usize> {
        let cap = self.cap(n, min_bytes);
        if let Some(b) = self.budget {
            let bytes = (n as u64).saturating_mul(each as u64);
            b.charge(format_args!("{what} ({n} declared)"), bytes)
                .map_err(|_| self.err(b.over_msg(format_args!("{what} ({n} declared)"), bytes)))?;
        }
        Ok(cap)
    }

    /// Parse error at the line of the last token.
    pub fn err(&self, msg: impl Into<String>) -> Error {
        Error::parse(self.path, Some(Location::Line(self.tok_line)), msg)
    }

    /// Parse error at the current byte offset (binary data).
    pub fn err_byte(&self, msg: impl Into<String>) -> Error {
        Error::parse(self.path, Some(Location::Byte(self.pos as u64)), msg)
    }

    pub fn err_at_byte(&self, at: usize, msg: impl Into<String>) -> Error {
        Error::parse(self.path, Some(Location::Byte(at as u64)), msg)
    }

    pub fn eof(&self, what: &str) -> Error {
        Error::parse(self.path, None, format!("unexpected end of file while reading {what}"))
    }

    fn bump(&mut self) {
        if self.data[self.pos] == b'\n' {
            self.line += 1;
        }
        self.pos += 1;
    }

    pub fn skip_ws(&mut self) {
        while self.pos < self.data.len() {
            let b = self.data[self.pos];
            if is_ws(b) {
                self.bump();
            } else if b == b'#' && self.hash_comments {
                while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
                    self.pos += 1;
                }
            } else {
                break;
            }
        }
    }

    pub fn at_eof(&mut self) -> bool {
        self.skip_ws();
        self.pos >= self.data.len()
    }

    /// Next whitespace-separated token, or None at end of file.
    pub fn token(&mut self) -> Option<&'a str> {
        self.skip_ws();
        if self.pos >= self.data.len() {
            return None;
        }
        let start = self.pos;
        self.tok_line = self.line;
        while self.pos < self.data.len() && !is_ws(self.data[self.pos]) {
            self.pos += 1;
        }
        // Non-UTF-8 bytes cannot form a valid number or keyword anyway; show them lossily.
        Some(std::str::from_utf8(&self.data[start..self.pos]).unwrap_or("<non-text bytes>"))
    }

    pub fn peek_token(&mut self) -> Option<&'a str> {
        let (pos, line, tok_line) = (self.pos, self.line, self.tok_line);
        let t = self.token();
        (self.pos, self.line, self.tok_line) = (pos, line, tok_line);
        t
    }

    pub fn expect_token(&mut self, what: &str) -> crate::Result<&'a str> {
        self.token().ok_or_else(|| self.eof(what))
    }

    /// Parse one token as a number of type `T`.
    pub fn parse<T: FromStr>(&mut self, what: &str) -> crate::Result<T> {
        let t = self.expect_token(what)?;
        t.parse()
            .map_err(|_| self.err(format!("expected a number ({what}), found '{}'", clip(t))))
    }

    /// Parse a count: a non-negative integer.
    pub fn count(&mut self, what: &str) -> crate::Result<usize> {
        let t = self.expect_token(what)?;
        t.parse()
            .map_err(|_| self.err(format!("expected a non-negative integer ({what}), found '{}'", clip(t))))
    }

    /// `n` numbers, with a truncation error that says how many were found.
    pub fn numbers<T: FromStr>(&mut self, n: usize, what: &str) -> crate::Result<Vec<T>> {
        let mut out = Vec::with_capacity(self.cap(n, 2));
        for i in 0..n {
            match self.token() {
                None => {
                    return Err(Error::parse(
                        self.path,
                        None,
                        format!("unexpected end of file while reading {what}: expected {n} values, found {i}"),
                    ));
                }
                Some(t) => out.push(
                    t.parse()
                        .map_err(|_| self.err(format!("expected a number ({what}), found '{}'", clip(t))))?,
                ),
            }
        }
        Ok(out)
    }

    /// The remaining tokens of the next non-blank line (the line is consumed).
    pub fn line_tokens(&mut self) -> Option<(usize, Vec<&'a str>)> {
        self.skip_ws();
        if self.pos >= self.data.len() {
            return None;
        }
        self.tok_line = self.line;
        let line = self.line;
        let start = self.pos;
        while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
            self.pos += 1;
        }
        let toks = std::str::from_utf8(&self.data[start..self.pos])
            .map(|s| s.split_ascii_whitespace().collect())
            .unwrap_or_else(|_| vec!["<non-text bytes>"]);
        if self.pos < self.data.len() {
            self.bump();
        }
        Some((line, toks))
    }

    /// The next line as it is (no whitespace skipped, newline consumed), or
    /// None at end of file; VTK's ASCII string arrays hold one string a line.
    pub fn raw_line(&mut self) -> Option<String> {
        if self.pos >= self.data.len() {
            return None;
        }
        self.tok_line = self.line;
        let start = self.pos;
        while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
            self.pos += 1;
        }
        let s = String::from_utf8_lossy(&self.data[start..self.pos]).into_owned();
        if self.pos < self.data.len() {
            self.bump();
        }
        Some(s)
    }

    /// Consume the rest of the current line including its newline: binary
    /// blocks start right after it, and their first byte may look like space.
    pub fn end_line(&mut self) {
        while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
            self.pos += 1;
        }
        if self.pos < self.data.len() {
            self.bump();
        }
    }

    /// Whether the upcoming bytes (after whitespace) start with `prefix`, ignoring ASCII case.
    pub fn looking_at(&mut self, prefix: &str) -> bool {
        let (pos, line) = (self.pos, self.line);
        self.skip_ws();
        let hit = self.data[self.pos..]
            .get(..prefix.len())
            .is_some_and(|s| s.eq_ignore_ascii_case(prefix.as_bytes()));
        (self.pos, self.line) = (pos, line);
        hit
    }

    /// `n` raw bytes (binary data); lines are not counted inside binary blocks.
    pub fn bytes(&mut self, n: usize, what: &str) -> crate::Result<&'a [u8]> {
        if n > self.remaining() {
            return Err(self.err_byte(format!(
                "unexpected end of file while reading {what}: needed {n} bytes, only {} left",
                self.remaining()
            )));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// Skip to just after the next occurrence of `needle`; false if absent.
    pub fn skip_past(&mut self, needle: &[u8]) -> bool {
        let hay = &self.data[self.pos..];
        match hay.windows(needle.len()).position(|w| w == needle) {
            Some(i) => {
                let end = self.pos + i + needle.len();
                while self.pos < end {
                    self.bump();
                }
                true
            }
            None => false,
        }
    }

    /// Skip lines until an empty one (VTK METADATA blocks end that way).
    pub fn skip_to_blank_line(&mut self) {
        self.end_line();
        while self.pos < self.data.len() {
            let start = self.pos;
            self.end_line();
            if self.data[start..self.pos].iter().all(|&b| is_ws(b)) {
                break;
            }
        }
    }
}

/// Fixed-size binary number decoding with a chosen byte order.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Endian {
    Little,
    Big,
}

macro_rules! decode_fn {
    ($name:ident, $t:ty) => {
        pub fn $name(self, b: &[u8]) -> $t {
            let mut a = [0u8; std::mem::size_of::<$t>()];
            a.copy_from_slice(&b[..std::mem::size_of::<$t>()]);
            match self {
                Endian::Little => <$t>::from_le_bytes(a),
                Endian::Big => <$t>::from_be_bytes(a),
            }
        }
    };
}

impl Endian {
    decode_fn!(i8, i8);
    decode_fn!(u8, u8);
    decode_fn!(i16, i16);
    decode_fn!(u16, u16);
    decode_fn!(i32, i32);
    decode_fn!(u32, u32);
    decode_fn!(i64, i64);
    decode_fn!(u64, u64);
    decode_fn!(f32, f32);
    decode_fn!(f64, f64);
}

/// Numeric element types of binary arrays (VTK legacy and XML names map here).
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
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    /// One value from `c` (at least `size()` bytes) as f64; integers above
    /// 2^53 lose precision, which only matters for nonsense ids.
    pub fn get(self, e: Endian, c: &[u8]) -> f64 {
        match self {
            Scalar::I8 => e.i8(c) as f64,
            Scalar::U8 => e.u8(c) as f64,
            Scalar::I16 => e.i16(c) as f64,
            Scalar::U16 => e.u16(c) as f64,
            Scalar::I32 => e.i32(c) as f64,
            Scalar::U32 => e.u32(c) as f64,
            Scalar::I64 => e.i64(c) as f64,
            Scalar::U64 => e.u64(c) as f64,
            Scalar::F32 => e.f32(c) as f64,
            Scalar::F64 => e.f64(c),
        }
    }
}

/// A value read as f64 that must be an index or count below `limit`.
pub(crate) fn as_index(v: f64, limit: usize) -> Option<usize> {
    (v >= 0.0 && v.fract() == 0.0 && v < limit as f64).then_some(v as usize)
}

/// At most ~80 characters of `s` for an error message (a corrupt file can put
/// megabytes in one token).
pub(crate) fn clip(s: &str) -> String {
    const MAX: usize = 80;
    match s.char_indices().nth(MAX) {
        None => s.to_string(),
        Some((i, _)) => format!("{}... ({} bytes)", &s[..i], s.len()),
    }
}

impl Scalar {
    pub fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The data-model type of arrays of this scalar.
    pub fn value_type(self) -> crate::mesh::ValueType {
        use crate::mesh::ValueType as V;
        match self {
            Scalar::I8 => V::I8,
            Scalar::U8 => V::U8,
            Scalar::I16 => V::I16,
            Scalar::U16 => V::U16,
            Scalar::I32 => V::I32,
            Scalar::U32 => V::U32,
            Scalar::I64 => V::I64,
            Scalar::U64 => V::U64,
            Scalar::F32 => V::F32,
            Scalar::F64 => V::F64,
        }
    }

    /// One integer value from `c` (`u64` above `i64::MAX` wraps).
    pub fn get_i64(self, e: Endian, c: &[u8]) -> i64 {
        match self {
            Scalar::I8 => e.i8(c) as i64,
            Scalar::U8 => e.u8(c) as i64,
            Scalar::I16 => e.i16(c) as i64,
            Scalar::U16 => e.u16(c) as i64,
            Scalar::I32 => e.i32(c) as i64,
            Scalar::U32 => e.u32(c) as i64,
            Scalar::I64 => e.i64(c),
            Scalar::U64 => e.u64(c) as i64,
            Scalar::F32 => e.f32(c) as i64,
            Scalar::F64 => e.f64(c) as i64,
        }
    }

    /// Values of `bytes` (a whole number of values) as typed values.
    pub fn decode_all(self, e: Endian, bytes: &[u8]) -> crate::mesh::Values {
        use rayon::prelude::*;
        let s = self.size();
        // a 10M-tet connectivity is 330 MB: worth both cores
        let min = (1 << 16) / s;
        if self.is_float() {
            crate::mesh::Values::Float(
                bytes
                    .par_chunks_exact(s)
                    .with_min_len(min)
                    .map(|c| self.get(e, c))
                    .collect(),
            )
        } else {
            crate::mesh::Values::Int(
                bytes
                    .par_chunks_exact(s)
                    .with_min_len(min)
                    .map(|c| self.get_i64(e, c))
                    .collect(),
            )
        }
    }

    /// Parse one text value of this type.
    pub fn parse_text(self, t: &str) -> Option<NumVal> {
        if self == Scalar::F32 {
            // the value a float array holds: the text rounded to f32
            t.parse::<f32>().ok().map(|x| NumVal::F(x as f64))
        } else if self.is_float() {
            t.parse::<f64>().ok().map(NumVal::F)
        } else if self == Scalar::U64 {
            t.parse::<u64>().ok().map(|v| NumVal::I(v as i64))
        } else {
            // VTK writes integers as integers; tolerate "3.0" from other writers
            t.parse::<i64>()
                .ok()
                .or_else(|| {
                    t.parse::<f64>()
                        .ok()
                        .filter(|x| x.fract() == 0.0 && x.abs() < 9.2e18)
                        .map(|x| x as i64)
                })
                .map(NumVal::I)
        }
    }
}

/// A parsed text value.
#[derive(Clone, Copy)]
pub(crate) enum NumVal {
    I(i64),
    F(f64),
}

/// Collects text values into typed storage.
pub(crate) fn push_val(out: &mut crate::mesh::Values, v: NumVal) {
    use crate::mesh::Values;
    match (out, v) {
        (Values::Int(o), NumVal::I(x)) => o.push(x),
        (Values::Float(o), NumVal::F(x)) => o.push(x),
        (Values::Float(o), NumVal::I(x)) => o.push(x as f64),
        (Values::Int(o), NumVal::F(x)) => o.push(x as i64),
        (Values::Str(_), _) => {}
    }
}

/// Empty storage for values of `s`.
pub(crate) fn empty_values(s: Scalar, cap: usize) -> crate::mesh::Values {
    if s.is_float() {
        crate::mesh::Values::Float(Vec::with_capacity(cap))
    } else {
        crate::mesh::Values::Int(Vec::with_capacity(cap))
    }
}
