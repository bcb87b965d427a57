//! Contact sheets: frames of one row of a figure side by side, each above a small label strip
//! (e.g. `beta=0.6`), as one 8-bit sRGB image.
//!
//! The seed's Fig. 5 shows each effect as a row of frames at increasing speed; the demo writes
//! each row as one PNG made here. Labels are drawn with a built-in 5 x 7 pixel font (digits,
//! lower-case letters, a few signs; upper case is drawn as lower case, anything else as a
//! hollow box), so no font file or crate is needed. Pure image assembly: no I/O.

/// One frame of a sheet: `width x height` pixels of 8-bit sRGB, row-major from the top row,
/// RGB interleaved (`3 * width * height` bytes), and the text of its label.
#[derive(Clone, Copy, Debug)]
pub struct Tile<'a> {
    pub width: usize,
    pub height: usize,
    pub rgb8: &'a [u8],
    pub label: &'a str,
}

/// Layout of a sheet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SheetStyle {
    /// Pixels between tiles and around the sheet.
    pub gap_px: usize,
    /// Each font pixel is drawn as `scale x scale` pixels.
    pub label_scale: usize,
    /// Background (gaps, label strips).
    pub background: [u8; 3],
    /// Label text colour.
    pub ink: [u8; 3],
}

impl Default for SheetStyle {
    fn default() -> Self {
        SheetStyle {
            gap_px: 4,
            label_scale: 2,
            background: [24, 24, 24],
            ink: [235, 235, 235],
        }
    }
}

/// A finished sheet: `width x height` pixels of 8-bit sRGB, RGB interleaved.
#[derive(Clone, Debug, PartialEq)]
pub struct Sheet {
    pub width: usize,
    pub height: usize,
    pub rgb8: Vec<u8>,
}

/// Width and height of one font glyph, font pixels.
pub const GLYPH_W: usize = 5;
pub const GLYPH_H: usize = 7;
/// Font pixels between two glyphs.
pub const GLYPH_SPACING: usize = 1;

/// Height of the label strip under each tile, pixels: the glyph height and a margin of two
/// font pixels above and below.
pub fn label_strip_height(style: &SheetStyle) -> usize {
    (GLYPH_H + 4) * style.label_scale
}

/// Width of `text` drawn at `scale`, pixels.
pub fn text_width(text: &str, scale: usize) -> usize {
    let n = text.chars().count();
    if n == 0 {
        0
    } else {
        (n * (GLYPH_W + GLYPH_SPACING) - GLYPH_SPACING) * scale
    }
}

/// The rows of a glyph, 5 bits each, most significant bit on the left.
pub fn glyph(c: char) -> [u8; GLYPH_H] {
    match c.to_ascii_lowercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        ' ' => [0; GLYPH_H],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        ',' => [0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
        '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
        'a' => [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F],
        'b' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E],
        'c' => [0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E],
        'd' => [0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        'f' => [0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08],
        'g' => [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'h' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11],
        'i' => [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E],
        'j' => [0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0C],
        'k' => [0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12],
        'l' => [0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'm' => [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'o' => [0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E],
        'p' => [0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10],
        'q' => [0x00, 0x00, 0x0D, 0x13, 0x0F, 0x01, 0x01],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'u' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D],
        'v' => [0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'w' => [0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A],
        'x' => [0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11],
        'y' => [0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        'z' => [0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F],
        // Unknown characters: a hollow box, so a missing glyph is visible, not silent.
        _ => [0x1F, 0x11, 0x11, 0x11, 0x11, 0x11, 0x1F],
    }
}

/// Draw `text` into an RGB8 image of `img_width` pixels per row with its top-left corner at
/// `(x0, y0)`, each font pixel `scale x scale`; pixels outside the image are skipped.
pub fn draw_text(
    img: &mut [u8],
    img_width: usize,
    x0: usize,
    y0: usize,
    text: &str,
    scale: usize,
    ink: [u8; 3],
) {
    let img_height = if img_width == 0 {
        0
    } else {
        img.len() / (3 * img_width)
    };
    for (k, c) in text.chars().enumerate() {
        let gx = x0 + k * (GLYPH_W + GLYPH_SPACING) * scale;
        for (row, bits) in glyph(c).iter().enumerate() {
            for col in 0..GLYPH_W {
                if bits & (1 << (GLYPH_W - 1 - col)) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let (x, y) = (gx + col * scale + dx, y0 + row * scale + dy);
                        if x < img_width && y < img_height {
                            let i = 3 * (y * img_width + x);
                            img[i..i + 3].copy_from_slice(&ink);
                        }
                    }
                }
            }
        }
    }
}

/// Lay `tiles` out left to right, each above its label strip (label centred, clipped to the
/// tile's width), with `style.gap_px` between tiles and around the sheet. Tiles may differ
/// in size; they are aligned at the top. Panics if a tile's buffer is not
/// `3 * width * height` bytes (a caller bug).
pub fn contact_sheet(tiles: &[Tile<'_>], style: &SheetStyle) -> Sheet {
    let gap = style.gap_px;
    let strip = label_strip_height(style);
    let tile_h = tiles.iter().map(|t| t.height).max().unwrap_or(0);
    let width = gap + tiles.iter().map(|t| t.width + gap).sum::<usize>();
    let height = 2 * gap + tile_h + strip;
    let mut rgb8 = Vec::with_capacity(3 * width * height);
    for _ in 0..width * height {
        rgb8.extend_from_slice(&style.background);
    }
    let mut x0 = gap;
    for t in tiles {
        assert_eq!(
            t.rgb8.len(),
            3 * t.width * t.height,
            "contact_sheet: tile buffer size"
        );
        for y in 0..t.height {
            let src = &t.rgb8[3 * y * t.width..3 * (y + 1) * t.width];
            let d = 3 * ((gap + y) * width + x0);
            rgb8[d..d + 3 * t.width].copy_from_slice(src);
        }
        // Label centred under the tile, clipped to the tile's columns.
        let text_w = text_width(t.label, style.label_scale);
        let lx = x0 + t.width.saturating_sub(text_w) / 2;
        let ly = gap + tile_h + 2 * style.label_scale;
        let mut label_img = vec![0u8; 3 * t.width * strip];
        for px in label_img.chunks_exact_mut(3) {
            px.copy_from_slice(&style.background);
        }
        draw_text(
            &mut label_img,
            t.width,
            lx - x0,
            ly - (gap + tile_h),
            t.label,
            style.label_scale,
            style.ink,
        );
        for y in 0..strip {
            let src = &label_img[3 * y * t.width..3 * (y + 1) * t.width];
            let d = 3 * ((gap + tile_h + y) * width + x0);
            rgb8[d..d + 3 * t.width].copy_from_slice(src);
        }
        x0 += t.width + gap;
    }
    Sheet {
        width,
        height,
        rgb8,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solid(w: usize, h: usize, c: [u8; 3]) -> Vec<u8> {
        (0..w * h).flat_map(|_| c).collect()
    }

    fn px(s: &Sheet, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * s.width + x);
        [s.rgb8[i], s.rgb8[i + 1], s.rgb8[i + 2]]
    }

    #[test]
    fn tiles_land_side_by_side_with_gaps() {
        let style = SheetStyle::default();
        let (a, b) = (solid(10, 6, [255, 0, 0]), solid(7, 4, [0, 0, 255]));
        let tiles = [
            Tile {
                width: 10,
                height: 6,
                rgb8: &a,
                label: "",
            },
            Tile {
                width: 7,
                height: 4,
                rgb8: &b,
                label: "",
            },
        ];
        let s = contact_sheet(&tiles, &style);
        let g = style.gap_px;
        assert_eq!(s.width, g + 10 + g + 7 + g);
        assert_eq!(s.height, g + 6 + label_strip_height(&style) + g);
        assert_eq!(s.rgb8.len(), 3 * s.width * s.height);
        // Corners of each tile, and the pixels just outside them.
        assert_eq!(px(&s, g, g), [255, 0, 0]);
        assert_eq!(px(&s, g + 9, g + 5), [255, 0, 0]);
        assert_eq!(px(&s, g + 10, g), style.background);
        let bx = g + 10 + g;
        assert_eq!(px(&s, bx, g), [0, 0, 255]);
        assert_eq!(px(&s, bx + 6, g + 3), [0, 0, 255]);
        // The shorter tile leaves background below it.
        assert_eq!(px(&s, bx, g + 4), style.background);
        assert_eq!(px(&s, 0, 0), style.background);
    }

    #[test]
    fn a_minus_sign_is_one_bar_of_five_font_pixels() {
        // '-' is the single row 11111 at row 3: 5 * scale^2 ink pixels, in one band of
        // `scale` rows starting 3 * scale below the text's top.
        let style = SheetStyle {
            label_scale: 3,
            ..SheetStyle::default()
        };
        let tile = solid(40, 5, [0, 0, 0]);
        let s = contact_sheet(
            &[Tile {
                width: 40,
                height: 5,
                rgb8: &tile,
                label: "-",
            }],
            &style,
        );
        let ink: Vec<(usize, usize)> = (0..s.height)
            .flat_map(|y| (0..s.width).map(move |x| (x, y)))
            .filter(|&(x, y)| px(&s, x, y) == style.ink)
            .collect();
        assert_eq!(ink.len(), 5 * 3 * 3);
        let top = style.gap_px + 5 + 2 * 3;
        assert!(ink.iter().all(|&(_, y)| y >= top + 9 && y < top + 12));
        // Centred: as many tile columns left of the bar as right of it (within one pixel).
        let (xmin, xmax) = (
            ink.iter().map(|p| p.0).min().unwrap(),
            ink.iter().map(|p| p.0).max().unwrap(),
        );
        let left = xmin - style.gap_px;
        let right = style.gap_px + 40 - 1 - xmax;
        assert!(left.abs_diff(right) <= 1, "{left} {right}");
    }

    #[test]
    fn every_digit_and_label_letter_has_a_distinct_glyph() {
        let chars: Vec<char> = "0123456789.-=abdeghilnoprstw".chars().collect();
        let unknown = glyph('\u{2603}');
        for (i, &a) in chars.iter().enumerate() {
            assert_ne!(glyph(a), unknown, "{a} has no glyph");
            for &b in &chars[i + 1..] {
                assert_ne!(glyph(a), glyph(b), "{a} and {b} look the same");
            }
        }
        assert_eq!(glyph('B'), glyph('b'));
        assert_eq!(text_width("ab", 2), (5 + 1 + 5) * 2);
    }
}
