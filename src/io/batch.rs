//! Large arrays written in batches: each batch is encoded in parallel pieces
//! while the batch before it is being written. Encoding overlaps the copy
//! into the page cache, and no array ever exists whole as bytes (at 10M
//! elements that was 0.4 GB of fresh pages per array, each one faulted in).

use std::io::{self, Write};
use std::ops::Range;

use rayon::prelude::*;

/// Pieces per batch: enough to keep every thread busy, few enough that a
/// batch of 1 MiB pieces stays in the caches' reach.
const PIECES: usize = 8;

/// Writes what `encode(range, out)` appends to `out` for items `0..n`,
/// asked for `piece` items at a time (the caller picks `piece` so that the
/// pieces' encodings simply join, e.g. whole base64 quanta). The file gets
/// exactly the bytes one call over `0..n` would give.
pub(crate) fn write_pieces(
    w: &mut dyn Write,
    n: usize,
    piece: usize,
    encode: impl Fn(Range<usize>, &mut Vec<u8>) + Sync,
) -> io::Result<()> {
    let piece = piece.max(1);
    let batches = n.div_ceil(piece * PIECES);
    let fill = |b: usize, bufs: &mut Vec<Vec<u8>>| {
        bufs.resize_with(PIECES, Vec::new);
        bufs.par_iter_mut().enumerate().for_each(|(k, buf)| {
            buf.clear();
            let p = b * PIECES + k;
            let range = (p * piece).min(n)..((p + 1) * piece).min(n);
            if !range.is_empty() {
                encode(range, buf);
            }
        });
    };
    let (mut cur, mut next) = (Vec::new(), Vec::new());
    if batches > 0 {
        fill(0, &mut cur);
    }
    for b in 0..batches {
        // the writer need not be Send: it stays on this thread while the
        // pool encodes the next batch
        let written = rayon::in_place_scope(|s| {
            if b + 1 < batches {
                s.spawn(|_| fill(b + 1, &mut next));
            }
            cur.iter().try_for_each(|buf| w.write_all(buf))
        });
        written?;
        std::mem::swap(&mut cur, &mut next);
    }
    Ok(())
}

/// `n` fixed-size records, record `i` filled by `fill(i, bytes)`, written
/// as [`write_pieces`] writes.
pub(crate) fn write_records(
    w: &mut dyn Write,
    n: usize,
    size: usize,
    fill: impl Fn(usize, &mut [u8]) + Sync,
) -> io::Result<()> {
    write_pieces(w, n, (1 << 20) / size.max(1), |range, out| {
        let start = out.len();
        out.resize(start + range.len() * size, 0);
        for (i, rec) in range.zip(out[start..].chunks_exact_mut(size)) {
            fill(i, rec);
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_join_to_the_whole_on_any_thread_count() {
        // several batches and a ragged last piece
        let n = 3 * PIECES * 1000 + 17;
        let whole: Vec<u8> = (0..n).flat_map(|i| (i as u32).to_le_bytes()).collect();
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut out = Vec::new();
            pool.install(|| {
                write_records(&mut out, n, 4, |i, r| r.copy_from_slice(&(i as u32).to_le_bytes())).unwrap();
            });
            assert_eq!(out, whole, "{threads} threads");
            let mut out = Vec::new();
            pool.install(|| {
                write_pieces(&mut out, n, 999, |r, o| {
                    r.for_each(|i| o.extend_from_slice(&(i as u32).to_le_bytes()))
                })
                .unwrap();
            });
            assert_eq!(out, whole, "{threads} threads, several batches");
        }
        let mut out = Vec::new();
        write_records(&mut out, 0, 4, |_, _| unreachable!()).unwrap();
        assert!(out.is_empty());
    }
}
