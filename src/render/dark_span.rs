//! Where the capture holds no light around a cube pixel: for each cube pixel, the bin
//! coordinates before which and from which the prefix sums of every pixel of its 3 x 3
//! neighbourhood (the pixels [`super::RenderScene::capture_taps`] can interpolate) are flat,
//! so that an emission window wholly inside either part receives exactly `+0` from each of
//! them, and the renderer can draw the point black without reading the taps or the prefix
//! sums. A unwarped capture is empty over most of each pixel's axis (light reaches a point
//! once, within a few nanoseconds), so most points of a frame fall there: on the render
//! bench's frame about two thirds of the visible points.
//!
//! "Exactly `+0`" is meant bit for bit, so that the shortcut is invisible: before the signal
//! every value read is `+0.0` (the literal of `PrefixCoord::Before`, or `P[i] + f (P[i+1] -
//! P[i])` over entries that are all `+0.0`); after it every value read is the total `T`, or
//! `T + f (T - T) = T` (`T` finite and not `-0.0`), and `T - T = +0`.

use rayon::prelude::*;

/// The flat parts of the prefix sums of a cube pixel's 3 x 3 neighbourhood, as bin
/// coordinates (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct DarkSpan {
    /// Every neighbour's `P(c)` is `+0.0` for `c < before` (infinite: for every finite `c`).
    before: f64,
    /// Every neighbour's `P(c)` is its total for `c >= after` (NaN: for no `c`).
    after: f64,
}

impl DarkSpan {
    /// A span that holds no window (before the cube's spans are known).
    pub(super) const NEVER: DarkSpan = DarkSpan {
        before: f64::NEG_INFINITY,
        after: f64::NAN,
    };

    /// Whether the window between the bin coordinates `ca` and `cb` lies wholly in a flat
    /// part, so that every neighbour's `P(cb) - P(ca)` is `+0.0` (false for a NaN).
    #[inline(always)]
    pub(super) fn holds(&self, ca: f64, cb: f64) -> bool {
        (ca < self.before && cb < self.before) || (ca >= self.after && cb >= self.after)
    }

    /// The flat parts of one pixel's prefix `p` (`nt + 1` values, `P[0]` first).
    fn of_prefix(p: &[f64]) -> DarkSpan {
        let zero = 0.0f64.to_bits();
        // P(c) for 0 < c < L reads P[0 ..= L]; c <= 0 reads the literal +0.
        let before = match p.iter().position(|v| v.to_bits() != zero) {
            None => f64::INFINITY,
            Some(first) => (first.max(1) - 1) as f64,
        };
        let total = p[p.len() - 1];
        let after = if !total.is_finite() || total.to_bits() == (-0.0f64).to_bits() {
            f64::NAN
        } else {
            // P(c) for c >= H reads P[H ..= nt] (or the total); c >= 1 is never `Before`.
            let last_other = p.iter().rposition(|v| v.to_bits() != total.to_bits());
            (last_other.map_or(0, |i| i + 1).max(1)) as f64
        };
        DarkSpan { before, after }
    }
}

/// The [`DarkSpan`] of every pixel of an `nx x ny` cube whose prefix sums are `prefix`
/// (`nt + 1` values per pixel, row-major pixels): each pixel's own flat parts, narrowed to
/// those of its neighbours inside the image.
pub(super) fn dark_spans(prefix: &[f64], nx: usize, ny: usize, nt: usize) -> Vec<DarkSpan> {
    let own: Vec<DarkSpan> = prefix.par_chunks(nt + 1).map(DarkSpan::of_prefix).collect();
    let mut spans = own.clone();
    spans
        .par_chunks_mut(nx.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, span) in row.iter_mut().enumerate() {
                for yn in y.saturating_sub(1)..(y + 2).min(ny) {
                    for xn in x.saturating_sub(1)..(x + 2).min(nx) {
                        let o = own[yn * nx + xn];
                        span.before = span.before.min(o.before);
                        // A neighbour that is never flat at the end makes the span so.
                        span.after = if o.after.is_nan() || span.after.is_nan() {
                            f64::NAN
                        } else {
                            span.after.max(o.after)
                        };
                    }
                }
            }
        });
    spans
}

/// `P(cb) - P(ca)` of the prefix `p` as the renderer reads it (tests).
#[cfg(test)]
fn window(p: &[f64], ca: f64, cb: f64) -> f64 {
    use crate::pyramid::PrefixCoord;
    let nt = p.len() - 1;
    PrefixCoord::new(cb, nt).read(p) - PrefixCoord::new(ca, nt).read(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Prefix sums of `bins`.
    fn prefix_of(bins: &[f64]) -> Vec<f64> {
        let mut p = vec![0.0];
        for b in bins {
            p.push(p[p.len() - 1] + b);
        }
        p
    }

    /// Wherever a span says a window is dark, every pixel of the neighbourhood reads `+0.0`
    /// for it, bit for bit: light in the middle of the axis, at its first and last bin,
    /// none, negative values that sum to `-0.0`, a NaN and an infinite total; windows before,
    /// across and after the light, on bin boundaries and outside the axis.
    #[test]
    fn a_dark_window_reads_plus_zero_from_every_neighbour() {
        let nt = 12;
        let mut bins = vec![
            [0., 0., 0., 1., 2., 0., 0., 0., 0., 0., 0., 0.],
            [5., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0.],
            [0.; 12],
            [0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 3.],
            [0., 0., 0., 0., 0., -0., 0., 0., 0., 0., 0., 0.],
            [0., 0., 0., 0., 0., 0., 0., 0., 0., 0.25, -0.25, 0.],
            [0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0.],
            [0., 0., 0., 0., 0., 0., 0., 0., 7., 0., 0., 0.],
            [0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0.],
        ];
        bins[6][4] = f64::NAN;
        bins[8][2] = f64::INFINITY;
        let mut prefix: Vec<f64> = bins.iter().flat_map(|b| prefix_of(b)).collect();
        // A prefix whose zeros are -0.0 (as a negative dark level can leave) and whose
        // total is -0.0.
        prefix[4 * (nt + 1)..5 * (nt + 1)].fill(-0.0);
        let (nx, ny) = (3, 3);
        let spans = dark_spans(&prefix, nx, ny, nt);
        let pixel = |i: usize| &prefix[i * (nt + 1)..(i + 1) * (nt + 1)];
        let coords: Vec<f64> = (-4..=2 * nt as i32 + 4)
            .map(|k| k as f64 * 0.5)
            .chain([0.3, 2.999, 3.0, 3.001, 11.5, -1e9, 1e9])
            .chain([f64::NAN, f64::INFINITY, f64::NEG_INFINITY])
            .collect();
        let (mut dark, mut checked) = (0, 0);
        for (centre, span) in spans.iter().enumerate() {
            let (cx, cy) = (centre % nx, centre / nx);
            for &ca in &coords {
                for &cb in &coords {
                    if !span.holds(ca, cb) {
                        continue;
                    }
                    dark += 1;
                    for y in cy.saturating_sub(1)..(cy + 2).min(ny) {
                        for x in cx.saturating_sub(1)..(cx + 2).min(nx) {
                            let w = window(pixel(y * nx + x), ca, cb);
                            assert_eq!(
                                w.to_bits(),
                                0,
                                "pixel ({x}, {y}) of {centre}: {ca}..{cb}: {w}"
                            );
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(dark > 100 && checked > 400, "{dark} dark windows");
        // A pixel with light in bins 3 and 4 alone is dark before coordinate 3 (the start
        // of bin 3) and from 5 on (the end of bin 4).
        assert_eq!(
            DarkSpan::of_prefix(&prefix_of(&bins[0])),
            DarkSpan {
                before: 3.0,
                after: 5.0
            }
        );
        assert_eq!(
            DarkSpan::of_prefix(&prefix_of(&bins[2])).before,
            f64::INFINITY
        );
    }
}
