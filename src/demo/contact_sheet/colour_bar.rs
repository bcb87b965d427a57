//! Colour bars: a horizontal strip under a false-colour image (the isochrones of seed Fig. 4)
//! showing the colour of every value of its range, with tick marks, tick labels and the unit
//! at the bar's right end (e.g. `ps`).
//!
//! Ticks fall on multiples of `k` times a base step (the isochrones' contour spacing, so that
//! each tick meets a dark contour line of the bar and of the image), with `k` the first of 1,
//! 2, 5, 10, 20, 50, ... whose labels fit side by side without touching. Pure image assembly.

use super::{draw_text, text_width, Sheet, SheetStyle, GLYPH_H, GLYPH_W};

/// What a colour bar shows: values `min .. max` (increasing), ticks on multiples of `k *
/// base_step`, and the unit written at the bar's right end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarRange<'a> {
    pub min: f64,
    pub max: f64,
    pub base_step: f64,
    pub unit: &'a str,
}

/// One tick of a drawn bar: its value, the pixel column of its mark, its label and the column
/// where the label starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Tick {
    pub value: f64,
    pub x: usize,
    pub label: String,
    pub label_x: usize,
}

/// A drawn colour bar: the strip and where things are in it.
#[derive(Clone, Debug, PartialEq)]
pub struct ColourBar {
    pub strip: Sheet,
    pub ticks: Vec<Tick>,
    /// Pixel columns of the bar's first and last colour column.
    pub bar_x: (usize, usize),
    /// Pixel rows of the bar's first and last colour row.
    pub bar_y: (usize, usize),
    /// Top row of the tick labels and the unit.
    pub label_y: usize,
    /// Column where the unit starts.
    pub unit_x: usize,
}

/// Layout in font pixels (times the style's label scale): margin above the bar, bar height,
/// tick length below it, margin below the labels, margin left and right of the strip.
const TOP: usize = 2;
const BAR: usize = 5;
const TICK: usize = 2;
const BOTTOM: usize = 1;
const SIDE: usize = 3;

/// Height of a colour bar strip drawn with `style`, pixels.
pub fn strip_height(style: &SheetStyle) -> usize {
    (TOP + BAR + TICK + 1 + GLYPH_H + BOTTOM) * style.label_scale
}

/// Decimals needed to write multiples of `step` (0 for steps of 1 or more).
fn decimals(step: f64) -> usize {
    if step >= 1.0 {
        0
    } else {
        ((-step.log10()) - 1e-9).ceil().clamp(0.0, 9.0) as usize
    }
}

fn format_value(v: f64, decimals: usize) -> String {
    // `+ 0.0` turns -0 into 0.
    format!("{:.*}", decimals, v + 0.0)
}

/// A tick at `value`, its mark at column `xf` (rounded), its label centred on it and kept
/// left of `right` (the unit's column).
fn tick(value: f64, xf: f64, decimals: usize, right: usize, scale: usize) -> Tick {
    let label = format_value(value, decimals);
    let x = xf.round().max(0.0) as usize;
    let w = text_width(&label, scale);
    Tick {
        value,
        x,
        label_x: x.saturating_sub(w / 2).min(right.saturating_sub(w)),
        label,
    }
}

/// Whether the labels of `ticks` leave a glyph's width between each other and before the
/// unit at column `right`.
fn fits(ticks: &[Tick], right: usize, scale: usize) -> bool {
    let gap = GLYPH_W * scale;
    let end = |t: &Tick| t.label_x + text_width(&t.label, scale) + gap;
    ticks.windows(2).all(|p| end(&p[0]) <= p[1].label_x)
        && ticks.last().is_none_or(|t| end(t) <= right)
}

/// Draw a colour bar `width` pixels wide for `range`, each column coloured by `colour` at its
/// value (8-bit sRGB), in `style`'s background, ink and label scale. With an empty or
/// invalid range, or no multiple of the step with two ticks whose labels fit, the ticks are
/// the two ends of the range.
pub fn colour_bar(
    width: usize,
    range: &BarRange,
    colour: impl Fn(f64) -> [u8; 3],
    style: &SheetStyle,
) -> ColourBar {
    let s = style.label_scale;
    let height = strip_height(style);
    let mut rgb8: Vec<u8> = (0..width * height).flat_map(|_| style.background).collect();
    let unit_w = text_width(range.unit, s);
    let unit_x = width.saturating_sub(SIDE * s + unit_w);
    let bx0 = SIDE * s;
    let bx1 = unit_x.saturating_sub(GLYPH_W * s + 1).max(bx0);
    let (by0, by1) = (TOP * s, (TOP + BAR) * s - 1);
    let label_y = (TOP + BAR + TICK + 1) * s;
    let valid = range.min.is_finite() && range.max.is_finite() && range.min < range.max;
    let span = if valid { range.max - range.min } else { 1.0 };
    // Column x shows the value at its centre; value v sits at column x(v).
    let cols = (bx1 + 1 - bx0) as f64;
    let value_at = |x: usize| range.min + (x as f64 + 0.5 - bx0 as f64) / cols * span;
    let x_of = |v: f64| bx0 as f64 - 0.5 + (v - range.min) / span * cols;
    for x in bx0..=bx1.min(width.saturating_sub(1)) {
        let c = colour(value_at(x));
        for y in by0..=by1 {
            let i = 3 * (y * width + x);
            rgb8[i..i + 3].copy_from_slice(&c);
        }
    }
    let mut ticks = Vec::new();
    if valid && range.base_step.is_finite() && range.base_step > 0.0 {
        let mut k = 1.0f64;
        loop {
            let step = k * range.base_step;
            let (first, last) = ((range.min / step).ceil(), (range.max / step).floor());
            if last - first < 1.0 {
                break; // fewer than two ticks from here on
            }
            let d = decimals(step);
            let t: Vec<Tick> = (first as i64..=last as i64)
                .map(|m| {
                    let v = m as f64 * step;
                    tick(v, x_of(v), d, unit_x, s)
                })
                .collect();
            if fits(&t, unit_x, s) {
                ticks = t;
                break;
            }
            // 1, 2, 5, 10, 20, 50, ...
            let mantissa = k / 10f64.powf(k.log10().floor());
            k *= if (mantissa - 2.0).abs() < 1e-9 {
                2.5
            } else {
                2.0
            };
        }
    }
    if ticks.is_empty() {
        let d = decimals(span / 10.0);
        ticks = vec![
            tick(range.min, bx0 as f64, d, unit_x, s),
            tick(range.max, bx1 as f64, d, unit_x, s),
        ];
    }
    for t in &ticks {
        for y in by1 + 1..=by1 + TICK * s {
            for x in t.x..(t.x + s).min(width) {
                let i = 3 * (y * width + x);
                rgb8[i..i + 3].copy_from_slice(&style.ink);
            }
        }
        draw_text(&mut rgb8, width, t.label_x, label_y, &t.label, s, style.ink);
    }
    draw_text(&mut rgb8, width, unit_x, label_y, range.unit, s, style.ink);
    ColourBar {
        strip: Sheet {
            width,
            height,
            rgb8,
        },
        ticks,
        bar_x: (bx0, bx1),
        bar_y: (by0, by1),
        label_y,
        unit_x,
    }
}

/// `top` above `bottom` (same width) as one image. Panics if the widths differ (a caller bug).
pub fn stack(top: &Sheet, bottom: &Sheet) -> Sheet {
    assert_eq!(top.width, bottom.width, "stack: widths differ");
    let mut rgb8 = Vec::with_capacity(top.rgb8.len() + bottom.rgb8.len());
    rgb8.extend_from_slice(&top.rgb8);
    rgb8.extend_from_slice(&bottom.rgb8);
    Sheet {
        width: top.width,
        height: top.height + bottom.height,
        rgb8,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A colour ramp that can be read back: red = value / 1000 * 255.
    fn ramp(v: f64) -> [u8; 3] {
        [(v / 1000.0 * 255.0).round().clamp(0.0, 255.0) as u8, 0, 40]
    }

    fn px(s: &Sheet, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * s.width + x);
        [s.rgb8[i], s.rgb8[i + 1], s.rgb8[i + 2]]
    }

    #[test]
    fn ticks_are_round_multiples_of_the_step_with_labels_that_fit() {
        let style = SheetStyle::default();
        let range = BarRange {
            min: 37.0,
            max: 963.0,
            base_step: 50.0,
            unit: "ps",
        };
        let bar = colour_bar(320, &range, ramp, &style);
        assert_eq!(bar.strip.height, strip_height(&style));
        assert_eq!(bar.strip.rgb8.len(), 3 * 320 * bar.strip.height);
        // The bar spans 276 columns for 926 ps. A label "100" is 34 px wide at scale 2, so
        // ticks every 50 ps (15 px) or 100 ps (30 px) crowd each other; every 250 ps fit.
        let values: Vec<f64> = bar.ticks.iter().map(|t| t.value).collect();
        assert_eq!(values, [250.0, 500.0, 750.0]);
        let labels: Vec<&str> = bar.ticks.iter().map(|t| t.label.as_str()).collect();
        assert_eq!(labels, ["250", "500", "750"]);
        assert!(fits(&bar.ticks, bar.unit_x, style.label_scale));
        assert_eq!(bar.unit_x, 320 - 3 * 2 - text_width("ps", 2));
        // The bar's colour under each tick mark is the colour of the tick's value, and the
        // mark is drawn below the bar.
        let y = bar.bar_y.0 + 1;
        for t in &bar.ticks {
            let want = ramp(t.value)[0] as i32;
            let got = px(&bar.strip, t.x, y)[0] as i32;
            assert!(
                (got - want).abs() <= 1,
                "{}: red {got}, want {want}",
                t.value
            );
            assert_eq!(px(&bar.strip, t.x, bar.bar_y.1 + 1), style.ink);
        }
        // The bar's ends show the ends of the range.
        assert!(px(&bar.strip, bar.bar_x.0, y)[0] <= ramp(37.0 + 3.0)[0]);
        assert!(px(&bar.strip, bar.bar_x.1, y)[0] >= ramp(963.0 - 3.0)[0]);
        assert_eq!(px(&bar.strip, bar.bar_x.1 + 1, y), style.background);
    }

    #[test]
    fn labels_and_unit_are_drawn_where_the_bar_says() {
        let style = SheetStyle {
            label_scale: 1,
            ..SheetStyle::default()
        };
        let range = BarRange {
            min: 0.25,
            max: 1.75,
            base_step: 0.1,
            unit: "ps",
        };
        let bar = colour_bar(160, &range, ramp, &style);
        assert!(bar.ticks.len() >= 2, "{:?}", bar.ticks);
        assert!(bar
            .ticks
            .iter()
            .all(|t| t.label.starts_with(['0', '1']) && t.label.contains('.')));
        // Redraw each label and the unit on a blank strip; the ink below the tick marks is
        // exactly that.
        let mut want = vec![0u8; 3 * 160 * bar.strip.height];
        for t in &bar.ticks {
            draw_text(
                &mut want,
                160,
                t.label_x,
                bar.label_y,
                &t.label,
                1,
                [1, 1, 1],
            );
        }
        draw_text(&mut want, 160, bar.unit_x, bar.label_y, "ps", 1, [1, 1, 1]);
        for y in bar.label_y..bar.strip.height {
            for x in 0..160 {
                let inked = px(&bar.strip, x, y) == style.ink;
                let i = 3 * (y * 160 + x);
                assert_eq!(inked, want[i] == 1, "pixel ({x}, {y})");
            }
        }
    }

    #[test]
    fn an_empty_range_labels_its_ends() {
        let style = SheetStyle::default();
        let range = BarRange {
            min: 5.0,
            max: 5.0,
            base_step: 1.0,
            unit: "ps",
        };
        let bar = colour_bar(120, &range, ramp, &style);
        let labels: Vec<&str> = bar.ticks.iter().map(|t| t.label.as_str()).collect();
        assert_eq!(labels, ["5.0", "5.0"]);
        let stacked = stack(
            &Sheet {
                width: 120,
                height: 3,
                rgb8: vec![7; 3 * 120 * 3],
            },
            &bar.strip,
        );
        assert_eq!(stacked.height, 3 + bar.strip.height);
        assert_eq!(px(&stacked, 0, 2), [7, 7, 7]);
        assert_eq!(px(&stacked, 0, 3), style.background);
    }
}
