//! Streak-image readers and writers, and the capture manifest.
//!
//! The two real Hamamatsu files must read with exactly the values listed in
//! `../shared/data/hamamatsu/FACTS.md`; every writer is checked by a round trip whose
//! expected values are computed here from the documented encoding, and the `.img` writer's
//! container layout is checked byte by byte against the HPD-TA conventions.

use femto::formats::hamamatsu::{AxisScaling, ImgFileType};
use femto::formats::{self, read_streak, FormatError, PixelType, StreakImage};
use femto::manifest::*;
use std::path::{Path, PathBuf};

#[path = "common/shared.rs"]
mod shared;

/// A real Hamamatsu file of `../shared` (skipped when absent; a failure under `CI=true`).
fn hamamatsu_file(name: &str) -> Option<PathBuf> {
    shared::file(&format!("data/hamamatsu/{name}"))
}

fn block(img: &StreakImage, x0: usize, t0: usize) -> [[f32; 3]; 3] {
    let mut b = [[0.0; 3]; 3];
    for (dt, row) in b.iter_mut().enumerate() {
        for (dx, v) in row.iter_mut().enumerate() {
            *v = img.at(x0 + dx, t0 + dt);
        }
    }
    b
}

/// The x-axis table values listed in FACTS.md (nm), as float32 literals.
const X_FIRST_NM: [f32; 5] = [472.252, 472.33337, 472.41473, 472.4961, 472.57745];

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn operate_mode_reads_with_the_documented_values() {
    let Some(path) = hamamatsu_file("operate_mode.img") else {
        return;
    };
    let img = read_streak(&path, false).unwrap();
    assert_eq!((img.nx, img.nt), (672, 512));
    assert_eq!(img.pixel_type, PixelType::U32);
    assert_eq!(
        block(&img, 0, 0),
        [
            [0.0, 0.0, 715.0],
            [246.0, 161.0, 475.0],
            [106.0, 899.0, 0.0]
        ]
    );
    let meta = img.img_meta.as_ref().unwrap();
    assert_eq!(meta.img_header().unwrap().comment_len, 3311);
    assert_eq!(meta.comment.len(), 3311);
    assert_eq!(meta.img_header().unwrap().file_type, ImgFileType::U32);
    for section in [
        "Application",
        "Camera",
        "Acquisition",
        "Streak camera",
        "Spectrograph",
        "Scaling",
    ] {
        assert!(meta.sections.contains_key(section), "missing [{section}]");
    }
    assert_eq!(
        meta.get("Scaling", "ScalingYScalingFile"),
        Some("#1382319,0512")
    );
    assert_eq!(meta.get("Streak camera", "Time Range"), Some("20 us"));

    // The raw time table, as stored (microseconds), and its conversion to ps.
    let us = [0.0f32, 0.031080816, 0.062164314, 0.09325048, 0.12433932];
    match &meta.scaling_y {
        AxisScaling::Table {
            unit,
            byte_offset,
            table_len,
            first_entry,
            values,
        } => {
            assert_eq!(unit, "us");
            assert_eq!(*byte_offset, 1382319);
            assert_eq!((*table_len, *first_entry), (512, 0));
            assert_eq!(values.len(), 512);
            for (v, want) in values.iter().zip(us) {
                assert_eq!(*v as f32, want);
            }
        }
        other => panic!("time axis should be a table, got {other:?}"),
    }
    let t_ps = img.time_axis_ps.as_ref().unwrap();
    assert_eq!(t_ps.len(), 512);
    for (t, want_us) in t_ps.iter().zip(us) {
        let want_ps = want_us as f64 * 1.0e6;
        assert!(
            (t - want_ps).abs() <= 1e-9 * want_ps.max(1.0),
            "{t} vs {want_ps}"
        );
    }

    // The X table increases after the reader flips the columns (the file stores it
    // decreasing, as HPD-TA does for spectrographs).
    let x = img.x_axis.as_ref().unwrap();
    assert_eq!(x.unit, "nm");
    assert_eq!(x.values.len(), 672);
    for (v, want) in x.values.iter().zip(X_FIRST_NM) {
        assert_eq!(*v as f32, want);
    }
    assert!(meta.columns_reversed && !meta.rows_reversed);

    assert_eq!(meta.time_range_ps, Some(20.0e6));
    assert_eq!(meta.mcp_gain, Some(50.0));
    assert_eq!(meta.n_exposures, Some(60));
    assert_eq!(meta.exposure_time_s, Some(5.0));
    assert_eq!(meta.total_exposure_s, Some(300.0));
    assert_eq!(meta.mode.as_deref(), Some("Operate"));
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn focus_mode_has_an_uncalibrated_vertical_axis() {
    let Some(path) = hamamatsu_file("focus_mode.img") else {
        return;
    };
    let img = read_streak(&path, false).unwrap();
    assert_eq!((img.nx, img.nt), (672, 512));
    assert_eq!(
        block(&img, 669, 509),
        [[0.0, 0.0, 36.0], [0.0, 0.0, 0.0], [21.0, 0.0, 0.0]]
    );
    let meta = img.img_meta.as_ref().unwrap();
    assert_eq!(meta.scaling_y, AxisScaling::Pixels);
    assert!(img.time_axis_ps.is_none());
    assert_eq!(meta.mode.as_deref(), Some("Focus"));
    let x = img.x_axis.as_ref().unwrap();
    assert_eq!(x.unit, "nm");
    for (v, want) in x.values.iter().zip(X_FIRST_NM) {
        assert_eq!(*v as f32, want);
    }
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn real_file_transposed_has_no_wavelength_time_axis() {
    let Some(path) = hamamatsu_file("operate_mode.img") else {
        return;
    };
    // Transposed, the file's X axis (nm) would be time: a wavelength is no time, so the
    // image is read without a time axis and says which key.
    let img = read_streak(&path, true).unwrap();
    assert!(img.time_axis_ps.is_none());
    let why = img.img_meta.unwrap().time_uncalibrated.unwrap();
    assert!(
        why.contains("ScalingXUnit=\"nm\"") && why.contains("not a time unit"),
        "{why}"
    );
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn truncated_real_img_names_the_file() {
    let Some(path) = hamamatsu_file("operate_mode.img") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(&path).unwrap();
    for cut in [40, 64 + 1000, 64 + 3311 + 672 * 100 * 4, 1382319 + 100] {
        let short = dir.path().join(format!("cut_{cut}.img"));
        std::fs::write(&short, &bytes[..cut]).unwrap();
        let err = read_streak(&short, false).unwrap_err();
        assert!(matches!(err, FormatError::Truncated { .. }), "{err}");
        assert!(err.to_string().contains(&format!("cut_{cut}.img")), "{err}");
    }
}

/// A test image with a ramp, negative values and values above any range.
fn test_image(nx: usize, nt: usize) -> StreakImage {
    let data = (0..nx * nt)
        .map(|i| {
            let (x, t) = (i % nx, i / nx);
            (x as f32 * 37.25 + t as f32 * 1001.5) - 300.0
        })
        .collect();
    StreakImage::new(nx, nt, data)
}

#[test]
fn png16_round_trip_with_scale() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.png");
    let (nx, nt) = (7, 5);
    let mut img = test_image(nx, nt);
    let scale = 0.0625; // stored count = v / 0.0625; 65535 counts = 4095.94
    img.data[3] = 1.0e6; // saturates
    img.data[4] = 4095.9; // 65534.4 -> 65534
    let saturated = formats::raster::write_png16(&path, &img, scale).unwrap();
    let expected_saturated = img
        .data
        .iter()
        .filter(|&&v| v as f64 / scale > 65535.5)
        .count();
    assert_eq!(saturated, expected_saturated);
    assert!(saturated >= 1);
    let back = read_streak(&path, false).unwrap();
    assert_eq!(
        (back.nx, back.nt, back.pixel_type),
        (nx, nt, PixelType::U16)
    );
    for (i, (&v, &s)) in img.data.iter().zip(&back.data).enumerate() {
        let decoded = s as f64 * scale;
        let v = v as f64;
        if v <= 0.0 {
            assert_eq!(s, 0.0, "pixel {i}: negative values store 0");
        } else if v / scale > 65535.5 {
            assert_eq!(s, 65535.0, "pixel {i}: saturated");
        } else {
            assert!(
                (decoded - v).abs() <= 0.5 * scale + 1e-9,
                "pixel {i}: {decoded} vs {v}"
            );
        }
    }
    assert_eq!(back.at(4, 0), 65534.0);
    // Bad scale and non-finite values are refused, and no file is left behind.
    let bad = dir.path().join("bad.png");
    assert!(formats::raster::write_png16(&bad, &img, 0.0).is_err());
    img.data[0] = f32::NAN;
    let err = formats::raster::write_png16(&bad, &img, scale).unwrap_err();
    assert!(
        matches!(err, FormatError::NonFinite { x: 0, t: 0, .. }),
        "{err}"
    );
    assert!(!bad.exists());
}

#[test]
fn exr_f32_round_trip_is_exact_and_keeps_non_finite_values() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.exr");
    let mut img = test_image(9, 4);
    img.data[0] = f32::NAN;
    img.data[1] = f32::INFINITY;
    img.data[2] = 1.0e-30;
    formats::raster::write_exr_f32(&path, &img).unwrap();
    let back = read_streak(&path, false).unwrap();
    assert_eq!((back.nx, back.nt, back.pixel_type), (9, 4, PixelType::F32));
    for (a, b) in img.data.iter().zip(&back.data) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
}

#[test]
fn exr_f16_y_and_rgb_read_as_documented() {
    use exr::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (6usize, 3usize);
    let vals: Vec<f16> = (0..w * h)
        .map(|i| f16::from_f32(i as f32 * 0.37 - 1.0))
        .collect();

    // A single f16 channel named Y.
    let y_path = dir.path().join("y16.exr");
    let mut list = SmallVec::new();
    list.push(AnyChannel::new("Y", FlatSamples::F16(vals.clone())));
    Image::from_channels((w, h), AnyChannels::sort(list))
        .write()
        .to_file(&y_path)
        .unwrap();
    let back = read_streak(&y_path, false).unwrap();
    assert_eq!((back.nx, back.nt, back.pixel_type), (w, h, PixelType::F16));
    for (a, b) in vals.iter().zip(&back.data) {
        assert_eq!(a.to_f32(), *b);
    }

    // R, G, B (+ A) in f16: the mean of the three colour channels, alpha ignored.
    let rgb_path = dir.path().join("rgb16.exr");
    let g: Vec<f16> = vals
        .iter()
        .map(|v| f16::from_f32(v.to_f32() * 2.0))
        .collect();
    let b: Vec<f16> = vals
        .iter()
        .map(|v| f16::from_f32(v.to_f32() + 4.0))
        .collect();
    let a: Vec<f16> = vec![f16::from_f32(0.25); w * h];
    let mut list = SmallVec::new();
    list.push(AnyChannel::new("R", FlatSamples::F16(vals.clone())));
    list.push(AnyChannel::new("G", FlatSamples::F16(g.clone())));
    list.push(AnyChannel::new("B", FlatSamples::F16(b.clone())));
    list.push(AnyChannel::new("A", FlatSamples::F16(a)));
    Image::from_channels((w, h), AnyChannels::sort(list))
        .write()
        .to_file(&rgb_path)
        .unwrap();
    let back = read_streak(&rgb_path, false).unwrap();
    assert_eq!(back.pixel_type, PixelType::RgbF16);
    for i in 0..w * h {
        let want = (vals[i].to_f32() + g[i].to_f32() + b[i].to_f32()) / 3.0;
        assert!((back.data[i] - want).abs() <= 1e-6 * want.abs().max(1.0));
    }

    // Two unrelated channels: refused, naming the channels.
    let odd = dir.path().join("odd.exr");
    let mut list = SmallVec::new();
    list.push(AnyChannel::new("Z", FlatSamples::F32(vec![0.0; w * h])));
    list.push(AnyChannel::new("depth", FlatSamples::F32(vec![0.0; w * h])));
    Image::from_channels((w, h), AnyChannels::sort(list))
        .write()
        .to_file(&odd)
        .unwrap();
    let err = read_streak(&odd, false).unwrap_err();
    assert!(matches!(err, FormatError::ChannelLayout { .. }), "{err}");
    assert!(err.to_string().contains("odd.exr"));
}

#[test]
fn hdr_reads_the_mean_of_rgb() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("line.HDR");
    let (w, h) = (4u32, 2u32);
    // Values exact in RGBE: 8-bit mantissas under one shared exponent per pixel.
    let pixels: Vec<[f32; 3]> = vec![
        [1.0, 0.5, 0.25],
        [0.75, 0.75, 0.75],
        [2.0, 2.0, 2.0],
        [0.0, 0.0, 0.0],
        [4.0, 1.0, 1.0],
        [0.5, 0.5, 0.5],
        [0.125, 0.125, 0.125],
        [8.0, 8.0, 8.0],
    ];
    let raw: Vec<f32> = pixels.iter().flatten().copied().collect();
    image::ImageBuffer::<image::Rgb<f32>, Vec<f32>>::from_raw(w, h, raw)
        .unwrap()
        .save_with_format(&path, image::ImageFormat::Hdr)
        .unwrap();
    let back = read_streak(&path, false).unwrap();
    assert_eq!((back.nx, back.nt, back.pixel_type), (4, 2, PixelType::Rgbe));
    for (p, v) in pixels.iter().zip(&back.data) {
        let want = (p[0] + p[1] + p[2]) / 3.0;
        assert!((v - want).abs() <= 1e-6, "{v} vs {want}");
    }
}

#[test]
fn tiff_16_bit_grey_and_32_bit_float() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (5u32, 3u32);
    let counts: Vec<u16> = (0..w * h).map(|i| (i * 4099 % 65536) as u16).collect();
    let path = dir.path().join("s.tif");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(w, h, counts.clone())
        .unwrap()
        .save_with_format(&path, image::ImageFormat::Tiff)
        .unwrap();
    let back = read_streak(&path, false).unwrap();
    assert_eq!((back.nx, back.nt, back.pixel_type), (5, 3, PixelType::U16));
    for (a, b) in counts.iter().zip(&back.data) {
        assert_eq!(*a as f32, *b);
    }

    let floats: Vec<f32> = (0..w * h).map(|i| i as f32 * -0.1 + 3.0).collect();
    let fpath = dir.path().join("f.tiff");
    let file = std::fs::File::create(&fpath).unwrap();
    let mut enc = tiff::encoder::TiffEncoder::new(file).unwrap();
    enc.write_image::<tiff::encoder::colortype::Gray32Float>(w, h, &floats)
        .unwrap();
    drop(enc);
    let back = read_streak(&fpath, false).unwrap();
    assert_eq!(back.pixel_type, PixelType::F32);
    assert_eq!(back.data, floats);
}

#[test]
fn integer_colour_must_be_grey() {
    let dir = tempfile::tempdir().unwrap();
    let grey = dir.path().join("grey.png");
    let colour = dir.path().join("colour.png");
    let raw: Vec<u16> = vec![7, 7, 7, 9000, 9000, 9000];
    image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(2, 1, raw)
        .unwrap()
        .save(&grey)
        .unwrap();
    let back = read_streak(&grey, false).unwrap();
    assert_eq!(back.pixel_type, PixelType::RgbU16);
    assert_eq!(back.data, vec![7.0, 9000.0]);
    let raw: Vec<u16> = vec![7, 7, 7, 9000, 9001, 9000];
    image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(2, 1, raw)
        .unwrap()
        .save(&colour)
        .unwrap();
    let err = read_streak(&colour, false).unwrap_err();
    assert!(matches!(err, FormatError::ChannelLayout { .. }), "{err}");
    let msg = err.to_string();
    assert!(
        msg.contains("colour.png") && msg.contains("x 1, row 0"),
        "{msg}"
    );
}

#[test]
fn truncated_png_and_unknown_type_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("whole.png");
    formats::raster::write_png16(&path, &test_image(40, 30), 1.0).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.png");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = read_streak(&cut, false).unwrap_err();
    assert!(matches!(err, FormatError::Decode { .. }), "{err}");
    assert!(err.to_string().contains("cut.png"), "{err}");

    let jpg = dir.path().join("a.jpg");
    std::fs::write(&jpg, b"x").unwrap();
    let err = read_streak(&jpg, false).unwrap_err();
    assert!(matches!(err, FormatError::UnknownFileType { .. }));
    assert!(err.to_string().contains("a.jpg"));

    let missing = dir.path().join("missing.exr");
    let err = read_streak(&missing, false).unwrap_err();
    assert!(matches!(err, FormatError::Io { .. }), "{err}");
    assert!(err.to_string().contains("missing.exr"));
}

#[test]
fn transpose_swaps_x_and_time() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.exr");
    let stored = test_image(6, 4); // the file: 6 columns, 4 rows
    formats::raster::write_exr_f32(&path, &stored).unwrap();
    let img = read_streak(&path, true).unwrap();
    // Transposed: x runs down the file's rows, time across its columns.
    assert_eq!((img.nx, img.nt), (4, 6));
    for t in 0..6 {
        for x in 0..4 {
            assert_eq!(img.at(x, t), stored.at(t, x));
        }
    }
}

/// Parse the comment of an `.img` written by `write_img`, independently of the reader.
fn img_layout(bytes: &[u8]) -> (usize, usize, usize, i16, String) {
    assert_eq!(&bytes[0..2], b"IM");
    let i16_at = |o: usize| i16::from_le_bytes([bytes[o], bytes[o + 1]]);
    let comment_len = i16_at(2) as usize;
    let comment = String::from_utf8(bytes[64..64 + comment_len].to_vec()).unwrap();
    (
        comment_len,
        i16_at(4) as usize,
        i16_at(6) as usize,
        i16_at(12),
        comment,
    )
}

#[test]
fn img_round_trip_16_and_32_bit_with_time_table() {
    let dir = tempfile::tempdir().unwrap();
    let (nx, nt) = (11, 7);
    let dt_ps = 1.875;
    let t0_ps = -3.5;
    let times: Vec<f64> = (0..nt).map(|i| t0_ps + dt_ps * i as f64).collect();
    for (bits, file_type, max) in [(16u32, 2i16, 65535.0f64), (32, 3, 4294967295.0)] {
        let mut img = test_image(nx, nt);
        img.data[5] = 70000.4; // saturates at 16 bits only
        img.data[6] = 2.5; // rounds half away from zero -> 3
        let path = dir.path().join(format!("s{bits}.img"));
        let saturated = formats::hamamatsu::write_img(&path, &img, bits, &times).unwrap();
        let expected_saturated = img
            .data
            .iter()
            .filter(|&&v| (v as f64).round() > max)
            .count();
        assert_eq!(saturated, expected_saturated);

        // Container layout, checked against the HPD-TA conventions directly.
        let bytes = std::fs::read(&path).unwrap();
        let (comment_len, w, h, ft, comment) = img_layout(&bytes);
        assert_eq!((w, h, ft), (nx, nt, file_type));
        let bpp = bits as usize / 8;
        let table_offset = 64 + comment_len + nx * nt * bpp;
        assert_eq!(bytes.len(), table_offset + 4 * nt);
        assert!(comment.contains("ScalingYType=2"), "{comment}");
        assert!(comment.contains("ScalingYUnit=\"ps\""), "{comment}");
        assert!(
            comment.contains(&format!("ScalingYScalingFile=\"#{table_offset},{nt:04}\"")),
            "{comment}"
        );
        for section in [
            "[Application]",
            "[Acquisition]",
            "[Streak camera]",
            "[Scaling]",
        ] {
            assert!(comment.contains(section), "{section} missing: {comment}");
        }
        // The sweep window, 7 rows of 1.875 ps = 13.125 ps, is recorded as the time range.
        assert!(comment.contains("Time Range=\"13.125 ps\""), "{comment}");

        let back = read_streak(&path, false).unwrap();
        assert_eq!((back.nx, back.nt), (nx, nt));
        assert_eq!(
            back.pixel_type,
            if bits == 16 {
                PixelType::U16
            } else {
                PixelType::U32
            }
        );
        for (i, (&v, &s)) in img.data.iter().zip(&back.data).enumerate() {
            let want = (v as f64).round().clamp(0.0, max);
            assert_eq!(s as f64, want, "pixel {i}: {v}");
        }
        assert_eq!(back.data[6], 3.0);
        let t = back.time_axis_ps.as_ref().unwrap();
        for (a, b) in t.iter().zip(&times) {
            assert!((a - b).abs() <= 1e-6 * b.abs().max(1.0), "{a} vs {b}");
        }
        let meta = back.img_meta.as_ref().unwrap();
        assert_eq!(meta.scaling_x, AxisScaling::Pixels);
        assert!(back.x_axis.is_none());
        assert!((meta.time_range_ps.unwrap() - 13.125).abs() < 1e-9);

        // Transposed, the rows become x (with the ps table as their axis) and time is
        // uncalibrated.
        let tr = read_streak(&path, true).unwrap();
        assert_eq!((tr.nx, tr.nt), (nt, nx));
        assert!(tr.time_axis_ps.is_none());
        assert_eq!(tr.x_axis.as_ref().unwrap().unit, "ps");
        for x in 0..nt {
            for t in 0..nx {
                assert_eq!(tr.at(x, t), back.at(t, x));
            }
        }
    }
}

#[test]
fn img_writer_refuses_bad_input_without_leaving_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.img");
    let img = test_image(3, 2);
    let w = formats::hamamatsu::write_img;
    assert!(matches!(
        w(&path, &img, 8, &[0.0, 1.0]),
        Err(FormatError::InvalidArgument { .. })
    ));
    assert!(matches!(
        w(&path, &img, 16, &[0.0]),
        Err(FormatError::SizeMismatch { .. })
    ));
    assert!(matches!(
        w(&path, &img, 16, &[1.0, 1.0]),
        Err(FormatError::InvalidArgument { .. })
    ));
    let mut nan = img.clone();
    nan.data[4] = f32::NAN;
    assert!(matches!(
        w(&path, &nan, 32, &[0.0, 1.0]),
        Err(FormatError::NonFinite { x: 1, t: 1, .. })
    ));
    assert!(!path.exists());
}

/// Write a small valid `.img`, then apply `patch` to its bytes.
fn patched_img(dir: &Path, name: &str, patch: impl FnOnce(&mut Vec<u8>)) -> PathBuf {
    let path = dir.join(name);
    let img = test_image(4, 3);
    formats::hamamatsu::write_img(&path, &img, 16, &[0.0, 2.0, 4.0]).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    patch(&mut bytes);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn replace_once(bytes: &mut [u8], from: &str, to: &str) {
    assert_eq!(from.len(), to.len());
    let at = bytes
        .windows(from.len())
        .position(|w| w == from.as_bytes())
        .unwrap();
    bytes[at..at + from.len()].copy_from_slice(to.as_bytes());
}

#[test]
fn img_reader_says_what_it_does_not_know() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: Vec<(PathBuf, &str)> = vec![
        (
            patched_img(d, "compressed.img", |b| b[12] = 1),
            "compressed",
        ),
        (patched_img(d, "type9.img", |b| b[12] = 9), "file type 9"),
        (
            patched_img(d, "magic.img", |b| b[0] = b'X'),
            "not a Hamamatsu",
        ),
        (
            patched_img(d, "scaling.img", |b| {
                replace_once(b, "ScalingYType=2", "ScalingYType=7")
            }),
            "unknown scaling type \"7\"",
        ),
        (
            patched_img(d, "unit.img", |b| {
                replace_once(b, "ScalingYUnit=\"ps\"", "ScalingYUnit=\"qs\"")
            }),
            "unknown time unit \"qs\"",
        ),
        (
            patched_img(d, "key.img", |b| {
                replace_once(b, "ScalingYScale=1", "ScalingYShift=1")
            }),
            "unknown key \"ScalingYShift\"",
        ),
        (
            patched_img(d, "short.img", |b| b.truncate(b.len() - 3)),
            "truncated",
        ),
        (
            // A table shorter than the image (a longer one is cropped by areSource).
            patched_img(d, "count.img", |b| replace_once(b, ",0003\"", ",0002\"")),
            "size mismatch",
        ),
    ];
    for (path, want) in cases {
        let err = read_streak(&path, false).unwrap_err();
        let msg = err.to_string();
        let name = path.file_name().unwrap().to_str().unwrap();
        assert!(msg.contains(name), "{msg}");
        assert!(msg.contains(want), "{name}: {msg}");
    }
}

fn full_manifest() -> Manifest {
    let (ny, nt) = (3, 4);
    Manifest {
        capture: CaptureInfo {
            scene: "cornell box".into(),
            nx: 8,
            ny,
            nt,
            dt_ps: 1.9,
            t0_ps: -12.5,
            exposure_s: Some(300.0),
            exposure_note: Some("60 exposures of 5 s".into()),
            sensor_fwhm_ps: Some(3.5),
            png_value_per_count: Some(1.0 / 4096.0),
            eta: 1.0,
            laser_wavelength_nm: 795.0,
            pulse_width_fs: 50.0,
            formats: vec![
                StreakFormat::Png16,
                StreakFormat::ExrF32,
                StreakFormat::Img32,
            ],
            seed: Some(42),
            spp: Some(64),
            created_by: Some("femto simulate --scene cornell".into()),
        },
        files: CaptureFiles {
            geometry: Some("scene.glb".into()),
            calibration: Some("calibration.toml".into()),
            fiducials: Some("fiducials.toml".into()),
            truth_camera: Some("truth_camera.h5".into()),
            truth_world: Some("truth_world.h5".into()),
            truth_direct: None,
            flat: Some("flat.exr".into()),
            dark: None,
        },
        imperfections: Imperfections {
            photon_noise: Some(PhotonNoise {
                photons_at_full_scale: Some(5000.0),
                photons_per_unit: None,
            }),
            dark: Some(Dark {
                offset: 0.01,
                sigma: 0.003,
            }),
            vignetting: Some(Vignetting {
                strength: 0.2,
                model: "1 - strength * r^2, r = distance from the centre / half-diagonal".into(),
            }),
            jitter: Some(Jitter {
                sigma_ps: 0.7,
                shifts_ps: vec![0.1, -0.6, 1.25],
            }),
            power: Some(Power {
                sigma: 0.05,
                factors: vec![1.02, 0.97, 1.0],
            }),
            sweep: Some(Sweep {
                strength: 0.03,
                bin_times_ps: vec![-12.5, -10.7, -8.7, -6.9, -4.9],
            }),
            saturation: Some(Saturation { level: 15.5 }),
            fiducials: Some(FiducialNoise {
                photo_px: 0.5,
                photo_width_px: 4032.0,
                sigma_px: 0.04,
            }),
        },
        // Deliberately out of order: loading sorts by index.
        scanlines: [2usize, 0, 1]
            .iter()
            .map(|&y| Scanline {
                index: y,
                file: Manifest::default_scanline_name(y, "png"),
                png: Some(Manifest::default_scanline_name(y, "png")),
                exr: Some(Manifest::default_scanline_name(y, "exr")),
                img: Some(Manifest::default_scanline_name(y, "img")),
            })
            .collect(),
    }
}

#[test]
fn manifest_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("manifest.toml");
    let m = full_manifest();
    m.save(&path).unwrap();
    let back = Manifest::load(&path).unwrap();
    let mut sorted = m.clone();
    sorted.scanlines.sort_by_key(|s| s.index);
    assert_eq!(back, sorted);
    assert_eq!(
        back.scanline_path(dir.path(), 1).unwrap(),
        dir.path().join("scanlines/scanline_0001.png")
    );
    assert!(back.scanline_path(dir.path(), 3).is_none());
    // Fields left out stay out of the file and come back as None.
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(!text.contains("truth_direct") && !text.contains("photons_per_unit"));
}

#[test]
fn manifest_bad_key_and_bad_coverage_name_the_line_and_index() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("manifest.toml");
    full_manifest().save(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();

    // An unknown key in [capture]: its line is where it was inserted.
    let insert_after = text.find("[capture]\n").unwrap() + "[capture]\n".len();
    let line = text[..insert_after].matches('\n').count() + 1;
    let bad = format!(
        "{}dt_fs = 3.0\n{}",
        &text[..insert_after],
        &text[insert_after..]
    );
    let bad_path = dir.path().join("bad.toml");
    std::fs::write(&bad_path, bad).unwrap();
    let err = Manifest::load(&bad_path).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, ManifestError::Parse { .. }), "{msg}");
    assert!(msg.contains("bad.toml"), "{msg}");
    assert!(msg.contains(&format!("line {line}")), "{msg}");
    assert!(msg.contains("dt_fs"), "{msg}");

    // A scanline listed twice.
    let dup = text.replacen("index = 2", "index = 0", 1);
    let dup_path = dir.path().join("dup.toml");
    std::fs::write(&dup_path, dup).unwrap();
    let msg = Manifest::load(&dup_path).unwrap_err().to_string();
    assert!(
        msg.contains("dup.toml") && msg.contains("index 0 appears twice"),
        "{msg}"
    );
}

#[test]
fn every_reader_refuses_truncated_files_without_panicking() {
    let dir = tempfile::tempdir().unwrap();
    let img = test_image(24, 16);
    let mut files = Vec::new();
    let png = dir.path().join("a.png");
    formats::raster::write_png16(&png, &img, 0.5).unwrap();
    files.push(png);
    let exr = dir.path().join("a.exr");
    formats::raster::write_exr_f32(&exr, &img).unwrap();
    files.push(exr);
    let tif = dir.path().join("a.tif");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(24, 16, vec![9u16; 24 * 16])
        .unwrap()
        .save_with_format(&tif, image::ImageFormat::Tiff)
        .unwrap();
    files.push(tif);
    let hdr = dir.path().join("a.hdr");
    image::ImageBuffer::<image::Rgb<f32>, Vec<f32>>::from_raw(24, 16, vec![0.5f32; 24 * 16 * 3])
        .unwrap()
        .save_with_format(&hdr, image::ImageFormat::Hdr)
        .unwrap();
    files.push(hdr);
    let times: Vec<f64> = (0..16).map(|i| i as f64).collect();
    let img_path = dir.path().join("a.img");
    formats::hamamatsu::write_img(&img_path, &img, 16, &times).unwrap();
    files.push(img_path);
    for path in files {
        let bytes = std::fs::read(&path).unwrap();
        let ext = path.extension().unwrap().to_str().unwrap();
        for frac in [0.0, 0.1, 0.3, 0.6, 0.9, 0.99] {
            let cut = (bytes.len() as f64 * frac) as usize;
            let short = dir.path().join(format!("cut{cut}.{ext}"));
            std::fs::write(&short, &bytes[..cut]).unwrap();
            match read_streak(&short, false) {
                Err(e) => assert!(e.to_string().contains(&format!("cut{cut}.{ext}")), "{e}"),
                Ok(_) => panic!("{}: {cut} of {} bytes read without error", ext, bytes.len()),
            }
        }
    }
}

/// Assemble an HPD-TA file by hand: header, comment, pixels, then `tail` (axis tables).
fn hand_built_img(
    file_type: i16,
    w: usize,
    h: usize,
    comment: &str,
    pixels: &[u8],
    tail: &[u8],
) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(b"IM");
    b.extend_from_slice(&(comment.len() as i16).to_le_bytes());
    b.extend_from_slice(&(w as i16).to_le_bytes());
    b.extend_from_slice(&(h as i16).to_le_bytes());
    b.extend_from_slice(&[0; 4]);
    b.extend_from_slice(&file_type.to_le_bytes());
    b.resize(64, 0);
    b.extend_from_slice(comment.as_bytes());
    b.extend_from_slice(pixels);
    b.extend_from_slice(tail);
    b
}

#[test]
fn hand_built_8_bit_img_with_linear_and_decreasing_axes() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (3usize, 4usize);
    let pixels: Vec<u8> = (0..(w * h) as u8).map(|i| i * 10).collect();

    // Linear axes: X in mm (0.25 per pixel), Y in ns (0.5 per pixel) -> 500 ps per row.
    let comment = "[Streak camera],Time Range=\"2 ns\",MCP Gain=\"12\"\r\n\
                   [Scaling],ScalingXType=1,ScalingXScale=0.25,ScalingXUnit=\"mm\",\
                   ScalingXScalingFile=\"\",ScalingYType=1,ScalingYScale=0.5,ScalingYUnit=\"ns\",\
                   ScalingYScalingFile=\"\"";
    let path = dir.path().join("linear.img");
    std::fs::write(&path, hand_built_img(0, w, h, comment, &pixels, &[])).unwrap();
    let img = read_streak(&path, false).unwrap();
    assert_eq!((img.nx, img.nt, img.pixel_type), (3, 4, PixelType::U8));
    assert_eq!(
        img.data,
        pixels.iter().map(|&p| p as f32).collect::<Vec<_>>()
    );
    assert_eq!(img.time_axis_ps.unwrap(), vec![0.0, 500.0, 1000.0, 1500.0]);
    let x = img.x_axis.unwrap();
    assert_eq!((x.values, x.unit.as_str()), (vec![0.0, 0.25, 0.5], "mm"));
    let meta = img.img_meta.unwrap();
    assert_eq!(meta.time_range_ps, Some(2000.0));
    assert_eq!(meta.mcp_gain, Some(12.0));

    // A decreasing time table (in fs): the rows are flipped so that time increases.
    let make = |offset: usize| {
        format!(
            "[Scaling],ScalingYType=2,ScalingYScale=1,ScalingYUnit=\"fs\",\
             ScalingYScalingFile=\"#{offset},{h:04}\""
        )
    };
    // The offset is written inside the comment: a three-digit offset fits here.
    let offset = 64 + make(100).len() + w * h;
    let comment = make(offset);
    assert_eq!(64 + comment.len() + w * h, offset);
    let table_fs: [f32; 4] = [3000.0, 2000.0, 1000.0, 0.0];
    let tail: Vec<u8> = table_fs.iter().flat_map(|v| v.to_le_bytes()).collect();
    let path = dir.path().join("flipped.img");
    std::fs::write(&path, hand_built_img(0, w, h, &comment, &pixels, &tail)).unwrap();
    let img = read_streak(&path, false).unwrap();
    assert_eq!(
        img.time_axis_ps.as_ref().unwrap(),
        &vec![0.0, 1.0, 2.0, 3.0]
    );
    for t in 0..h {
        for x in 0..w {
            assert_eq!(img.at(x, t), pixels[(h - 1 - t) * w + x] as f32);
        }
    }
    assert!(img.img_meta.as_ref().unwrap().rows_reversed);

    // A table that goes back and forth is refused.
    let bumpy: Vec<u8> = [0.0f32, 2.0, 1.0, 3.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let path = dir.path().join("bumpy.img");
    std::fs::write(&path, hand_built_img(0, w, h, &comment, &pixels, &bumpy)).unwrap();
    let err = read_streak(&path, false).unwrap_err();
    assert!(
        matches!(
            err,
            FormatError::NonMonotonicAxis {
                axis: 'Y',
                index: 2,
                ..
            }
        ),
        "{err}"
    );
}
