//! Mutations of a seed file, driven by a seeded PCG generator so that every case is
//! reproducible from `(FEMTO_FUZZ_SEED, target, case number)`.
//!
//! Byte mutations (every reader): bit flips, bytes replaced by interesting values, 4- and
//! 8-byte aligned words replaced by interesting integers (0, -1, 0x7FFFFFFF, -2^31,
//! 0xFFFFFFF0, ...) or floats (NaN, ±Inf, 1e300, -1, 0), truncation, duplication or removal
//! of a range, and splicing with a range of another seed. Half of the offsets are drawn from
//! the first 4 KiB, where headers and metadata live, half from the whole file.
//!
//! Text mutations (TOML and CSV): a numeric literal replaced by an extreme one (`nan`, `inf`,
//! `1e300`, `-1`, `0`, `18446744073709551615`, `4294967296`, `1e-300`), a string emptied, the
//! last element of an array removed, a line removed or duplicated, plus the byte mutations.

use rand::{Rng, RngCore};

/// Integers worth writing over a header field (little-endian, as 4 bytes).
const INTERESTING_I32: [i32; 12] = [
    0,
    1,
    -1,
    2,
    255,
    0x7FFF,
    0xFFFF,
    0x7FFF_FFFF,
    i32::MIN,
    0xFFFF_FFF0_u32 as i32,
    0x0100_0000,
    0x8000,
];

/// 8-byte integers (lengths and offsets of 64-bit formats such as HDF5).
const INTERESTING_I64: [i64; 7] = [0, -1, i64::MAX, i64::MIN, 0x7FFF_FFFF, 0xFFFF_FFFF, 1 << 40];

const INTERESTING_F32: [f32; 8] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    1e30,
    -1.0,
    0.0,
    f32::MIN_POSITIVE,
    f32::MAX,
];

const INTERESTING_F64: [f64; 8] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e300,
    -1.0,
    0.0,
    1e-300,
    f64::MAX,
];

const INTERESTING_U8: [u8; 6] = [0, 0xFF, 0x7F, 0x80, 1, b'\n'];

/// Numeric literals that TOML and CSV readers must refuse or bound (`nan` and `inf` are TOML
/// floats; the huge integers do not fit an `i64` or fit and ask for too much).
const EXTREME_NUMBERS: [&str; 14] = [
    "nan",
    "inf",
    "-inf",
    "1e300",
    "-1e300",
    "1e-300",
    "-1",
    "0",
    "-0.0",
    "18446744073709551615",
    "9223372036854775807",
    "-9223372036854775808",
    "4294967296",
    "1e19",
];

/// Finite numbers at the edges of what an f64 or a count holds (issue 28: a bin width of
/// 1e-300 ps, a keyframe at 1e308 ps, a time scale of 1e9 passed every finiteness check).
const EXTREME_FINITE: [&str; 16] = [
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "5e-324",
    "-5e-324",
    "2.2250738585072014e-308",
    "1e-300",
    "1e-6",
    "0",
    "0.0",
    "1e300",
    "1e15",
    "65536",
    "1e9",
    "4294967296",
    "9007199254740993",
];

/// A copy of one of `seeds` with one to three of its numbers replaced by values of
/// [`EXTREME_FINITE`]; nothing else changes, so the file still parses.
pub fn extreme_mutation(rng: &mut impl RngCore, seeds: &[Vec<u8>]) -> Vec<u8> {
    let mut data = seeds[rng.random_range(0..seeds.len())].clone();
    for _ in 0..rng.random_range(1..4) {
        // Values only: not the digits of a key such as `t0_ps`.
        let values: Vec<(usize, usize)> = tokens(&data)
            .numbers
            .into_iter()
            .filter(|&(a, _)| {
                a == 0 || !(data[a - 1].is_ascii_alphanumeric() || data[a - 1] == b'_')
            })
            .collect();
        if let Some((a, b)) = pick(rng, &values) {
            let new = EXTREME_FINITE[rng.random_range(0..EXTREME_FINITE.len())];
            data.splice(a..b, new.bytes());
        }
    }
    data
}

/// A mutated copy of one of `seeds` (`text` adds the text mutations).
pub fn mutate(rng: &mut impl RngCore, seeds: &[Vec<u8>], text: bool) -> Vec<u8> {
    let mut data = seeds[rng.random_range(0..seeds.len())].clone();
    // Most cases get one mutation, some a few stacked.
    let rounds = match rng.random_range(0..8) {
        0..=4 => 1,
        5 | 6 => 2,
        _ => rng.random_range(3..8),
    };
    for _ in 0..rounds {
        if text && rng.random_bool(0.6) {
            text_mutation(rng, &mut data);
        } else {
            byte_mutation(rng, &mut data, seeds);
        }
    }
    data
}

/// An offset into `len` bytes: half from the first 4 KiB (headers), half anywhere.
fn offset(rng: &mut impl RngCore, len: usize) -> usize {
    if len == 0 {
        return 0;
    }
    if rng.random_bool(0.5) {
        rng.random_range(0..len.min(4096))
    } else {
        rng.random_range(0..len)
    }
}

fn write_at(data: &mut [u8], at: usize, bytes: &[u8]) {
    let end = (at + bytes.len()).min(data.len());
    data[at..end].copy_from_slice(&bytes[..end - at]);
}

fn byte_mutation(rng: &mut impl RngCore, data: &mut Vec<u8>, seeds: &[Vec<u8>]) {
    if data.is_empty() {
        data.push(rng.random());
        return;
    }
    let len = data.len();
    match rng.random_range(0..10) {
        0 => {
            let at = offset(rng, len);
            data[at] ^= 1 << rng.random_range(0..8);
        }
        1 => {
            let at = offset(rng, len);
            data[at] = INTERESTING_U8[rng.random_range(0..INTERESTING_U8.len())];
        }
        2 => {
            let at = offset(rng, len) & !3;
            let v = INTERESTING_I32[rng.random_range(0..INTERESTING_I32.len())];
            write_at(data, at, &v.to_le_bytes());
        }
        3 => {
            // Header fields of 16 bits (HPD-TA) at 2-byte alignment.
            let at = offset(rng, len) & !1;
            let v = INTERESTING_I32[rng.random_range(0..INTERESTING_I32.len())] as i16;
            write_at(data, at, &v.to_le_bytes());
        }
        4 => {
            let at = offset(rng, len) & !7;
            let v = INTERESTING_I64[rng.random_range(0..INTERESTING_I64.len())];
            write_at(data, at, &v.to_le_bytes());
        }
        5 => {
            let at = offset(rng, len) & !3;
            let v = INTERESTING_F32[rng.random_range(0..INTERESTING_F32.len())];
            write_at(data, at, &v.to_le_bytes());
        }
        6 => {
            let at = offset(rng, len) & !7;
            let v = INTERESTING_F64[rng.random_range(0..INTERESTING_F64.len())];
            write_at(data, at, &v.to_le_bytes());
        }
        7 => {
            // Truncation.
            let at = offset(rng, len);
            data.truncate(at);
        }
        8 => {
            // Duplicate or remove a range.
            let at = offset(rng, len);
            let n = rng.random_range(1..=(len - at).min(256));
            if rng.random_bool(0.5) {
                let copy = data[at..at + n].to_vec();
                let to = offset(rng, len);
                data.splice(to..to, copy);
            } else {
                data.drain(at..at + n);
            }
        }
        _ => {
            // Splice a range of another seed over this one.
            let other = &seeds[rng.random_range(0..seeds.len())];
            if other.is_empty() {
                return;
            }
            let from = offset(rng, other.len());
            let n = rng.random_range(1..=(other.len() - from).min(512));
            let at = offset(rng, len);
            let end = (at + n).min(len);
            data.splice(at..end, other[from..from + n].iter().copied());
        }
    }
}

/// Byte ranges of the tokens a text mutation may replace.
#[derive(Default)]
struct Tokens {
    numbers: Vec<(usize, usize)>,
    strings: Vec<(usize, usize)>,
    arrays: Vec<(usize, usize)>,
    lines: Vec<(usize, usize)>,
}

/// A rough TOML/CSV tokenizer: numbers and quoted strings outside comments, innermost
/// one-line arrays, and lines.
fn tokens(data: &[u8]) -> Tokens {
    let mut t = Tokens::default();
    let mut line_start = 0;
    let mut open_brackets: Vec<usize> = Vec::new();
    let mut i = 0;
    while i < data.len() {
        let b = data[i];
        match b {
            b'\n' => {
                t.lines.push((line_start, i + 1));
                line_start = i + 1;
                open_brackets.clear();
                i += 1;
            }
            b'#' => {
                while i < data.len() && data[i] != b'\n' {
                    i += 1;
                }
            }
            b'"' => {
                let start = i;
                i += 1;
                while i < data.len() && data[i] != b'"' && data[i] != b'\n' {
                    i += 1;
                }
                if i < data.len() && data[i] == b'"' {
                    t.strings.push((start, i + 1));
                    i += 1;
                }
            }
            b'[' => {
                open_brackets.push(i);
                i += 1;
            }
            b']' => {
                if let Some(start) = open_brackets.pop() {
                    t.arrays.push((start, i + 1));
                }
                i += 1;
            }
            b'0'..=b'9' | b'-' | b'+' => {
                let start = i;
                i += 1;
                while i < data.len()
                    && matches!(
                        data[i],
                        b'0'..=b'9' | b'.' | b'e' | b'E' | b'_' | b'-' | b'+'
                    )
                {
                    i += 1;
                }
                if data[start..i].iter().any(u8::is_ascii_digit) {
                    t.numbers.push((start, i));
                }
            }
            _ => i += 1,
        }
    }
    if line_start < data.len() {
        t.lines.push((line_start, data.len()));
    }
    t
}

fn pick(rng: &mut impl RngCore, v: &[(usize, usize)]) -> Option<(usize, usize)> {
    (!v.is_empty()).then(|| v[rng.random_range(0..v.len())])
}

fn text_mutation(rng: &mut impl RngCore, data: &mut Vec<u8>) {
    let t = tokens(data);
    match rng.random_range(0..10) {
        0..=4 => {
            if let Some((a, b)) = pick(rng, &t.numbers) {
                let new = EXTREME_NUMBERS[rng.random_range(0..EXTREME_NUMBERS.len())];
                data.splice(a..b, new.bytes());
            }
        }
        5 => {
            if let Some((a, b)) = pick(rng, &t.strings) {
                data.splice(a..b, b"\"\"".iter().copied());
            }
        }
        6 | 7 => {
            // Shorten an array by its last element (or empty it).
            if let Some((a, b)) = pick(rng, &t.arrays) {
                let inner = &data[a + 1..b - 1];
                let keep = match inner.iter().rposition(|&c| c == b',') {
                    Some(comma) if rng.random_bool(0.8) => comma,
                    _ => 0,
                };
                data.splice(a + 1 + keep..b - 1, std::iter::empty());
            }
        }
        8 => {
            if let Some((a, b)) = pick(rng, &t.lines) {
                data.drain(a..b);
            }
        }
        _ => {
            if let Some((a, b)) = pick(rng, &t.lines) {
                let line = data[a..b].to_vec();
                data.splice(b..b, line);
            }
        }
    }
}

#[test]
fn text_mutations_find_numbers_strings_and_arrays() {
    let t = tokens(b"a = 1.5e3 # 7\nb = \"x\"\nc = [1, -2, 3]\n");
    assert_eq!(t.numbers, vec![(4, 9), (27, 28), (30, 32), (34, 35)]);
    assert_eq!(t.strings, vec![(18, 21)]);
    assert_eq!(t.arrays, vec![(26, 36)]);
    assert_eq!(t.lines.len(), 3);
}
