//! Unit tests of the HPD-TA `.img` reader and writer (moved out of `hamamatsu.rs`).

use super::write::{check_write_args, format_time_range, push_counts};
use super::*;

#[test]
fn comment_sections_follow_values_directly() {
    let s = parse_comment("[A],k=1,q=\"x, y\"\r\n[B],Type=5,SubType=0[C],ExposureTime=5 s,E=\"\"")
        .unwrap();
    assert_eq!(s["A"]["k"], "1");
    assert_eq!(s["A"]["q"], "x, y");
    assert_eq!(s["B"]["SubType"], "0");
    assert_eq!(s["C"]["ExposureTime"], "5 s");
    assert_eq!(s["C"]["E"], "");
}

#[test]
fn comment_errors_give_offsets() {
    assert_eq!(parse_comment("k=1").unwrap_err().0, 0);
    assert_eq!(parse_comment("[A],k=1,lonely").unwrap_err().0, 8);
    assert!(parse_comment("[A],k=\"open").is_err());
    assert!(parse_comment("[A],k=1,k=2")
        .unwrap_err()
        .1
        .contains("duplicate"));
}

#[test]
fn time_values_must_be_finite_in_ps() {
    let p = Path::new("x.img");
    let t = |v: &str| parse_time_value(p, "Streak camera", "Time Range", v);
    assert_eq!(t("20 us").unwrap(), 2e7);
    for v in ["inf ps", "nan ns", "1e300 s", "-inf fs"] {
        let e = t(v).unwrap_err().to_string();
        assert!(e.contains("finite") && e.contains("Time Range"), "{v}: {e}");
    }
}

#[test]
fn time_units() {
    assert_eq!(time_unit_to_ps("us"), Some(1e6));
    assert_eq!(time_unit_to_ps("\u{b5}s"), Some(1e6));
    assert_eq!(time_unit_to_ps("fs"), Some(1e-3));
    assert_eq!(time_unit_to_ps("s"), Some(1e12));
    assert_eq!(time_unit_to_ps("nm"), None);
    assert_eq!(format_time_range(1900.0), "1.9 ns");
    assert_eq!(format_time_range(640.0), "640 ps");
    assert_eq!(format_time_range(2.0e7), "20 us");
}

#[test]
fn pixels_decode_little_endian_at_each_depth() {
    assert_eq!(
        decode_pixels(ImgFileType::U8, &[0, 7, 255]),
        [0.0, 7.0, 255.0]
    );
    assert_eq!(
        decode_pixels(ImgFileType::U16, &[0x34, 0x12, 0xff, 0xff]),
        [4660.0, 65535.0]
    );
    assert_eq!(
        decode_pixels(ImgFileType::U32, &[1, 0, 0, 0, 0, 0, 1, 0]),
        [1.0, 65536.0]
    );
}

#[test]
fn decreasing_axes_are_reversed_with_the_pixels() {
    let p = Path::new("x.img");
    // 3 columns x 2 rows.
    let mut data = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
    let mut x = Some((vec![30.0, 20.0, 10.0], "um".to_string()));
    let mut y = Some((vec![0.0, 5.0], "ps".to_string()));
    let flips = make_axes_increase(p, &mut data, 3, &mut x, &mut y).unwrap();
    assert_eq!(flips, (true, false));
    assert_eq!(data, [3.0, 2.0, 1.0, 6.0, 5.0, 4.0]);
    assert_eq!(x.unwrap().0, [10.0, 20.0, 30.0]);
    let mut y = Some((vec![5.0, 0.0], "ps".to_string()));
    let flips = make_axes_increase(p, &mut data, 3, &mut None, &mut y).unwrap();
    assert_eq!(flips, (false, true));
    assert_eq!(data, [6.0, 5.0, 4.0, 3.0, 2.0, 1.0]);
    let mut y = Some((vec![0.0, 5.0, 1.0], "ps".to_string()));
    let e = make_axes_increase(p, &mut data, 2, &mut None, &mut y).unwrap_err();
    assert!(
        matches!(
            e,
            FormatError::NonMonotonicAxis {
                axis: 'Y',
                index: 2,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn counts_round_clamp_and_report_saturation() {
    let mut out = Vec::new();
    let sat = push_counts(&mut out, &[-3.0, 1.5, 65535.4, 65535.6, 1e9], 16);
    assert_eq!(sat, 2);
    let v: Vec<u16> = out
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    assert_eq!(v, [0, 2, 65535, 65535, 65535]);
    let mut out = Vec::new();
    assert_eq!(push_counts(&mut out, &[70000.0], 32), 0);
    assert_eq!(out, 70000u32.to_le_bytes());
}

#[test]
fn the_writer_refuses_bad_depths_sizes_and_time_axes() {
    let p = Path::new("x.img");
    let img = StreakImage {
        nx: 2,
        nt: 2,
        data: vec![0.0; 4],
        pixel_type: PixelType::U16,
        time_axis_ps: None,
        x_axis: None,
        img_meta: None,
    };
    assert!(matches!(
        check_write_args(p, &img, 16, &[0.0, 1.0]),
        Ok(ImgFileType::U16)
    ));
    assert!(matches!(
        check_write_args(p, &img, 32, &[0.0, 1.0]),
        Ok(ImgFileType::U32)
    ));
    let e = check_write_args(p, &img, 8, &[0.0, 1.0])
        .unwrap_err()
        .to_string();
    assert!(e.contains("bit depth 8"), "{e}");
    let e = check_write_args(p, &img, 16, &[1.0, 1.0])
        .unwrap_err()
        .to_string();
    assert!(e.contains("not strictly increasing at row 1"), "{e}");
    let e = check_write_args(p, &img, 16, &[0.0, f64::NAN])
        .unwrap_err()
        .to_string();
    assert!(e.contains("not finite"), "{e}");
    assert!(check_write_args(p, &img, 16, &[0.0]).is_err());
}

#[test]
fn time_range_is_a_duration_or_a_sweep_range_index() {
    let p = Path::new("x.img");
    assert_eq!(
        parse_time_range(p, "20 us").unwrap(),
        TimeRange::Duration { ps: 2e7 }
    );
    assert_eq!(parse_time_range(p, "4").unwrap(), TimeRange::Index(4));
    assert_eq!(parse_time_range(p, " 1 ").unwrap(), TimeRange::Index(1));
    for v in ["2.5", "-1", "", "us", "99999999999"] {
        let e = parse_time_range(p, v).unwrap_err().to_string();
        assert!(
            e.contains("Time Range") && e.contains("sweep-range index"),
            "{v}: {e}"
        );
    }
    // A unit HPD-TA does not write is still an unknown unit, not an index.
    assert!(matches!(
        parse_time_range(p, "3 min"),
        Err(FormatError::UnknownUnit { .. })
    ));
}
