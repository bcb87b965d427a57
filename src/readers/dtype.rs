//! Stored sample types of array files and their decoding into f32: unsigned and signed
//! integers of 1 to 8 bytes and IEEE floats of 2, 4 and 8 bytes, little- or big-endian.
//!
//! f32 holds every integer up to 2^24 exactly; an integer above that is rounded to the
//! nearest f32 and counted ([`Decoded::inexact`]), so that ingest can warn and record it.

/// The type of the stored samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dtype {
    U8,
    U16,
    U32,
    U64,
    I8,
    I16,
    I32,
    I64,
    F16,
    F32,
    F64,
}

impl Dtype {
    /// The NumPy name (`uint16`, `float32`).
    pub fn name(self) -> &'static str {
        match self {
            Dtype::U8 => "uint8",
            Dtype::U16 => "uint16",
            Dtype::U32 => "uint32",
            Dtype::U64 => "uint64",
            Dtype::I8 => "int8",
            Dtype::I16 => "int16",
            Dtype::I32 => "int32",
            Dtype::I64 => "int64",
            Dtype::F16 => "float16",
            Dtype::F32 => "float32",
            Dtype::F64 => "float64",
        }
    }

    /// Bytes per sample.
    pub fn size(self) -> usize {
        match self {
            Dtype::U8 | Dtype::I8 => 1,
            Dtype::U16 | Dtype::I16 | Dtype::F16 => 2,
            Dtype::U32 | Dtype::I32 | Dtype::F32 => 4,
            Dtype::U64 | Dtype::I64 | Dtype::F64 => 8,
        }
    }

    /// The type of `size` bytes, integer (signed or not) or float.
    pub fn from_parts(float: bool, signed: bool, size: usize) -> Option<Dtype> {
        Some(match (float, signed, size) {
            (true, _, 2) => Dtype::F16,
            (true, _, 4) => Dtype::F32,
            (true, _, 8) => Dtype::F64,
            (false, false, 1) => Dtype::U8,
            (false, false, 2) => Dtype::U16,
            (false, false, 4) => Dtype::U32,
            (false, false, 8) => Dtype::U64,
            (false, true, 1) => Dtype::I8,
            (false, true, 2) => Dtype::I16,
            (false, true, 4) => Dtype::I32,
            (false, true, 8) => Dtype::I64,
            _ => return None,
        })
    }

    /// Whether samples are integers.
    pub fn is_integer(self) -> bool {
        !matches!(self, Dtype::F16 | Dtype::F32 | Dtype::F64)
    }

    /// The largest value the type stores (its saturation level), `None` for floats.
    pub fn max_value(self) -> Option<f64> {
        Some(match self {
            Dtype::U8 => u8::MAX as f64,
            Dtype::U16 => u16::MAX as f64,
            Dtype::U32 => u32::MAX as f64,
            Dtype::U64 => u64::MAX as f64,
            Dtype::I8 => i8::MAX as f64,
            Dtype::I16 => i16::MAX as f64,
            Dtype::I32 => i32::MAX as f64,
            Dtype::I64 => i64::MAX as f64,
            _ => return None,
        })
    }
}

/// Samples decoded into f32, in storage order.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded {
    pub values: Vec<f32>,
    /// Integer samples that f32 does not hold exactly (above 2^24 in magnitude).
    pub inexact: usize,
    /// The largest magnitude among them (0 when none).
    pub largest_inexact: f64,
}

/// A sample's bytes (1 to 8), little-endian, in the low bytes of a u64's.
fn word(b: &[u8], big_endian: bool) -> [u8; 8] {
    let mut w = [0u8; 8];
    if big_endian {
        for (i, v) in b.iter().rev().enumerate() {
            w[i] = *v;
        }
    } else {
        w[..b.len()].copy_from_slice(b);
    }
    w
}

/// Decode `bytes` (a whole number of samples) of `dtype`, big-endian when `big_endian`.
pub fn decode(bytes: &[u8], dtype: Dtype, big_endian: bool) -> Decoded {
    let n = dtype.size();
    let word = |b: &[u8]| word(b, big_endian);
    let mut inexact = 0usize;
    let mut largest = 0f64;
    let mut int = |v: i128| -> f32 {
        let f = v as f32;
        if f as i128 != v {
            inexact += 1;
            largest = largest.max((v as f64).abs());
        }
        f
    };
    let chunks = bytes.chunks_exact(n);
    let values: Vec<f32> = match dtype {
        // The common cases first, without the generic word assembly.
        Dtype::U8 => bytes.iter().map(|&v| f32::from(v)).collect(),
        Dtype::U16 if !big_endian => chunks
            .map(|b| f32::from(u16::from_le_bytes([b[0], b[1]])))
            .collect(),
        Dtype::F32 if !big_endian => chunks
            .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
            .collect(),
        Dtype::F16 => chunks
            .map(|b| {
                let w = word(b);
                half::f16::from_le_bytes([w[0], w[1]]).to_f32()
            })
            .collect(),
        Dtype::F32 => chunks
            .map(|b| {
                let w = word(b);
                f32::from_le_bytes([w[0], w[1], w[2], w[3]])
            })
            .collect(),
        Dtype::F64 => chunks.map(|b| f64::from_le_bytes(word(b)) as f32).collect(),
        Dtype::U16 | Dtype::U32 | Dtype::U64 => chunks
            .map(|b| int(i128::from(u64::from_le_bytes(word(b)))))
            .collect(),
        Dtype::I8 | Dtype::I16 | Dtype::I32 | Dtype::I64 => chunks
            .map(|b| {
                let w = word(b);
                // Sign-extend from the sample's top byte.
                let shift = 64 - 8 * n as u32;
                let v = (i64::from_le_bytes(w) << shift) >> shift;
                int(i128::from(v))
            })
            .collect(),
    };
    Decoded {
        values,
        inexact,
        largest_inexact: largest,
    }
}

/// Bytes read at a time by [`decode_from`]: a multiple of every sample size.
const DECODE_CHUNK_BYTES: usize = 1 << 20;

/// Decode `count` samples of `dtype` read from `reader` in chunks of 1 MiB, so that the
/// stored bytes are never held whole: the f32 values are the only array allocated (the
/// caller has checked that they fit, [`super::check_decode`]). A reader that ends early is
/// an `UnexpectedEof` error.
pub fn decode_from(
    reader: &mut impl std::io::Read,
    count: usize,
    dtype: Dtype,
    big_endian: bool,
) -> std::io::Result<Decoded> {
    let size = dtype.size();
    let mut values = Vec::with_capacity(count);
    let mut inexact = 0usize;
    let mut largest = 0f64;
    let mut chunk = vec![0u8; DECODE_CHUNK_BYTES.min(count.saturating_mul(size))];
    let mut left = count;
    while left > 0 {
        let n = left.min(DECODE_CHUNK_BYTES / size);
        let bytes = &mut chunk[..n * size];
        reader.read_exact(bytes)?;
        let d = decode(bytes, dtype, big_endian);
        values.extend_from_slice(&d.values);
        inexact += d.inexact;
        largest = largest.max(d.largest_inexact);
        left -= n;
    }
    Ok(Decoded {
        values,
        inexact,
        largest_inexact: largest,
    })
}

/// One sample from its bytes, in full f64 precision (`None`: too few bytes).
pub fn value_f64(bytes: &[u8], dtype: Dtype, big_endian: bool) -> Option<f64> {
    let w = word(bytes.get(..dtype.size())?, big_endian);
    Some(match dtype {
        Dtype::F64 => f64::from_le_bytes(w),
        Dtype::F32 => f64::from(f32::from_le_bytes([w[0], w[1], w[2], w[3]])),
        Dtype::F16 => f64::from(half::f16::from_le_bytes([w[0], w[1]]).to_f32()),
        Dtype::U8 | Dtype::U16 | Dtype::U32 | Dtype::U64 => u64::from_le_bytes(w) as f64,
        _ => {
            let shift = 64 - 8 * dtype.size() as u32;
            ((i64::from_le_bytes(w) << shift) >> shift) as f64
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_decodes_in_both_byte_orders() {
        let cases: [(Dtype, Vec<u8>, f32); 11] = [
            (Dtype::U8, vec![200], 200.0),
            (Dtype::U16, 65535u16.to_le_bytes().to_vec(), 65535.0),
            (Dtype::U32, 70000u32.to_le_bytes().to_vec(), 70000.0),
            (Dtype::U64, 12345u64.to_le_bytes().to_vec(), 12345.0),
            (Dtype::I8, (-7i8).to_le_bytes().to_vec(), -7.0),
            (Dtype::I16, (-300i16).to_le_bytes().to_vec(), -300.0),
            (Dtype::I32, (-70000i32).to_le_bytes().to_vec(), -70000.0),
            (Dtype::I64, (-5i64).to_le_bytes().to_vec(), -5.0),
            (
                Dtype::F16,
                half::f16::from_f32(1.5).to_le_bytes().to_vec(),
                1.5,
            ),
            (Dtype::F32, 2.25f32.to_le_bytes().to_vec(), 2.25),
            (Dtype::F64, (-0.125f64).to_le_bytes().to_vec(), -0.125),
        ];
        for (dtype, le, want) in cases {
            assert_eq!(decode(&le, dtype, false).values, [want], "{dtype:?} <");
            let be: Vec<u8> = le.iter().rev().copied().collect();
            assert_eq!(decode(&be, dtype, true).values, [want], "{dtype:?} >");
        }
    }

    #[test]
    fn decoding_from_a_reader_in_chunks_matches_decoding_the_bytes() {
        // More than one chunk of u16, big-endian, with a remainder.
        let n = DECODE_CHUNK_BYTES / 2 + 7;
        let bytes: Vec<u8> = (0..n)
            .flat_map(|i| ((i * 31) as u16).to_be_bytes())
            .collect();
        let whole = decode(&bytes, Dtype::U16, true);
        let streamed = decode_from(&mut &bytes[..], n, Dtype::U16, true).unwrap();
        assert_eq!(streamed, whole);
        assert!(decode_from(&mut &bytes[..], 0, Dtype::U16, true)
            .unwrap()
            .values
            .is_empty());
        let short = decode_from(&mut &bytes[..3], 2, Dtype::U16, true).unwrap_err();
        assert_eq!(short.kind(), std::io::ErrorKind::UnexpectedEof);
    }

    #[test]
    fn integers_above_2_pow_24_are_counted_as_inexact() {
        let v = [16_777_216u32, 16_777_217, 5];
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let d = decode(&bytes, Dtype::U32, false);
        assert_eq!(d.inexact, 1);
        assert_eq!(d.largest_inexact, 16_777_217.0);
        assert_eq!(d.values[2], 5.0);
    }
}
