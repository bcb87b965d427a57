//! How `femto info` shortens what it prints by default: numbers rounded to the digits they
//! carry, and long lists summarised (`femto info --full` prints them whole, `--json` always
//! does). Nothing here changes a file or the JSON.

/// Lists longer than this are summarised in the default text.
pub const LONGEST_LIST: usize = 6;

/// `x` rounded to `digits` significant digits, without trailing zeros: `4.000001907348633`
/// with 7 digits is `4.000002`, `0.19999999999999998` with 6 is `0.2`. Magnitudes below 1e-4
/// or from 1e9 up are written with an exponent; non-finite values as Rust writes them.
pub fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return x.to_string();
    }
    let digits = digits.max(1);
    let magnitude = x.abs().log10().floor() as i32;
    if !(-4..9).contains(&magnitude) {
        let text = format!("{:.*e}", digits - 1, x);
        let (mantissa, exponent) = text.split_once('e').expect("an exponent");
        return format!("{}e{exponent}", trim_zeros(mantissa));
    }
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    trim_zeros(&format!("{x:.decimals$}")).to_string()
}

/// `4.500` -> `4.5`, `3.000` -> `3`; text without a point is returned as it is.
fn trim_zeros(text: &str) -> &str {
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        text
    }
}

/// A note's value as the default text shows it: a JSON list longer than [`LONGEST_LIST`]
/// becomes its count and range (numbers) or its first and last entries (anything else), a
/// lone number is rounded to 6 significant digits, and anything else is printed as stored.
pub fn note_value(stored: &str) -> String {
    match serde_json::from_str::<serde_json::Value>(stored) {
        Ok(serde_json::Value::Array(items)) if items.len() > LONGEST_LIST => list(&items),
        Ok(serde_json::Value::Number(n)) if n.is_f64() => {
            significant(n.as_f64().expect("an f64"), 6)
        }
        _ => stored.to_string(),
    }
}

/// The summary of a long list: `72 numbers, -2.9 .. 3.5` or `48 entries, "a" .. "z"`.
fn list(items: &[serde_json::Value]) -> String {
    let numbers: Option<Vec<f64>> = items.iter().map(|v| v.as_f64()).collect();
    let n = items.len();
    match numbers {
        Some(v) => {
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            format!(
                "{n} numbers, {} .. {} (--full lists them)",
                significant(lo, 6),
                significant(hi, 6)
            )
        }
        None => format!(
            "{n} entries, {} .. {} (--full lists them)",
            items[0],
            items[n - 1]
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::{note_value, significant};

    #[test]
    fn significant_rounds_and_trims() {
        assert_eq!(significant(4.000001907348633, 7), "4.000002");
        assert_eq!(significant(0.19999999999999998, 6), "0.2");
        assert_eq!(significant(-108.0, 7), "-108");
        assert_eq!(significant(1_996.000_015_258_789, 7), "1996");
        assert_eq!(significant(0.000046517383, 6), "4.65174e-5");
        assert_eq!(significant(2.5e12, 6), "2.5e12");
        assert_eq!(significant(0.0, 6), "0");
        assert_eq!(significant(f64::NAN, 6), "NaN");
    }

    #[test]
    fn long_lists_are_summarised_and_short_ones_kept() {
        let shifts = format!(
            "[{}]",
            (0..72)
                .map(|i| format!("{}.25", i - 30))
                .collect::<Vec<_>>()
                .join(",")
        );
        assert_eq!(
            note_value(&shifts),
            "72 numbers, -30.25 .. 41.25 (--full lists them)"
        );
        let files = format!(
            "[{}]",
            (0..48)
                .map(|i| format!("\"s_{i:04}.png\""))
                .collect::<Vec<_>>()
                .join(",")
        );
        assert_eq!(
            note_value(&files),
            "48 entries, \"s_0000.png\" .. \"s_0047.png\" (--full lists them)"
        );
        assert_eq!(note_value("[\"dark\",\"flat\"]"), "[\"dark\",\"flat\"]");
        assert_eq!(note_value("1.6411945904467917"), "1.64119");
        assert_eq!(note_value("795"), "795");
        assert_eq!(
            note_value("shuffle + deflate level 1"),
            "shuffle + deflate level 1"
        );
    }
}
