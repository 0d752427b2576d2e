//! Binary payloads of VTK XML files: raw or base64 bytes, with a byte-count
//! header or VTK's compressed-block header (`vtkZLibDataCompressor`,
//! `vtkLZ4DataCompressor`, `vtkLZMADataCompressor`).
//!
//! Compressed layout: `[nblocks, blocksize, lastsize, csize_0 .. csize_{n-1}]`
//! in the file's header type (UInt32 or UInt64), then the compressed blocks
//! back to back; every block but the last inflates to `blocksize` bytes, the
//! last to `lastsize` (or `blocksize` when `lastsize` is 0).

use std::io::{Read, Write};

use super::lex::{Endian, Scalar};
use super::limits::Budget;

/// The compressors VTK ships.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Codec {
    Zlib,
    Lz4,
    Lzma,
}

impl Codec {
    pub fn from_vtk(name: &str) -> Option<Codec> {
        match name {
            "vtkZLibDataCompressor" => Some(Codec::Zlib),
            "vtkLZ4DataCompressor" => Some(Codec::Lz4),
            "vtkLZMADataCompressor" => Some(Codec::Lzma),
            _ => None,
        }
    }

    /// Inflate `input` to exactly `size` bytes. A block that could not
    /// inflate to `size` is refused before decoding, and decoding stops at
    /// `size`: a forged stream never allocates more than its header says.
    fn inflate(self, input: &[u8], size: usize) -> Result<Vec<u8>, String> {
        let most = self.most(input.len());
        if size > most {
            return Err(format!(
                "its header says it inflates to {size} bytes, more than {} bytes of {self:?} data can hold ({most})",
                input.len()
            ));
        }
        let out = match self {
            Codec::Zlib => {
                let mut out = Vec::with_capacity(size);
                flate2::read::ZlibDecoder::new(input)
                    .take(size as u64 + 1)
                    .read_to_end(&mut out)
                    .map_err(|e| format!("zlib: {e}"))?;
                out
            }
            Codec::Lz4 => lz4_flex::block::decompress(input, size).map_err(|e| format!("LZ4: {e}"))?,
            Codec::Lzma => {
                // lzma-rs keeps a whole LZMA2 run in memory before it writes
                // any of it, so the run's size is read from its chunk
                // headers first
                let declared = xz_unpacked_size(input).map_err(|m| format!("LZMA: {m}"))?;
                if declared > size as u64 {
                    return Err(format!(
                        "LZMA: its chunks inflate to {declared} bytes, the block header says {size}"
                    ));
                }
                let mut out = Limited {
                    buf: Vec::with_capacity(size),
                    limit: size,
                };
                lzma_rs::xz_decompress(&mut std::io::BufReader::new(input), &mut out)
                    .map_err(|e| format!("LZMA: {e}"))?;
                out.buf
            }
        };
        if out.len() != size {
            return Err(format!(
                "a block inflates to {} bytes, its header says {size}",
                out.len()
            ));
        }
        Ok(out)
    }

    /// The most bytes `input` can inflate to: deflate's best case is 258
    /// bytes from a 2-bit code (1032:1), LZ4's a 255-byte length run per
    /// input byte; LZMA's is only known from its chunk headers.
    fn most(self, n: usize) -> usize {
        match self {
            Codec::Zlib => n.saturating_mul(1032).saturating_add(1 << 10),
            Codec::Lz4 => n.saturating_mul(256).saturating_add(1 << 10),
            Codec::Lzma => usize::MAX,
        }
    }
}

/// What an xz stream (VTK's LZMA blocks: `lzma_easy_buffer_encode`) inflates
/// to, summed from its LZMA2 chunk headers without decoding: each chunk
/// states its unpacked size. Errors for a stream that is not xz with LZMA2
/// chunks, which the decoder would refuse too.
fn xz_unpacked_size(b: &[u8]) -> Result<u64, String> {
    const MAGIC: &[u8] = &[0xfd, b'7', b'z', b'X', b'Z', 0];
    let short = || "the stream ends early (truncated?)".to_string();
    if b.len() < 12 || &b[..6] != MAGIC {
        return Err("not an xz stream".into());
    }
    let check = match b[7] & 0x0f {
        0 => 0,
        c => 4usize << ((c - 1) / 3),
    };
    let mut at = 12;
    let mut total = 0u64;
    loop {
        let head = *b.get(at).ok_or_else(short)?;
        if head == 0 {
            // the index: no more blocks
            return Ok(total);
        }
        let block = at;
        at += (head as usize + 1) * 4;
        loop {
            let c = *b.get(at).ok_or_else(short)?;
            let word = |i: usize| -> Result<usize, String> {
                let s = b.get(i..i + 2).ok_or_else(short)?;
                Ok(u16::from_be_bytes([s[0], s[1]]) as usize + 1)
            };
            match c {
                0 => {
                    at += 1;
                    break;
                }
                1 | 2 => {
                    let n = word(at + 1)?;
                    total += n as u64;
                    at += 3 + n;
                }
                0x80.. => {
                    let unpacked = ((c as usize & 0x1f) << 16) + word(at + 1)?;
                    let packed = word(at + 3)?;
                    total += unpacked as u64;
                    at += 5 + usize::from(c >= 0xc0) + packed;
                }
                _ => return Err(format!("invalid LZMA2 chunk type {c}")),
            }
        }
        at = block + (at - block).next_multiple_of(4) + check;
    }
}

/// A `Write` that refuses to grow past `limit` bytes (a forged LZMA stream
/// must not fill the memory).
struct Limited {
    buf: Vec<u8>,
    limit: usize,
}

impl Write for Limited {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if self.buf.len() + b.len() > self.limit {
            return Err(std::io::Error::other("more data than the block header says"));
        }
        self.buf.extend_from_slice(b);
        Ok(b.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Error inside a payload: a message and the file offset it refers to.
pub(crate) type PResult<T> = Result<T, (usize, String)>;

/// Bytes of a payload, read front to back.
pub(crate) trait Source {
    /// The next `n` bytes; fails (without allocating `n`) if fewer are left.
    fn take(&mut self, n: usize) -> PResult<Vec<u8>>;
    /// File offset of the next byte, for errors.
    fn at(&self) -> usize;
    /// An upper bound on the bytes left.
    fn left(&self) -> usize;
}

use base64::Engine;
use base64::engine::general_purpose::STANDARD as B64;

/// Raw bytes (appended `encoding="raw"`).
pub(crate) struct RawSource<'a> {
    pub data: &'a [u8],
    pub pos: usize,
    /// File offset of `data[0]`.
    pub base: usize,
}

impl Source for RawSource<'_> {
    fn take(&mut self, n: usize) -> PResult<Vec<u8>> {
        if n > self.left() {
            return Err((
                self.at(),
                format!("the data ends {} bytes too early (truncated file?)", n - self.left()),
            ));
        }
        let s = self.data[self.pos..self.pos + n].to_vec();
        self.pos += n;
        Ok(s)
    }

    fn at(&self) -> usize {
        self.base + self.pos
    }

    fn left(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }
}

/// Base64 text decoded as one byte stream. VTK encodes the header and the
/// data as separate padded runs, other writers as one; decoding quantum by
/// quantum (4 characters to at most 3 bytes) reads both the same way.
/// Whitespace is skipped.
pub(crate) struct B64Source<'a> {
    pub text: &'a [u8],
    pub pos: usize,
    pub base: usize,
    pending: Vec<u8>,
}

fn b64_value(c: u8) -> Option<u8> {
    Some(match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => return None,
    })
}

impl<'a> B64Source<'a> {
    pub fn new(text: &'a [u8], pos: usize, base: usize) -> Self {
        B64Source {
            text,
            pos,
            base,
            pending: Vec::new(),
        }
    }

    /// Decode the next quantum into `pending`; false at the end of the text.
    fn quantum(&mut self) -> PResult<bool> {
        let mut q = [0u8; 4];
        let mut k = 0;
        let start = self.at();
        while k < 4 {
            let Some(&c) = self.text.get(self.pos) else {
                if k == 0 {
                    return Ok(false);
                }
                return Err((start, "base64 data ends inside a 4-character group (truncated?)".into()));
            };
            self.pos += 1;
            if c.is_ascii_whitespace() {
                continue;
            }
            q[k] = c;
            k += 1;
        }
        let pad = q.iter().rev().take_while(|&&c| c == b'=').count();
        if pad > 2 {
            return Err((start, "invalid base64 padding".into()));
        }
        let mut bits = 0u32;
        for (i, &c) in q.iter().enumerate() {
            let v = if i >= 4 - pad {
                0
            } else {
                b64_value(c).ok_or_else(|| {
                    (
                        start,
                        format!(
                            "invalid base64 character {:?}",
                            char::from(c).escape_default().to_string()
                        ),
                    )
                })?
            };
            bits = (bits << 6) | v as u32;
        }
        let bytes = bits.to_be_bytes();
        self.pending.extend_from_slice(&bytes[1..4 - pad]);
        Ok(true)
    }
}

impl B64Source<'_> {
    /// Decodes a long run of whole quanta (no whitespace, no padding) with
    /// the base64 crate, in parallel chunks, stopping at `quanta` quanta.
    /// Returns false when there is no such run here (or it holds an invalid
    /// character): [`quantum`](Self::quantum) then decodes, and reports
    /// errors, exactly as before.
    fn bulk(&mut self, quanta: usize) -> bool {
        const MIN: usize = 1 << 12;
        let rest = &self.text[self.pos..];
        let mut run = rest.len().min(quanta.saturating_mul(4)) / 4 * 4;
        // a padded last quantum is left to `quantum`
        if run >= 4 && rest[run - 4..run].contains(&b'=') {
            run -= 4;
        }
        if run < MIN {
            return false;
        }
        // up to the first character that is not a base64 digit (a line
        // break, padding, or garbage that `quantum` will report): the scan
        // stops there, so each character is looked at a bounded number of
        // times however often the text is wrapped
        use rayon::prelude::*;
        const SCAN: usize = 1 << 16;
        let bad = |c: &u8| b64_value(*c).is_none();
        // whole chunks in parallel (rayon's per-item search is slow), then
        // the first bad chunk byte by byte
        let clean = match rest[..run].par_chunks(SCAN).position_first(|ch| ch.iter().any(bad)) {
            Some(k) => k * SCAN + rest[k * SCAN..run].iter().position(bad).unwrap_or(0),
            None => run,
        } / 4
            * 4;
        clean >= MIN && self.decode_run(clean)
    }

    /// Decodes the next `run` characters (a multiple of 4) if they are all
    /// base64 digits.
    fn decode_run(&mut self, run: usize) -> bool {
        use rayon::prelude::*;
        const CHUNK: usize = 1 << 20;
        let text = &self.text[self.pos..self.pos + run];
        let old = self.pending.len();
        self.pending.resize(old + run / 4 * 3, 0);
        let ok = self.pending[old..]
            .par_chunks_mut(CHUNK / 4 * 3)
            .zip(text.par_chunks(CHUNK))
            .all(|(out, inp)| matches!(B64.decode_slice_unchecked(inp, out), Ok(k) if k == out.len()));
        if !ok {
            self.pending.truncate(old);
            return false;
        }
        self.pos += run;
        true
    }
}

impl Source for B64Source<'_> {
    fn take(&mut self, n: usize) -> PResult<Vec<u8>> {
        if n > self.left() {
            return Err((
                self.at(),
                format!(
                    "the base64 data holds at most {} more bytes, {n} are needed (truncated file?)",
                    self.left()
                ),
            ));
        }
        while self.pending.len() < n {
            let need = n - self.pending.len();
            if self.bulk(need.div_ceil(3)) {
                continue;
            }
            if !self.quantum()? {
                return Err((
                    self.at(),
                    format!(
                        "the base64 data ends {} bytes too early (truncated file?)",
                        n - self.pending.len()
                    ),
                ));
            }
        }
        let rest = self.pending.split_off(n);
        Ok(std::mem::replace(&mut self.pending, rest))
    }

    fn at(&self) -> usize {
        self.base + self.pos
    }

    fn left(&self) -> usize {
        self.pending.len() + self.text.len().saturating_sub(self.pos) / 4 * 3 + 3
    }
}

/// How the payload of a binary array is laid out.
#[derive(Clone, Copy)]
pub(crate) struct Layout {
    pub header: Scalar,
    pub endian: Endian,
    pub codec: Option<Codec>,
}

impl Layout {
    fn word(&self, src: &mut dyn Source, what: &str) -> PResult<usize> {
        let at = src.at();
        let b = src.take(self.header.size())?;
        let v = self.header.get_i64(self.endian, &b);
        usize::try_from(v).map_err(|_| (at, format!("{what} {} is not a size", v as u64)))
    }

    /// One array's bytes: header, then the (possibly compressed) data. `max`
    /// bounds the inflated size (what the array can hold at most); the bytes
    /// are charged to `budget` before they are allocated.
    pub fn read(&self, src: &mut dyn Source, max: usize, budget: &Budget) -> PResult<Vec<u8>> {
        let Some(codec) = self.codec else {
            let at = src.at();
            let n = self.word(src, "the byte count")?;
            if n > max {
                return Err((
                    at,
                    format!("the header says {n} bytes, more than the array can hold ({max})"),
                ));
            }
            if n > src.left() {
                return Err((
                    at,
                    format!(
                        "the header says {n} bytes, the data holds at most {} (truncated file?)",
                        src.left()
                    ),
                ));
            }
            budget
                .charge("the data", n as u64)
                .map_err(|_| (at, budget.over_msg("the data", n as u64)))?;
            return src.take(n);
        };
        let at = src.at();
        let nb = self.word(src, "the block count")?;
        let bs = self.word(src, "the block size")?;
        let last = self.word(src, "the last block size")?;
        if nb.saturating_mul(self.header.size()) > src.left() {
            return Err((
                at,
                format!("{nb} compressed blocks announced, the file is too short for them (truncated?)"),
            ));
        }
        let total = match nb {
            0 => 0,
            _ => (nb - 1)
                .saturating_mul(bs)
                .saturating_add(if last == 0 { bs } else { last }),
        };
        if total > max || (nb > 1 && last > bs) {
            return Err((
                at,
                format!(
                    "compression header: {nb} blocks of {bs} bytes (last {last}) do not fit the array ({max} bytes at most)"
                ),
            ));
        }
        let mut sizes = Vec::with_capacity(nb);
        for _ in 0..nb {
            sizes.push(self.word(src, "a compressed block size")?);
        }
        let packed = sizes.iter().fold(0usize, |a, &c| a.saturating_add(c));
        if packed > src.left() {
            return Err((
                at,
                format!(
                    "the compressed blocks are {packed} bytes, the data holds at most {} (truncated file?)",
                    src.left()
                ),
            ));
        }
        let most = sizes.iter().fold(0usize, |a, &c| a.saturating_add(codec.most(c)));
        if total > most {
            return Err((
                at,
                format!(
                    "compression header: {nb} blocks of {bs} bytes (last {last}) cannot come from \
                     {packed} bytes of {codec:?} data (at most {most} bytes)"
                ),
            ));
        }
        let what = format!("{nb} compressed blocks inflating to {total} bytes");
        budget
            .charge(&what, total as u64)
            .map_err(|_| (at, budget.over_msg(&what, total as u64)))?;
        let mut out = Vec::with_capacity(total);
        for (i, &cs) in sizes.iter().enumerate() {
            let at = src.at();
            let block = src.take(cs)?;
            let size = if i + 1 == nb && last != 0 { last } else { bs };
            let bytes = codec
                .inflate(&block, size)
                .map_err(|m| (at, format!("compressed block {i} of {nb} is corrupt or truncated: {m}")))?;
            out.extend_from_slice(&bytes);
        }
        Ok(out)
    }
}

/// The `size`-byte values of an uncompressed base64 payload, each converted
/// by `get`, decoded piece by piece in parallel straight into the output: no
/// copy of the array as bytes (at 10M elements the connectivity alone was
/// 330 MB of fresh pages, written once and read once). This reads the
/// layout VTK and meshsmooth write: the byte-count header in its own padded
/// run, then the data in one run with no line breaks. `None` for anything
/// else, for small arrays and for a count above `max` values: the caller then
/// reads the payload as bytes, which decodes every layout and names errors.
pub(crate) fn b64_values<T: Copy + Default + Send>(
    layout: &Layout,
    text: &[u8],
    max: usize,
    size: usize,
    get: impl Fn(&[u8]) -> T + Sync,
) -> Option<Vec<T>> {
    use rayon::prelude::*;
    // a multiple of 3 and of every value size, so that each piece but the
    // last is whole quanta and whole values
    const PIECE: usize = (3 * 8) << 13;
    if layout.codec.is_some() || !matches!(size, 1 | 2 | 4 | 8) {
        return None;
    }
    let start = text.iter().position(|c| !c.is_ascii_whitespace())?;
    let hsize = layout.header.size();
    let hchars = hsize.div_ceil(3) * 4;
    let header = B64.decode(text.get(start..start + hchars)?).ok()?;
    if header.len() != hsize {
        return None;
    }
    let bytes = usize::try_from(layout.header.get_i64(layout.endian, &header)).ok()?;
    if bytes < 1 << 12 || bytes % size != 0 || bytes / size > max {
        return None;
    }
    let body = text.get(start + hchars..start + hchars + bytes.div_ceil(3) * 4)?;
    let mut out = vec![T::default(); bytes / size];
    let ok = out
        .par_chunks_mut(PIECE / size)
        .zip(body.par_chunks(PIECE / 3 * 4))
        .map_init(
            || vec![0u8; PIECE],
            |buf, (o, t)| {
                // unchecked: the buffer holds a whole piece
                let whole = matches!(B64.decode_slice_unchecked(t, buf), Ok(k) if k == o.len() * size);
                if whole {
                    o.iter_mut().zip(buf.chunks_exact(size)).for_each(|(v, c)| *v = get(c));
                }
                whole
            },
        )
        .all(|ok| ok);
    ok.then_some(out)
}

/// VTK's zlib block format with a UInt64 header, as one buffer of header
/// words and one of compressed data (base64-encoded separately by the writer).
/// The blocks are independent, so they are compressed in parallel.
pub(crate) fn zlib_blocks(data: &[u8]) -> (Vec<u8>, Vec<u8>) {
    use rayon::prelude::*;
    const BS: usize = 1 << 15;
    let last = data.len() % BS;
    let compressed: Vec<Vec<u8>> = data
        .par_chunks(BS)
        .map(|b| {
            let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            enc.write_all(b).expect("writing to a Vec cannot fail");
            enc.finish().expect("writing to a Vec cannot fail")
        })
        .collect();
    let mut header: Vec<u64> = vec![compressed.len() as u64, BS as u64, last as u64];
    header.extend(compressed.iter().map(|c| c.len() as u64));
    (
        header.iter().flat_map(|w| w.to_le_bytes()).collect(),
        compressed.concat(),
    )
}

/// Base64 of `data`, encoded in parallel chunks of a multiple of 3 bytes
/// (which encode to exactly what the whole would, with no padding between).
pub(crate) fn b64_encode(data: &[u8]) -> String {
    use rayon::prelude::*;
    const CHUNK: usize = 3 << 18;
    if data.len() <= CHUNK {
        return B64.encode(data);
    }
    let mut out = vec![0u8; data.len().div_ceil(3) * 4];
    out.par_chunks_mut(CHUNK / 3 * 4)
        .zip(data.par_chunks(CHUNK))
        .for_each(|(o, d)| {
            B64.encode_slice(d, o).expect("the output holds the encoding");
        });
    String::from_utf8(out).expect("base64 is ASCII")
}

#[cfg(test)]
mod tests {
    use super::*;
    use base64::Engine;
    use base64::engine::general_purpose::STANDARD as B64;

    fn big() -> Budget {
        Budget::new(std::path::Path::new("t"), &crate::io::ReadLimits { max_bytes: 1 << 40 })
    }

    #[test]
    fn base64_runs_decode_as_one_stream() {
        let (a, b) = (B64.encode([1u8, 2, 3, 4]), B64.encode([5u8, 6]));
        let text = format!("{a}\n {b}");
        let mut s = B64Source::new(text.as_bytes(), 0, 0);
        assert_eq!(s.take(5).unwrap(), vec![1, 2, 3, 4, 5]);
        assert_eq!(s.take(1).unwrap(), vec![6]);
        assert!(s.take(1).is_err());
    }

    /// Decodes `text` one quantum at a time, as the reader did before the
    /// parallel path.
    fn quantum_by_quantum(text: &[u8], n: usize) -> PResult<Vec<u8>> {
        let mut s = B64Source::new(text, 0, 0);
        while s.pending.len() < n {
            if !s.quantum()? {
                return Err((s.at(), "short".into()));
            }
        }
        Ok(s.pending[..n].to_vec())
    }

    #[test]
    fn chunked_base64_decodes_and_encodes_as_the_whole() {
        // several 1 MiB chunks and a ragged end, after a padded header run
        let data: Vec<u8> = (0..3_500_001u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect();
        let enc = b64_encode(&data);
        assert_eq!(enc, B64.encode(&data));
        let text = format!("\n   {}{}\n  ", B64.encode(8u64.to_le_bytes()), enc);
        let mut s = B64Source::new(text.as_bytes(), 0, 0);
        assert_eq!(s.take(8).unwrap(), 8u64.to_le_bytes());
        assert_eq!(s.take(data.len()).unwrap(), data);
        // the same bytes with line breaks inside (other writers wrap lines)
        let wrapped: String = enc
            .as_bytes()
            .chunks(76 * 1000 + 3)
            .map(|c| std::str::from_utf8(c).unwrap())
            .collect::<Vec<_>>()
            .join("\n");
        let mut s = B64Source::new(wrapped.as_bytes(), 0, 0);
        assert_eq!(s.take(data.len()).unwrap(), data);
        assert_eq!(quantum_by_quantum(wrapped.as_bytes(), data.len()).unwrap(), data);
        // a bad character deep inside a run: the same error, at the same offset
        let mut bad = enc.clone().into_bytes();
        bad[2_345_678] = b'*';
        let want = quantum_by_quantum(&bad, data.len()).unwrap_err();
        let got = B64Source::new(&bad, 0, 0).take(data.len()).unwrap_err();
        assert_eq!(got, want);
        assert_eq!(got.0, 2_345_676);
    }

    #[test]
    fn fused_values_are_the_byte_paths_or_declined() {
        let vals: Vec<i64> = (0..70_001).map(|i| i * 7919 - 3).collect();
        let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let get = |c: &[u8]| Scalar::I64.get_i64(Endian::Little, c);
        for header in [Scalar::U32, Scalar::U64] {
            let layout = Layout {
                header,
                endian: Endian::Little,
                codec: None,
            };
            let count = &(bytes.len() as u64).to_le_bytes()[..header.size()];
            // VTK's layout: the header in its own padded run
            let text = format!("\n  {}{}\n  ", B64.encode(count), B64.encode(&bytes));
            let by_bytes = layout
                .read(&mut B64Source::new(text.as_bytes(), 0, 0), bytes.len(), &big())
                .unwrap();
            assert_eq!(by_bytes, bytes);
            let fused = b64_values(&layout, text.as_bytes(), vals.len(), 8, get);
            assert_eq!(fused.as_ref(), Some(&vals));
            // more values than the array may hold, header and data in one
            // run, a line break, a bad character: left to the byte path
            assert_eq!(b64_values(&layout, text.as_bytes(), vals.len() - 1, 8, get), None);
            let joined = B64.encode([count, &bytes].concat());
            assert_eq!(b64_values(&layout, joined.as_bytes(), vals.len(), 8, get), None);
            for (at, c) in [(text.len() / 2, b'\n'), (text.len() / 3, b'*')] {
                let mut bad = text.clone().into_bytes();
                bad[at] = c;
                assert_eq!(b64_values(&layout, &bad, vals.len(), 8, get), None);
            }
        }
    }

    #[test]
    fn zlib_blocks_read_back() {
        let data: Vec<u8> = (0..100_000u32).map(|i| (i % 251) as u8).collect();
        let (h, body) = zlib_blocks(&data);
        let all = [h, body].concat();
        let layout = Layout {
            header: Scalar::U64,
            endian: Endian::Little,
            codec: Some(Codec::Zlib),
        };
        let mut src = RawSource {
            data: &all,
            pos: 0,
            base: 0,
        };
        assert_eq!(layout.read(&mut src, data.len(), &big()).unwrap(), data);
        // a bound below the real size is refused before inflating
        let mut src = RawSource {
            data: &all,
            pos: 0,
            base: 0,
        };
        assert!(layout.read(&mut src, data.len() - 1, &big()).is_err());
    }
}
