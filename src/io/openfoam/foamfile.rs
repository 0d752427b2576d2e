//! OpenFOAM's file format: the `FoamFile` header, C and C++ comments,
//! words, strings and punctuation, and the lists of the polyMesh files,
//! ASCII or binary (a binary list is its count, `(`, the raw values and `)`).

use std::path::Path;

use crate::error::{Error, Location, Result};
use crate::io::lex::{Endian, clip};
use crate::io::limits::Budget;

/// What the `FoamFile` header says.
#[derive(Clone)]
pub(super) struct Header {
    pub binary: bool,
    pub endian: Endian,
    /// Bytes of a label (4 or 8).
    pub label: usize,
    /// Bytes of a scalar (4 or 8).
    pub scalar: usize,
    pub class: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Tok<'a> {
    Punct(u8),
    Word(&'a str),
    Str(&'a str),
    End,
}

impl Tok<'_> {
    fn show(&self) -> String {
        match self {
            Tok::Punct(p) => format!("'{}'", *p as char),
            Tok::Word(w) => format!("'{}'", clip(w)),
            Tok::Str(s) => format!("\"{}\"", clip(s)),
            Tok::End => "the end of the file".into(),
        }
    }
}

/// What a label list is, for its errors: `owner`, or face 12 of `face`.
#[derive(Clone, Copy)]
pub(super) struct What<'s> {
    pub list: &'s str,
    pub item: Option<usize>,
}

impl<'s> What<'s> {
    pub fn list(list: &'s str) -> Self {
        What { list, item: None }
    }

    /// Entry `i` of the list.
    fn at(&self, i: usize) -> String {
        match self.item {
            Some(k) => format!("{} {k}: entry {i}", self.list),
            None => format!("{} {i}", self.list),
        }
    }
}

impl std::fmt::Display for What<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.item {
            Some(k) => write!(f, "{} {k}", self.list),
            None => f.write_str(self.list),
        }
    }
}

fn is_punct(b: u8) -> bool {
    matches!(b, b'(' | b')' | b'{' | b'}' | b';' | b'[' | b']')
}

/// A cursor over one file's (decompressed) bytes.
pub(super) struct Lexer<'a> {
    pub path: &'a Path,
    data: &'a [u8],
    pos: usize,
    line: usize,
    tok_line: usize,
    pub header: Header,
    budget: &'a Budget,
}

impl<'a> Lexer<'a> {
    /// The file's header read; the cursor then stands at its first entry.
    pub fn new(path: &'a Path, data: &'a [u8], budget: &'a Budget) -> Result<Lexer<'a>> {
        let mut lx = Lexer {
            path,
            data,
            pos: 0,
            line: 1,
            tok_line: 1,
            header: Header {
                binary: false,
                endian: Endian::Little,
                label: 4,
                scalar: 8,
                class: String::new(),
            },
            budget,
        };
        let start = (lx.pos, lx.line);
        if lx.next()? != Tok::Word("FoamFile") {
            // no header: ASCII with the default sizes
            (lx.pos, lx.line) = start;
            return Ok(lx);
        }
        lx.expect(b'{', "the FoamFile header")?;
        loop {
            let key = match lx.next()? {
                Tok::Punct(b'}') => break,
                Tok::Word(w) => w,
                t => return Err(lx.err(format!("expected a keyword in the FoamFile header, found {}", t.show()))),
            };
            let value = match lx.next()? {
                Tok::Word(w) | Tok::Str(w) => w,
                t => {
                    return Err(lx.err(format!(
                        "expected the value of '{key}' in the header, found {}",
                        t.show()
                    )));
                }
            };
            match key {
                "format" => {
                    lx.header.binary = match value {
                        "binary" => true,
                        "ascii" => false,
                        other => {
                            return Err(lx.err(format!("format '{}' is neither ascii nor binary", clip(other))));
                        }
                    }
                }
                "class" => lx.header.class = value.to_string(),
                "arch" => lx.arch(value)?,
                _ => {}
            }
            lx.skip_value()?;
        }
        Ok(lx)
    }

    /// `arch "LSB;label=32;scalar=64"`: byte order and sizes.
    fn arch(&mut self, arch: &str) -> Result<()> {
        for part in arch.split(';').map(str::trim).filter(|p| !p.is_empty()) {
            let size = |v: &str, what: &str| -> Result<usize> {
                match v {
                    "32" => Ok(4),
                    "64" => Ok(8),
                    _ => Err(self.err(format!(
                        "arch says {what}={}: meshsmooth reads {what}s of 32 or 64 bits",
                        clip(v)
                    ))),
                }
            };
            match part.split_once('=') {
                None if part == "LSB" => self.header.endian = Endian::Little,
                None if part == "MSB" => self.header.endian = Endian::Big,
                Some(("label", v)) => self.header.label = size(v, "label")?,
                Some(("scalar", v)) => self.header.scalar = size(v, "scalar")?,
                _ => {}
            }
        }
        Ok(())
    }

    /// Parse error at the line of the last token.
    pub fn err(&self, msg: impl Into<String>) -> Error {
        Error::parse(self.path, Some(Location::Line(self.tok_line)), msg)
    }

    fn err_byte(&self, at: usize, msg: impl Into<String>) -> Error {
        Error::parse(self.path, Some(Location::Byte(at as u64)), msg)
    }

    fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    fn skip_space(&mut self) -> Result<()> {
        while let Some(&b) = self.data.get(self.pos) {
            if b.is_ascii_whitespace() {
                if b == b'\n' {
                    self.line += 1;
                }
                self.pos += 1;
            } else if b == b'/' && self.data.get(self.pos + 1) == Some(&b'/') {
                while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
                    self.pos += 1;
                }
            } else if b == b'/' && self.data.get(self.pos + 1) == Some(&b'*') {
                let from = self.line;
                self.pos += 2;
                loop {
                    match self.data.get(self.pos) {
                        None => {
                            return Err(Error::parse(
                                self.path,
                                Some(Location::Line(from)),
                                "a /* comment is never closed",
                            ));
                        }
                        Some(b'*') if self.data.get(self.pos + 1) == Some(&b'/') => {
                            self.pos += 2;
                            break;
                        }
                        Some(&c) => {
                            if c == b'\n' {
                                self.line += 1;
                            }
                            self.pos += 1;
                        }
                    }
                }
            } else {
                break;
            }
        }
        Ok(())
    }

    /// The next token.
    pub fn next(&mut self) -> Result<Tok<'a>> {
        self.skip_space()?;
        self.tok_line = self.line;
        let Some(&b) = self.data.get(self.pos) else {
            return Ok(Tok::End);
        };
        if is_punct(b) {
            self.pos += 1;
            return Ok(Tok::Punct(b));
        }
        let text = |s: &'a [u8]| std::str::from_utf8(s).unwrap_or("<non-text bytes>");
        if b == b'"' {
            let start = self.pos + 1;
            let mut i = start;
            while i < self.data.len() && self.data[i] != b'"' {
                if self.data[i] == b'\\' {
                    i += 1;
                }
                if self.data.get(i) == Some(&b'\n') {
                    self.line += 1;
                }
                i += 1;
            }
            if i >= self.data.len() {
                return Err(self.err("a string is never closed"));
            }
            self.pos = i + 1;
            return Ok(Tok::Str(text(&self.data[start..i])));
        }
        let start = self.pos;
        while let Some(&c) = self.data.get(self.pos) {
            if c.is_ascii_whitespace() || is_punct(c) || c == b'"' {
                break;
            }
            // a comment right after a word ends it
            if c == b'/' && matches!(self.data.get(self.pos + 1), Some(b'/' | b'*')) {
                break;
            }
            self.pos += 1;
        }
        Ok(Tok::Word(text(&self.data[start..self.pos])))
    }

    pub fn peek(&mut self) -> Result<Tok<'a>> {
        let (pos, line, tok_line) = (self.pos, self.line, self.tok_line);
        let t = self.next();
        (self.pos, self.line, self.tok_line) = (pos, line, tok_line);
        t
    }

    pub fn expect(&mut self, p: u8, what: &str) -> Result<()> {
        match self.next()? {
            Tok::Punct(q) if q == p => Ok(()),
            t => Err(self.err(format!("expected '{}' in {what}, found {}", p as char, t.show()))),
        }
    }

    /// A non-negative integer.
    pub fn count(&mut self, what: &str) -> Result<usize> {
        match self.next()? {
            Tok::Word(w) => w
                .parse()
                .map_err(|_| self.err(format!("expected the number of {what}, found '{}'", clip(w)))),
            t => Err(self.err(format!("expected the number of {what}, found {}", t.show()))),
        }
    }

    /// Skips an entry's value up to and including its `;`, nested lists and
    /// dictionaries included (binary lists of labels, scalars and bools
    /// skipped by their size, after a `List<T>` word says which).
    pub fn skip_value(&mut self) -> Result<()> {
        let mut depth = 0usize;
        let mut elem: Option<usize> = None;
        let mut count: Option<usize> = None;
        loop {
            let t = self.next()?;
            match t {
                Tok::End => return Err(self.err("the file ends inside an entry (a ';' is missing)")),
                Tok::Punct(b';') if depth == 0 => return Ok(()),
                Tok::Punct(b'(') if self.header.binary && elem.is_some() && count.is_some() => {
                    let bytes = count.unwrap_or(0).saturating_mul(elem.unwrap_or(0));
                    self.raw(bytes, "a binary list")?;
                    self.expect(b')', "a binary list")?;
                    elem = None;
                }
                Tok::Punct(b'(' | b'{' | b'[') => depth += 1,
                Tok::Punct(b')' | b'}' | b']') => {
                    depth = depth
                        .checked_sub(1)
                        .ok_or_else(|| self.err(format!("unexpected {}", t.show())))?;
                }
                Tok::Word(w) => {
                    if let Some(ty) = w.strip_prefix("List<").and_then(|r| r.strip_suffix('>')) {
                        elem = match ty {
                            "label" => Some(self.header.label),
                            "scalar" => Some(self.header.scalar),
                            "bool" => Some(1),
                            "vector" => Some(3 * self.header.scalar),
                            _ => None,
                        };
                    }
                    count = w.parse().ok();
                    continue;
                }
                _ => {}
            }
            count = None;
        }
    }

    /// `n` raw bytes after the cursor (no whitespace skipped).
    fn raw(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if n > self.remaining() {
            return Err(self.err_byte(
                self.pos,
                format!(
                    "{what} needs {n} bytes of binary data, but only {} are left in the file",
                    self.remaining()
                ),
            ));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// Charges `n` values of `each` bytes, declared for `what`, to the
    /// budget, after checking that the file can hold them (`min` bytes each).
    fn reserve(&self, what: impl std::fmt::Display, n: usize, min: usize, each: usize) -> Result<()> {
        if min > 0 && n > self.remaining() / min + 1 {
            return Err(self.err(format!(
                "{what}: {n} declared, more than the {} bytes left in the file can hold",
                self.remaining()
            )));
        }
        let bytes = (n as u64).saturating_mul(each as u64);
        let name = self.path.file_name().map(|n| n.to_string_lossy()).unwrap_or_default();
        self.budget.charge(format_args!("{name}: {what} ({n} declared)"), bytes)
    }

    /// The opening of a list: its count (`None` for an ASCII list without
    /// one), and whether it is a uniform `N{value}`.
    fn open_list(&mut self, what: impl std::fmt::Display) -> Result<(Option<usize>, bool)> {
        match self.next()? {
            Tok::Punct(b'(') if !self.header.binary => Ok((None, false)),
            Tok::Word(w) => {
                let n = w
                    .parse()
                    .map_err(|_| self.err(format!("expected the size of {what}, found '{}'", clip(w))))?;
                match self.next()? {
                    Tok::Punct(b'(') => Ok((Some(n), false)),
                    Tok::Punct(b'{') => Ok((Some(n), true)),
                    t => Err(self.err(format!("expected '(' to open {what}, found {}", t.show()))),
                }
            }
            t => Err(self.err(format!("expected the size of {what}, found {}", t.show()))),
        }
    }

    /// One ASCII label, below `limit` (or -1, as `u32::MAX`, where `minus_one`).
    fn label_text(&mut self, what: What, i: usize, limit: usize, minus_one: bool) -> Result<u32> {
        match self.next()? {
            Tok::Word(w) => match w.parse::<i64>() {
                Ok(-1) if minus_one => Ok(u32::MAX),
                Ok(v) if v >= 0 && (v as u64) < limit as u64 => Ok(v as u32),
                Ok(v) => Err(self.err(format!("{} is {v}, outside 0..{limit}", what.at(i)))),
                Err(_) => Err(self.err(format!("{}: expected a label, found '{}'", what.at(i), clip(w)))),
            },
            t => Err(self.err(format!("{}: expected a label, found {}", what.at(i), t.show()))),
        }
    }

    fn label_bin(&self, c: &[u8], at: usize, what: What, i: usize, limit: usize, minus_one: bool) -> Result<u32> {
        let v = if self.header.label == 8 {
            self.header.endian.i64(c)
        } else {
            self.header.endian.i32(c) as i64
        };
        match v {
            -1 if minus_one => Ok(u32::MAX),
            v if v >= 0 && (v as u64) < limit as u64 => Ok(v as u32),
            v => Err(self.err_byte(at, format!("{} is {v}, outside 0..{limit}", what.at(i)))),
        }
    }

    /// A list of labels (`what` names one, `limit` bounds them): `N(...)`,
    /// `N{v}`, or in ASCII `(...)`.
    pub fn labels(&mut self, what: What, limit: usize, minus_one: bool) -> Result<Vec<u32>> {
        let (n, uniform) = self.open_list(what)?;
        if uniform {
            let n = n.unwrap_or(0);
            self.reserve(what, n, 0, 4)?;
            let v = self.label_text(what, 0, limit, minus_one)?;
            self.expect(b'}', &what.to_string())?;
            return Ok(vec![v; n]);
        }
        let mut out = Vec::new();
        if self.header.binary {
            let n = n.unwrap_or(0);
            let size = self.header.label;
            self.reserve(what, n, size, 4)?;
            let at = self.pos;
            let raw = self.raw(n * size, &what.to_string())?;
            out.reserve_exact(n);
            for (i, c) in raw.chunks_exact(size).enumerate() {
                out.push(self.label_bin(c, at + i * size, what, i, limit, minus_one)?);
            }
            self.close(what)?;
            return Ok(out);
        }
        if let Some(n) = n {
            self.reserve(what, n, 2, 4)?;
            out.reserve_exact(n);
            for i in 0..n {
                out.push(self.label_text(what, i, limit, minus_one)?);
            }
            self.close(what)?;
        } else {
            while self.peek()? != Tok::Punct(b')') {
                self.reserve(what, 1, 2, 4)?;
                let i = out.len();
                out.push(self.label_text(what, i, limit, minus_one)?);
            }
            self.next()?;
        }
        Ok(out)
    }

    /// The `)` that ends a list.
    fn close(&mut self, what: What) -> Result<()> {
        match self.next()? {
            Tok::Punct(b')') => Ok(()),
            t => Err(self.err(format!("expected ')' to end {what}, found {}", t.show()))),
        }
    }

    fn scalar_text(&mut self, i: usize) -> Result<f64> {
        match self.next()? {
            Tok::Word(w) => w
                .parse()
                .map_err(|_| self.err(format!("point {i}: expected a coordinate, found '{}'", clip(w)))),
            t => Err(self.err(format!("point {i}: expected a coordinate, found {}", t.show()))),
        }
    }

    /// The points: `N((x y z) ...)`, or `N(` and 3N raw scalars `)`.
    pub fn points(&mut self) -> Result<Vec<[f64; 3]>> {
        let (n, uniform) = self.open_list("points")?;
        if uniform {
            return Err(self.err("a uniform list of points (N{...}) puts every point in one place"));
        }
        let mut out = Vec::new();
        if self.header.binary {
            let n = n.unwrap_or(0);
            let s = self.header.scalar;
            self.reserve("points", n, 3 * s, 24)?;
            let raw = self.raw(n * 3 * s, "points")?;
            let e = self.header.endian;
            let get = |c: &[u8]| if s == 8 { e.f64(c) } else { e.f32(c) as f64 };
            out.reserve_exact(n);
            out.extend(
                raw.chunks_exact(3 * s)
                    .map(|p| [get(&p[..s]), get(&p[s..2 * s]), get(&p[2 * s..])]),
            );
            self.expect(b')', "points")?;
            return Ok(out);
        }
        if let Some(n) = n {
            self.reserve("points", n, 7, 24)?;
            out.reserve_exact(n);
        }
        loop {
            match self.next()? {
                Tok::Punct(b')') => break,
                Tok::Punct(b'(') => {}
                t => {
                    return Err(self.err(format!(
                        "point {}: expected '(' or the list's closing ')', found {}",
                        out.len(),
                        t.show()
                    )));
                }
            }
            if n.is_none() {
                self.reserve("points", 1, 7, 24)?;
            }
            let i = out.len();
            out.push([self.scalar_text(i)?, self.scalar_text(i)?, self.scalar_text(i)?]);
            self.expect(b')', "a point")?;
        }
        if let Some(n) = n.filter(|&n| n != out.len()) {
            return Err(self.err(format!("the list declares {n} points but holds {}", out.len())));
        }
        Ok(out)
    }

    /// The faces of a `faceList`: `N(k(a b c ...) ...)`, each face binary
    /// (`k(` raw labels `)`) in a binary file; `limit` bounds the labels.
    pub fn face_list(&mut self, limit: usize) -> Result<(Vec<usize>, Vec<u32>)> {
        let (n, uniform) = self.open_list("faces")?;
        if uniform {
            return Err(self.err("a uniform list of faces (N{...}) repeats one face"));
        }
        let mut offsets = vec![0usize];
        let mut conn = Vec::new();
        if let Some(n) = n {
            self.reserve("faces", n, 4, 8 + 16)?;
            offsets.reserve_exact(n);
        }
        loop {
            let f = offsets.len() - 1;
            if self.peek()? == Tok::Punct(b')') {
                self.next()?;
                break;
            }
            let what = What {
                list: "face",
                item: Some(f),
            };
            let face = self.labels(what, limit, false)?;
            conn.extend_from_slice(&face);
            offsets.push(conn.len());
        }
        if let Some(n) = n.filter(|&n| n != offsets.len() - 1) {
            return Err(self.err(format!("the list declares {n} faces but holds {}", offsets.len() - 1)));
        }
        Ok((offsets, conn))
    }

    /// The faces of a `faceCompactList`: the offsets (faces + 1), then the
    /// labels.
    pub fn face_compact_list(&mut self, limit: usize) -> Result<(Vec<usize>, Vec<u32>)> {
        let offsets = self.labels(What::list("face offset"), u32::MAX as usize, false)?;
        let line = self.tok_line;
        let conn = self.labels(What::list("face point"), limit, false)?;
        let bad = |msg: String| Error::parse(self.path, Some(Location::Line(line)), msg);
        if offsets.is_empty() {
            if !conn.is_empty() {
                return Err(bad(format!("{} face points but no face offsets", conn.len())));
            }
            return Ok((vec![0], conn));
        }
        if offsets[0] != 0 {
            return Err(bad(format!("the first face offset is {}, not 0", offsets[0])));
        }
        if let Some(f) = offsets.windows(2).position(|w| w[1] < w[0]) {
            return Err(bad(format!(
                "face offset {} ({}) is below the one before it ({})",
                f + 1,
                offsets[f + 1],
                offsets[f]
            )));
        }
        let last = offsets.last().map_or(0, |&o| o as usize);
        if last != conn.len() {
            return Err(bad(format!(
                "the face offsets end at {last}, but the file has {} face points",
                conn.len()
            )));
        }
        Ok((offsets.into_iter().map(|o| o as usize).collect(), conn))
    }

    /// Nothing but comments may follow the data.
    pub fn end(&mut self) -> Result<()> {
        match self.next()? {
            Tok::End => Ok(()),
            t => Err(self.err(format!("unexpected {} after the data", t.show()))),
        }
    }
}

/// One entry of a `boundary` or zones file: its name and, per keyword, the
/// first word of the value; `labels` gets the label list of `list_key`.
pub(super) struct DictEntry<'a> {
    pub name: &'a str,
    pub line: usize,
    pub words: Vec<(&'a str, &'a str)>,
    pub labels: Option<Vec<u32>>,
}

impl<'a> DictEntry<'a> {
    pub fn get(&self, key: &str) -> Option<&'a str> {
        self.words.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
    }
}

impl<'a> Lexer<'a> {
    /// A list of named dictionaries, `N(name{key value; ...} ...)`, as the
    /// `boundary` and zones files hold; `list_key` (`cellLabels`) names the
    /// label list each one holds, below `limit`.
    pub fn dict_list(&mut self, list_key: Option<&str>, limit: usize) -> Result<Vec<DictEntry<'a>>> {
        let n = match self.peek()? {
            Tok::Punct(b'(') => {
                self.next()?;
                None
            }
            _ => {
                let n = self.count("entries")?;
                self.expect(b'(', "the list of entries")?;
                Some(n)
            }
        };
        let mut out = Vec::new();
        loop {
            let name = match self.next()? {
                Tok::Punct(b')') => break,
                Tok::Word(w) | Tok::Str(w) => w,
                t => return Err(self.err(format!("expected an entry's name, found {}", t.show()))),
            };
            let line = self.tok_line;
            self.expect(b'{', &format!("entry '{}'", clip(name)))?;
            let mut e = DictEntry {
                name,
                line,
                words: Vec::new(),
                labels: None,
            };
            loop {
                let key = match self.next()? {
                    Tok::Punct(b'}') => break,
                    Tok::Word(w) => w,
                    t => {
                        return Err(self.err(format!(
                            "expected a keyword in entry '{}', found {}",
                            clip(name),
                            t.show()
                        )));
                    }
                };
                if Some(key) == list_key {
                    if let Tok::Word(w) = self.peek()?
                        && w.starts_with("List<")
                    {
                        self.next()?;
                    }
                    let what = format!("{}'s {key} entry", clip(name));
                    e.labels = Some(self.labels(What::list(&what), limit, false)?);
                    self.expect(b';', &what)?;
                    continue;
                }
                match self.peek()? {
                    Tok::Word(v) | Tok::Str(v) => e.words.push((key, v)),
                    _ => {}
                }
                self.skip_value()?;
            }
            out.push(e);
        }
        if let Some(n) = n.filter(|&n| n != out.len()) {
            return Err(self.err(format!("the list declares {n} entries but holds {}", out.len())));
        }
        Ok(out)
    }
}
