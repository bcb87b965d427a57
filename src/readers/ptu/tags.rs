//! The PTU header: the magic `PQTTTR\0\0`, an 8-byte version, then tagged entries of 48
//! bytes (a 32-byte name, an `i32` index, a `u32` type, an 8-byte value) up to `Header_End`.
//! Entries of variable length (float arrays, strings, blobs) say their byte count in the
//! value and follow it; their length is checked against what the file holds, and only the
//! strings are kept (arrays and blobs are skipped). The records start after `Header_End`.
//! Types and names are PicoQuant's (the "PicoQuant Unified Tag Dictionary").

use crate::readers::ReaderError;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// The first bytes of a PTU file.
pub const MAGIC: &[u8] = b"PQTTTR\0\0";

const TY_EMPTY8: u32 = 0xFFFF_0008;
const TY_BOOL8: u32 = 0x0000_0008;
const TY_INT8: u32 = 0x1000_0008;
const TY_BITSET64: u32 = 0x1100_0008;
const TY_COLOR8: u32 = 0x1200_0008;
const TY_FLOAT8: u32 = 0x2000_0008;
const TY_DATETIME: u32 = 0x2100_0008;
const TY_FLOAT8_ARRAY: u32 = 0x2001_FFFF;
const TY_ANSI_STRING: u32 = 0x4001_FFFF;
const TY_WIDE_STRING: u32 = 0x4002_FFFF;
const TY_BINARY_BLOB: u32 = 0xFFFF_FFFF;

/// The longest string kept, bytes (PicoQuant's comments are a few hundred).
const MAX_STRING_BYTES: u64 = 1 << 20;
/// The most entries a header may have before it is taken as corrupt.
const MAX_TAGS: usize = 100_000;

/// A tag's value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Int(i64),
    Float(f64),
    Text(String),
    /// Kept only as a mark that the tag is there (arrays, blobs, empty tags).
    Other,
}

/// The header: every tag (name, index, value) and where the records start.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    pub version: String,
    pub tags: Vec<(String, i32, Value)>,
    pub records_at: u64,
}

impl Header {
    fn get(&self, name: &str) -> Option<&Value> {
        self.tags
            .iter()
            .find(|(n, i, _)| n == name && *i < 1)
            .map(|(_, _, v)| v)
    }

    /// Whether the tag is present (whatever its value).
    pub fn has(&self, name: &str) -> bool {
        self.get(name).is_some()
    }

    /// An integer (or boolean) tag.
    pub fn int(&self, name: &str) -> Option<i64> {
        match self.get(name)? {
            Value::Int(v) => Some(*v),
            Value::Float(f) if f.fract() == 0.0 => Some(*f as i64),
            _ => None,
        }
    }

    /// A number tag (float or integer).
    pub fn float(&self, name: &str) -> Option<f64> {
        match self.get(name)? {
            Value::Float(v) => Some(*v),
            Value::Int(v) => Some(*v as f64),
            _ => None,
        }
    }

    /// A string tag.
    pub fn text(&self, name: &str) -> Option<&str> {
        match self.get(name)? {
            Value::Text(s) => Some(s),
            _ => None,
        }
    }
}

fn bad(path: &Path, key: &str, m: impl Into<String>) -> ReaderError {
    ReaderError::invalid(path, key, m)
}

/// Read the header of the PTU file `f` (at `path`, `len` bytes long).
pub fn read_header<R: Read + Seek>(
    path: &Path,
    f: &mut R,
    len: u64,
) -> Result<Header, ReaderError> {
    let io = |e: std::io::Error| bad(path, "ptu header", format!("truncated: {e}"));
    let mut head = [0u8; 16];
    f.read_exact(&mut head).map_err(io)?;
    if &head[..8] != MAGIC {
        return Err(bad(path, "ptu header", "not a PTU file (no PQTTTR magic)"));
    }
    let version = String::from_utf8_lossy(&head[8..])
        .trim_end_matches('\0')
        .trim()
        .to_string();
    let mut tags = Vec::new();
    let mut at = 16u64;
    loop {
        if tags.len() > MAX_TAGS {
            return Err(bad(
                path,
                "ptu header",
                format!("more than {MAX_TAGS} tags without Header_End"),
            ));
        }
        let mut e = [0u8; 48];
        f.read_exact(&mut e).map_err(io)?;
        at += 48;
        let name = String::from_utf8_lossy(&e[..32])
            .trim_end_matches('\0')
            .to_string();
        let index = i32::from_le_bytes(e[32..36].try_into().expect("4 bytes"));
        let ty = u32::from_le_bytes(e[36..40].try_into().expect("4 bytes"));
        let raw: [u8; 8] = e[40..48].try_into().expect("8 bytes");
        let value = match ty {
            TY_EMPTY8 => Value::Other,
            TY_BOOL8 | TY_INT8 | TY_BITSET64 | TY_COLOR8 => Value::Int(i64::from_le_bytes(raw)),
            TY_FLOAT8 | TY_DATETIME => Value::Float(f64::from_le_bytes(raw)),
            TY_FLOAT8_ARRAY | TY_ANSI_STRING | TY_WIDE_STRING | TY_BINARY_BLOB => {
                let n = u64::from_le_bytes(raw);
                if n > len.saturating_sub(at) {
                    return Err(bad(
                        path,
                        &name,
                        format!("declares {n} bytes of data, more than the file holds after it"),
                    ));
                }
                at += n;
                if ty == TY_ANSI_STRING && n <= MAX_STRING_BYTES {
                    let mut s = vec![0u8; n as usize];
                    f.read_exact(&mut s).map_err(io)?;
                    Value::Text(
                        String::from_utf8_lossy(&s)
                            .trim_end_matches('\0')
                            .to_string(),
                    )
                } else {
                    f.seek(SeekFrom::Current(n as i64)).map_err(io)?;
                    Value::Other
                }
            }
            other => {
                return Err(bad(path, &name, format!("unknown tag type 0x{other:08X}")));
            }
        };
        if name == "Header_End" {
            return Ok(Header {
                version,
                tags,
                records_at: at,
            });
        }
        tags.push((name, index, value));
    }
}

/// A header's bytes, for tests: `(name, index, type, raw value)` entries, then `Header_End`.
#[cfg(test)]
pub fn header_bytes(entries: &[(&str, i32, Value)]) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(b"1.0.00\0\0");
    let mut push = |name: &str, index: i32, ty: u32, raw: [u8; 8], extra: &[u8]| {
        let mut n = [0u8; 32];
        n[..name.len()].copy_from_slice(name.as_bytes());
        out.extend_from_slice(&n);
        out.extend_from_slice(&index.to_le_bytes());
        out.extend_from_slice(&ty.to_le_bytes());
        out.extend_from_slice(&raw);
        out.extend_from_slice(extra);
    };
    for (name, index, v) in entries {
        match v {
            Value::Int(i) => push(name, *index, TY_INT8, i.to_le_bytes(), &[]),
            Value::Float(x) => push(name, *index, TY_FLOAT8, x.to_le_bytes(), &[]),
            Value::Text(s) => {
                let mut b = s.as_bytes().to_vec();
                b.resize(s.len().next_multiple_of(8).max(8), 0);
                push(
                    name,
                    *index,
                    TY_ANSI_STRING,
                    (b.len() as u64).to_le_bytes(),
                    &b,
                );
            }
            Value::Other => push(name, *index, TY_EMPTY8, [0; 8], &[]),
        }
    }
    push("Header_End", -1, TY_EMPTY8, [0; 8], &[]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_read_back_and_a_lying_length_is_refused() {
        let bytes = header_bytes(&[
            ("MeasDesc_Resolution", -1, Value::Float(4e-12)),
            ("ImgHdr_PixX", -1, Value::Int(16)),
            ("HW_Type", -1, Value::Text("HydraHarp".into())),
        ]);
        let len = bytes.len() as u64;
        let h = read_header(Path::new("a.ptu"), &mut std::io::Cursor::new(&bytes), len).unwrap();
        assert_eq!(h.float("MeasDesc_Resolution"), Some(4e-12));
        assert_eq!(h.int("ImgHdr_PixX"), Some(16));
        assert_eq!(h.text("HW_Type"), Some("HydraHarp"));
        assert_eq!(h.records_at, len);
        // A string that claims more bytes than the file has.
        let mut lying = bytes.clone();
        let at = 16 + 2 * 48 + 40;
        lying[at..at + 8].copy_from_slice(&1_000_000u64.to_le_bytes());
        let err =
            read_header(Path::new("a.ptu"), &mut std::io::Cursor::new(&lying), len).unwrap_err();
        assert!(err.to_string().contains("HW_Type"), "{err}");
        assert!(read_header(Path::new("a.ptu"), &mut std::io::Cursor::new(b"PNG\0"), 4).is_err());
    }
}
