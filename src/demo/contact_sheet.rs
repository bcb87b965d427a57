//! Contact sheets: frames of one row of a figure side by side, each above a small label strip
//! (e.g. `beta=0.6`, one or more lines), as one 8-bit sRGB image; and colour bars with tick
//! labels under false-colour images ([`colour_bar`]).
//!
//! The seed's Fig. 5 shows each effect as a row of frames at increasing speed; the demo writes
//! each row as one PNG made here. Labels are drawn with a built-in bitmap font ([`font`]:
//! printable ASCII and the degree sign, with descenders), so no font file or crate is
//! needed. Pure image assembly: no I/O.

pub mod colour_bar;
pub mod font;

pub use font::{glyph, GLYPH_H, GLYPH_W};

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

/// Font pixels between two glyphs of a line.
pub const GLYPH_SPACING: usize = 1;
/// Font pixels between two lines of a label.
pub const LINE_SPACING: usize = 1;
/// Font pixels of background above a label's first line and below its last line's cell.
const LABEL_MARGIN_TOP: usize = 2;
const LABEL_MARGIN_BOTTOM: usize = 1;

/// Height of a label strip holding `lines` lines of text (at least one), pixels: the glyph
/// cells (descenders included), the spacing between lines and the margins.
pub fn label_strip_height(style: &SheetStyle, lines: usize) -> usize {
    let n = lines.max(1);
    (LABEL_MARGIN_TOP + n * GLYPH_H + (n - 1) * LINE_SPACING + LABEL_MARGIN_BOTTOM)
        * style.label_scale
}

/// Width of one line of `text` drawn at `scale`, pixels.
pub fn text_width(text: &str, scale: usize) -> usize {
    let n = text.chars().count();
    if n == 0 {
        0
    } else {
        (n * (GLYPH_W + GLYPH_SPACING) - GLYPH_SPACING) * scale
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

/// Draw the lines of `text` (split at `\n`) into an RGB8 image of `img_width` pixels per
/// row, each line centred on the column `centre_x` (clipped at the image's left edge), the
/// first line's top at `y0`, [`LINE_SPACING`] font pixels between lines.
pub fn draw_lines_centred(
    img: &mut [u8],
    img_width: usize,
    centre_x: usize,
    y0: usize,
    text: &str,
    scale: usize,
    ink: [u8; 3],
) {
    for (k, line) in text.lines().enumerate() {
        let x = centre_x.saturating_sub(text_width(line, scale) / 2);
        let y = y0 + k * (GLYPH_H + LINE_SPACING) * scale;
        draw_text(img, img_width, x, y, line, scale, ink);
    }
}

/// Lay `tiles` out left to right, each above its label strip (each line of the label centred,
/// clipped to the tile's width), with `style.gap_px` between tiles and around the sheet. The
/// strips are as high as the label with the most lines. Tiles may differ in size; they are
/// aligned at the top. Panics if a tile's buffer is not `3 * width * height` bytes (a caller
/// bug).
pub fn contact_sheet(tiles: &[Tile<'_>], style: &SheetStyle) -> Sheet {
    let gap = style.gap_px;
    let lines = tiles
        .iter()
        .map(|t| t.label.lines().count())
        .max()
        .unwrap_or(1);
    let strip = label_strip_height(style, lines);
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
        // The label, drawn into a strip as wide as the tile so that it is clipped there.
        let mut label_img = vec![0u8; 3 * t.width * strip];
        for px in label_img.chunks_exact_mut(3) {
            px.copy_from_slice(&style.background);
        }
        draw_lines_centred(
            &mut label_img,
            t.width,
            t.width / 2,
            LABEL_MARGIN_TOP * style.label_scale,
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
        assert_eq!(s.height, g + 6 + label_strip_height(&style, 1) + g);
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
    fn a_two_line_label_gets_a_taller_strip_with_each_line_centred() {
        let style = SheetStyle::default();
        let sc = style.label_scale;
        let tile = solid(60, 5, [0, 0, 0]);
        let sheet = |label: &str| {
            contact_sheet(
                &[Tile {
                    width: 60,
                    height: 5,
                    rgb8: &tile,
                    label,
                }],
                &style,
            )
        };
        let (one, two) = (sheet("-"), sheet("-\n--"));
        assert_eq!(
            two.height - one.height,
            (GLYPH_H + LINE_SPACING) * sc,
            "one more line of glyph cells"
        );
        // Ink rows: the first line's bar at glyph row 3, the second line's one line lower.
        let ink = |s: &Sheet, y: usize| (0..s.width).filter(|&x| px(s, x, y) == style.ink).count();
        let top = style.gap_px + 5 + 2 * sc;
        let bar1 = top + 3 * sc;
        let bar2 = bar1 + (GLYPH_H + LINE_SPACING) * sc;
        assert_eq!(ink(&two, bar1), 5 * sc);
        assert_eq!(ink(&two, bar2), 2 * 5 * sc, "two bars of five font pixels");
        let ink_rows: usize = (0..two.height).map(|y| ink(&two, y)).sum();
        assert_eq!(ink_rows, (5 + 10) * sc * sc, "nothing else is drawn");
        // Both lines centred on the tile (within a pixel).
        for (y, w) in [(bar1, 5 * sc), (bar2, 11 * sc)] {
            let xmin = (0..two.width)
                .find(|&x| px(&two, x, y) == style.ink)
                .unwrap();
            let left = xmin - style.gap_px;
            let right = 60 - left - w;
            assert!(left.abs_diff(right) <= 1, "{left} {right}");
        }
        assert_eq!(text_width("ab", 2), (5 + 1 + 5) * 2);
    }
}
