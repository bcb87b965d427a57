//! The contact sheets' built-in bitmap font: every printable ASCII character and the degree
//! sign, 5 x 9 font pixels per glyph, so that no font file or crate is needed.
//!
//! Metrics, as in a printed typeface: capitals, digits and ascenders (`b d f h k l t`) stand
//! on the baseline ([`BASELINE_ROW`]) and reach [`CAP_ROW`]; the other lower-case letters
//! are [`X_HEIGHT_ROW`] high; `g j p q y` (and `, ; _`) descend into the two rows below the
//! baseline. A lower-case `g` is therefore a short bowl with a tail below the line, never a
//! tall `9` (the demo's first font drew "edge" as "ed9e").
//!
//! The glyphs are drawn below as specimen sheets: each sheet lists its characters and then
//! nine rows of pixels, one 5-column cell per character, cells separated by a space,
//! `#` ink and `.` paper, so the font can be read and edited as a picture.

/// Width and height of one glyph cell, font pixels.
pub const GLYPH_W: usize = 5;
pub const GLYPH_H: usize = 9;
/// Top row of capitals, digits and ascenders.
pub const CAP_ROW: usize = 0;
/// Top row of the short lower-case letters (`a c e m n o r s u v w x z`, and the bowls of
/// `g p q y`).
pub const X_HEIGHT_ROW: usize = 2;
/// The last row of a glyph that stands on the line; the rows below it are descenders.
pub const BASELINE_ROW: usize = 6;

/// One specimen sheet: its characters, and `GLYPH_H` rows of `6 * n - 1` cells.
type Specimen = (&'static str, [&'static str; GLYPH_H]);

const SHEETS: [Specimen; 8] = [
    (
        "0123456789",
        [
            ".###. ..#.. .###. ##### ...#. ##### ..##. ##### .###. .###.",
            "#...# .##.. #...# ...#. ..##. #.... .#... ....# #...# #...#",
            "#..## #.#.. ....# ..#.. .#.#. ####. #.... ...#. #...# #...#",
            "#.#.# ..#.. ...#. ...#. #..#. ....# ####. ..#.. .###. .####",
            "##..# ..#.. ..#.. ....# ##### ....# #...# .#... #...# ....#",
            "#...# ..#.. .#... #...# ...#. #...# #...# .#... #...# ...#.",
            ".###. ##### ##### .###. ...#. .###. .###. .#... .###. .##..",
            "..... ..... ..... ..... ..... ..... ..... ..... ..... .....",
            "..... ..... ..... ..... ..... ..... ..... ..... ..... .....",
        ],
    ),
    (
        "ABCDEFGHIJKLM",
        [
            ".###. ####. .###. ###.. ##### ##### .###. #...# .###. ..### #...# #.... #...#",
            "#...# #...# #...# #..#. #.... #.... #...# #...# ..#.. ...#. #..#. #.... ##.##",
            "#...# #...# #.... #...# #.... #.... #.... #...# ..#.. ...#. #.#.. #.... #.#.#",
            "##### ####. #.... #...# ####. ####. #.### ##### ..#.. ...#. ##... #.... #.#.#",
            "#...# #...# #.... #...# #.... #.... #...# #...# ..#.. ...#. #.#.. #.... #...#",
            "#...# #...# #...# #..#. #.... #.... #...# #...# ..#.. #..#. #..#. #.... #...#",
            "#...# ####. .###. ###.. ##### #.... .#### #...# .###. .##.. #...# ##### #...#",
            "..... ..... ..... ..... ..... ..... ..... ..... ..... ..... ..... ..... .....",
            "..... ..... ..... ..... ..... ..... ..... ..... ..... ..... ..... ..... .....",
        ],
    ),
    (
        "NOPQRSTUVWXYZ",
        [
            "#...# .###. ####. .###. ####. .#### ##### #...# #...# #...# #...# #...# #####",
            "#...# #...# #...# #...# #...# #.... ..#.. #...# #...# #...# #...# #...# ....#",
            "##..# #...# #...# #...# #...# #.... ..#.. #...# #...# #...# .#.#. .#.#. ...#.",
            "#.#.# #...# ####. #...# ####. .###. ..#.. #...# #...# #.#.# ..#.. ..#.. ..#..",
            "#..## #...# #.... #.#.# #.#.. ....# ..#.. #...# #...# #.#.# .#.#. ..#.. .#...",
            "#...# #...# #.... #..#. #..#. ....# ..#.. #...# .#.#. #.#.# #...# ..#.. #....",
            "#...# .###. #.... .##.# #...# ####. ..#.. .###. ..#.. .#.#. #...# ..#.. #####",
            "..... ..... ..... ..... ..... ..... ..... ..... ..... ..... ..... ..... .....",
            "..... ..... ..... ..... ..... ..... ..... ..... ..... ..... ..... ..... .....",
        ],
    ),
    (
        "abcdefghijklm",
        [
            "..... #.... ..... ....# ..... ..##. ..... #.... ..#.. ...#. #.... .##.. .....",
            "..... #.... ..... ....# ..... .#..# ..... #.... ..... ..... #.... ..#.. .....",
            ".###. #.##. .###. .##.# .###. .#... .#### #.##. .##.. ..##. #..#. ..#.. ##.#.",
            "....# ##..# #.... #..## #...# ###.. #...# ##..# ..#.. ...#. #.#.. ..#.. #.#.#",
            ".#### #...# #.... #...# ##### .#... #...# #...# ..#.. ...#. ##... ..#.. #.#.#",
            "#...# #...# #...# #...# #.... .#... #...# #...# ..#.. ...#. #.#.. ..#.. #...#",
            ".#### ####. .###. .#### .###. .#... .#### #...# .###. ...#. #..#. ...## #...#",
            "..... ..... ..... ..... ..... ..... ....# ..... ..... #..#. ..... ..... .....",
            "..... ..... ..... ..... ..... ..... .###. ..... ..... .##.. ..... ..... .....",
        ],
    ),
    (
        "nopqrstuvwxyz",
        [
            "..... ..... ..... ..... ..... ..... .#... ..... ..... ..... ..... ..... .....",
            "..... ..... ..... ..... ..... ..... .#... ..... ..... ..... ..... ..... .....",
            "#.##. .###. ####. .#### #.##. .###. ####. #...# #...# #...# #...# #...# #####",
            "##..# #...# #...# #...# ##..# #.... .#... #...# #...# #...# .#.#. #...# ...#.",
            "#...# #...# #...# #...# #.... .###. .#... #...# #...# #.#.# ..#.. #...# ..#..",
            "#...# #...# #...# #...# #.... ....# .#... #..## .#.#. #.#.# .#.#. #...# .#...",
            "#...# .###. ####. .#### #.... ####. ..##. .##.# ..#.. .#.#. #...# .#### #####",
            "..... ..... #.... ....# ..... ..... ..... ..... ..... ..... ..... ....# .....",
            "..... ..... #.... ....# ..... ..... ..... ..... ..... ..... ..... .###. .....",
        ],
    ),
    (
        " !\"#$%&'()*",
        [
            "..... ..#.. .#.#. .#.#. ..#.. ##... .##.. ..#.. ...#. .#... .....",
            "..... ..#.. .#.#. .#.#. .#### ##..# #..#. ..#.. ..#.. ..#.. ..#..",
            "..... ..#.. ..... ##### #.#.. ...#. #.#.. .#... .#... ...#. #.#.#",
            "..... ..#.. ..... .#.#. .###. ..#.. .#... ..... .#... ...#. .###.",
            "..... ..#.. ..... ##### ..#.# .#... #.#.# ..... .#... ...#. #.#.#",
            "..... ..... ..... .#.#. ####. #..## #..#. ..... ..#.. ..#.. ..#..",
            "..... ..#.. ..... .#.#. ..#.. ...## .##.# ..... ...#. .#... .....",
            "..... ..... ..... ..... ..... ..... ..... ..... ..... ..... .....",
            "..... ..... ..... ..... ..... ..... ..... ..... ..... ..... .....",
        ],
    ),
    (
        "+,-./:;<=>?",
        [
            "..... ..... ..... ..... ..... ..... ..... ...#. ..... .#... .###.",
            "..#.. ..... ..... ..... ....# .##.. .##.. ..#.. ..... ..#.. #...#",
            "..#.. ..... ..... ..... ...#. .##.. .##.. .#... ##### ...#. ....#",
            "##### ..... ##### ..... ..#.. ..... ..... #.... ..... ....# ...#.",
            "..#.. ..... ..... ..... .#... .##.. .##.. .#... ##### ...#. ..#..",
            "..#.. .##.. ..... .##.. #.... .##.. .##.. ..#.. ..... ..#.. .....",
            "..... .##.. ..... .##.. ..... ..... ..#.. ...#. ..... .#... ..#..",
            "..... ..#.. ..... ..... ..... ..... .#... ..... ..... ..... .....",
            "..... .#... ..... ..... ..... ..... ..... ..... ..... ..... .....",
        ],
    ),
    (
        "@[\\]^_`{|}~°",
        [
            ".###. .###. ..... .###. ..#.. ..... .#... ...#. ..#.. .#... ..... .##..",
            "#...# .#... #.... ...#. .#.#. ..... ..#.. ..#.. ..#.. ..#.. ..... #..#.",
            "#.### .#... .#... ...#. #...# ..... ..... ..#.. ..#.. ..#.. .#... #..#.",
            "#.#.# .#... ..#.. ...#. ..... ..... ..... .#... ..#.. ...#. #.#.# .##..",
            "#.### .#... ...#. ...#. ..... ..... ..... ..#.. ..#.. ..#.. ...#. .....",
            "#.... .#... ....# ...#. ..... ..... ..... ..#.. ..#.. ..#.. ..... .....",
            ".###. .###. ..... .###. ..... ..... ..... ...#. ..#.. .#... ..... .....",
            "..... ..... ..... ..... ..... ..... ..... ..... ..#.. ..... ..... .....",
            "..... ..... ..... ..... ..... ##### ..... ..... ..#.. ..... ..... .....",
        ],
    ),
];

/// Drawn for a character the font lacks: a hollow box from the cap height to the baseline,
/// so that a missing glyph is visible, not silent.
pub const MISSING: [u8; GLYPH_H] = [0x1F, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1F, 0x00, 0x00];

/// The rows of the glyph of `c`, 5 bits each, most significant bit on the left
/// ([`MISSING`] for a character the font lacks).
pub fn glyph(c: char) -> [u8; GLYPH_H] {
    for (chars, rows) in &SHEETS {
        if let Some(k) = chars.chars().position(|x| x == c) {
            let mut out = [0u8; GLYPH_H];
            for (bits, row) in out.iter_mut().zip(rows) {
                let cell = &row.as_bytes()[k * (GLYPH_W + 1)..k * (GLYPH_W + 1) + GLYPH_W];
                *bits = cell
                    .iter()
                    .fold(0u8, |acc, &p| (acc << 1) | u8::from(p == b'#'));
            }
            return out;
        }
    }
    MISSING
}

/// Every character the font draws, in the order of its specimen sheets.
pub fn characters() -> impl Iterator<Item = char> {
    SHEETS.iter().flat_map(|(chars, _)| chars.chars())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of `c`'s glyph that hold ink.
    fn inked_rows(c: char) -> Vec<usize> {
        (0..GLYPH_H).filter(|&r| glyph(c)[r] != 0).collect()
    }

    #[test]
    fn specimen_sheets_are_well_formed_and_cover_printable_ascii() {
        let mut seen = std::collections::BTreeSet::new();
        for (chars, rows) in &SHEETS {
            let n = chars.chars().count();
            for row in rows {
                assert_eq!(row.len(), n * (GLYPH_W + 1) - 1, "sheet {chars:?}: {row}");
                for (k, b) in row.bytes().enumerate() {
                    let sep = k % (GLYPH_W + 1) == GLYPH_W;
                    assert!(
                        if sep {
                            b == b' '
                        } else {
                            b == b'#' || b == b'.'
                        },
                        "sheet {chars:?}: {row}"
                    );
                }
            }
            for c in chars.chars() {
                assert!(seen.insert(c), "{c:?} is on two sheets");
            }
        }
        for c in (' '..='~').chain(['°']) {
            assert!(seen.contains(&c), "{c:?} has no glyph");
        }
        assert_eq!(glyph('\u{2603}'), MISSING);
    }

    #[test]
    fn every_glyph_differs_from_every_other_and_from_the_missing_box() {
        let chars: Vec<char> = characters().collect();
        for (i, &a) in chars.iter().enumerate() {
            if a != ' ' {
                assert!(glyph(a).iter().any(|&r| r != 0), "{a:?} is blank");
            }
            assert_ne!(glyph(a), MISSING, "{a:?} looks like a missing glyph");
            for &b in &chars[i + 1..] {
                assert_ne!(glyph(a), glyph(b), "{a:?} and {b:?} look the same");
            }
        }
    }

    #[test]
    fn letters_and_digits_keep_to_their_lines() {
        // Capitals and digits: from the cap height to the baseline, nothing below.
        for c in ('A'..='Z').chain('0'..='9') {
            let rows = inked_rows(c);
            assert_eq!(
                rows.first(),
                Some(&CAP_ROW),
                "{c} does not reach the cap height"
            );
            assert_eq!(
                rows.last(),
                Some(&BASELINE_ROW),
                "{c} does not stand on the line"
            );
        }
        // Lower case: ascenders reach the top, short letters start at the x-height,
        // descenders go below the line and nothing else does (the first font's 'g' was as
        // tall as a digit and read as '9').
        for c in 'a'..='z' {
            let rows = inked_rows(c);
            let (top, bottom) = (rows[0], *rows.last().unwrap());
            if "bdfhklt".contains(c) {
                assert_eq!(top, CAP_ROW, "ascender {c}");
            } else if "ij".contains(c) {
                assert!(top < X_HEIGHT_ROW, "{c} has no dot");
            } else {
                assert_eq!(top, X_HEIGHT_ROW, "{c} is not x-height high");
            }
            if "gjpqy".contains(c) {
                assert!(bottom > BASELINE_ROW, "{c} does not descend");
            } else {
                assert_eq!(bottom, BASELINE_ROW, "{c} does not stand on the line");
            }
        }
    }
}
