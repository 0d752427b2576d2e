//! The header of a classic netCDF file (CDF-1, 64-bit offset CDF-2, CDF-5),
//! read only to find where its data ends: libnetCDF reads the values a cut
//! file no longer holds as fill values without a word, so a reader checks
//! the length first.

/// Where a classic file's data must reach, with the variable that reaches
/// there; `Err` says why the header cannot be read. `None` for a file that
/// is not classic netCDF.
pub(crate) fn data_end(data: &[u8]) -> Option<Result<(u64, String), String>> {
    let version = match data.get(..4)? {
        [b'C', b'D', b'F', v @ (1 | 2 | 5)] => *v,
        _ => return None,
    };
    Some(Header { data, at: 4, version }.end())
}

struct Header<'a> {
    data: &'a [u8],
    at: usize,
    version: u8,
}

const DIMENSION: u64 = 0x0A;
const VARIABLE: u64 = 0x0B;
const ATTRIBUTE: u64 = 0x0C;
/// numrecs of a file still being written
const STREAMING: u64 = 0xFFFF_FFFF;

impl Header<'_> {
    fn bytes(&mut self, n: u64) -> Result<&[u8], String> {
        let end = usize::try_from(n)
            .ok()
            .and_then(|n| self.at.checked_add(n))
            .filter(|&e| e <= self.data.len());
        let Some(end) = end else {
            return Err(format!("the header is cut at byte {}", self.data.len()));
        };
        let b = &self.data[self.at..end];
        self.at = end;
        Ok(b)
    }

    fn u32(&mut self) -> Result<u64, String> {
        Ok(u64::from(u32::from_be_bytes(
            self.bytes(4)?.try_into().expect("4 bytes"),
        )))
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_be_bytes(self.bytes(8)?.try_into().expect("8 bytes")))
    }

    /// A count: 4 bytes, 8 in CDF-5.
    fn count(&mut self) -> Result<u64, String> {
        if self.version == 5 { self.u64() } else { self.u32() }
    }

    fn offset(&mut self) -> Result<u64, String> {
        if self.version == 1 { self.u32() } else { self.u64() }
    }

    fn name(&mut self) -> Result<String, String> {
        let n = self.count()?;
        let s = String::from_utf8_lossy(self.bytes(n)?).into_owned();
        self.bytes((4 - n % 4) % 4)?;
        Ok(s)
    }

    /// A list's tag and length; an absent list is two zeros.
    fn list(&mut self, tag: u64) -> Result<u64, String> {
        let (t, n) = (self.u32()?, self.count()?);
        match t {
            0 if n == 0 => Ok(0),
            t if t == tag => Ok(n),
            t => Err(format!("list tag {t:#x} where {tag:#x} belongs")),
        }
    }

    fn attributes(&mut self) -> Result<(), String> {
        for _ in 0..self.list(ATTRIBUTE)? {
            self.name()?;
            let size = type_size(self.u32()?)?;
            let n = self.count()?.checked_mul(size).ok_or("an attribute's size overflows")?;
            self.bytes(n.div_ceil(4) * 4)?;
        }
        Ok(())
    }

    fn end(mut self) -> Result<(u64, String), String> {
        let numrecs = self.count()?;
        let numrecs = if numrecs == STREAMING && self.version != 5 {
            0
        } else {
            numrecs
        };
        let ndims = self.list(DIMENSION)?;
        let mut dims = Vec::new();
        for _ in 0..ndims {
            self.name()?;
            dims.push(self.count()?);
        }
        self.attributes()?;
        // (name, begin, bytes of one record or of the whole variable, is a record variable)
        let mut vars = Vec::new();
        for _ in 0..self.list(VARIABLE)? {
            let name = self.name()?;
            let rank = self.count()?;
            let mut size = 1u64;
            let mut record = false;
            for k in 0..rank {
                let id = if self.version == 5 { self.u64()? } else { self.u32()? };
                let len = *usize::try_from(id)
                    .ok()
                    .and_then(|i| dims.get(i))
                    .ok_or(format!("variable {name} names dimension {id} of {ndims}"))?;
                if len == 0 && k == 0 {
                    record = true;
                } else {
                    size = size
                        .checked_mul(len)
                        .ok_or(format!("variable {name}'s size overflows"))?;
                }
            }
            self.attributes()?;
            size = size
                .checked_mul(type_size(self.u32()?)?)
                .ok_or(format!("variable {name}'s size overflows"))?;
            self.count()?; // vsize: capped at 2^32 - 1 in CDF-1/2, so computed instead
            let begin = self.offset()?;
            vars.push((name, begin, size, record));
        }
        let records: Vec<_> = vars.iter().filter(|v| v.3).collect();
        // one record variable is not padded; several are, each to 4 bytes
        let recsize: u64 = if records.len() == 1 {
            records[0].2
        } else {
            records.iter().map(|v| v.2.div_ceil(4) * 4).sum()
        };
        let mut end = (self.at as u64, "the header".to_string());
        for (name, begin, size, record) in &vars {
            let reach = if *record {
                if numrecs == 0 {
                    continue;
                }
                (numrecs - 1)
                    .checked_mul(recsize)
                    .and_then(|r| r.checked_add(*begin))
                    .and_then(|r| r.checked_add(*size))
            } else {
                begin.checked_add(*size)
            };
            let reach = reach.ok_or(format!("variable {name} reaches beyond any file"))?;
            if reach > end.0 {
                end = (reach, format!("variable {name}"));
            }
        }
        Ok(end)
    }
}

fn type_size(t: u64) -> Result<u64, String> {
    Ok(match t {
        1 | 2 | 7 => 1,
        3 | 8 => 2,
        4 | 5 | 9 => 4,
        6 | 10 | 11 => 8,
        t => return Err(format!("unknown netCDF type {t}")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A CDF-1 file with one fixed and one record variable, by the format's grammar.
    fn file(numrecs: u32) -> Vec<u8> {
        let mut b = b"CDF\x01".to_vec();
        let w = |b: &mut Vec<u8>, v: u32| b.extend(v.to_be_bytes());
        w(&mut b, numrecs);
        w(&mut b, 0x0A);
        w(&mut b, 2);
        for (name, len) in [("n", 3u32), ("t", 0)] {
            w(&mut b, 1);
            b.extend(name.as_bytes());
            b.extend([0, 0, 0]);
            w(&mut b, len);
        }
        w(&mut b, 0);
        w(&mut b, 0);
        w(&mut b, 0x0B);
        w(&mut b, 2);
        for (name, dims, begin) in [("x", vec![0u32], HEADER), ("v", vec![1, 0], HEADER + 24)] {
            w(&mut b, 1);
            b.extend(name.as_bytes());
            b.extend([0, 0, 0]);
            w(&mut b, dims.len() as u32);
            for d in dims {
                w(&mut b, d);
            }
            w(&mut b, 0);
            w(&mut b, 0);
            w(&mut b, 6);
            w(&mut b, 24);
            w(&mut b, begin);
        }
        assert_eq!(b.len(), HEADER as usize);
        b
    }

    const HEADER: u32 = 132;

    #[test]
    fn data_end_counts_fixed_and_record_variables() {
        // with no records the fixed variable x (3 doubles) ends the data
        assert_eq!(data_end(&file(0)), Some(Ok((132 + 24, "variable x".into()))));
        // two records of v, 3 doubles each
        assert_eq!(data_end(&file(2)), Some(Ok((132 + 24 + 2 * 24, "variable v".into()))));
        assert!(data_end(&file(2)[..30]).unwrap().is_err(), "a cut header is an error");
        assert_eq!(data_end(b"HDF5...."), None);
    }
}
