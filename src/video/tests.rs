//! Tests of the video writers: GIF, MP4, frame sequences and colour conversion.

use super::*;
use image::AnimationDecoder;

/// A smooth moving pattern: a horizontal sine in red that travels 3 pixels per frame,
/// a vertical ramp in green and a horizontal ramp in blue, kept inside 20..=235 so that
/// limited-range clipping plays no part.
fn moving_gradient(width: usize, height: usize, k: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(width * height * 3);
    for y in 0..height {
        for x in 0..width {
            let phase = 2.0 * std::f64::consts::PI * (x + 3 * k) as f64 / width as f64;
            let r = 128.0 + 90.0 * phase.sin();
            let g = 30.0 + 180.0 * y as f64 / (height - 1) as f64;
            let b = 220.0 - 150.0 * x as f64 / (width - 1) as f64;
            out.extend([r, g, b].map(|v| v.round() as u8));
        }
    }
    out
}

fn srgb_frame(width: usize, height: usize, srgb8: Vec<u8>) -> Frame {
    Frame {
        width,
        height,
        linear_rgb: Vec::new(),
        srgb8,
    }
}

#[test]
fn bt709_limited_range_matches_published_code_values() {
    // ITU-R BT.709 8-bit studio-range values of the primaries, white and black.
    let cases: [([u8; 3], [u8; 3]); 5] = [
        ([255, 255, 255], [235, 128, 128]),
        ([0, 0, 0], [16, 128, 128]),
        ([255, 0, 0], [63, 102, 240]),
        ([0, 255, 0], [173, 42, 26]),
        ([0, 0, 255], [32, 240, 118]),
    ];
    for (rgb, ycbcr) in cases {
        let img: Vec<u8> = (0..4).flat_map(|_| rgb).collect();
        let (mut y, mut cb, mut cr) = ([0u8; 4], [0u8; 1], [0u8; 1]);
        srgb8_to_yuv420_bt709(&img, 2, 2, &mut y, &mut cb, &mut cr);
        assert_eq!([y[0], cb[0], cr[0]], ycbcr, "rgb {rgb:?}");
        assert!(y.iter().all(|&v| v == ycbcr[0]));
    }
}

// ---- A minimal MP4 reader, written for this test: box walk, sample table, avcC. ----

fn be32(b: &[u8]) -> u32 {
    u32::from_be_bytes([b[0], b[1], b[2], b[3]])
}

fn boxes(mut data: &[u8]) -> Vec<([u8; 4], &[u8])> {
    let mut out = Vec::new();
    while data.len() >= 8 {
        let size = be32(data) as usize;
        let kind = [data[4], data[5], data[6], data[7]];
        let (header, size) = match size {
            0 => (8, data.len()),
            1 => (
                16,
                u64::from_be_bytes(data[8..16].try_into().unwrap()) as usize,
            ),
            s => (8, s),
        };
        out.push((kind, &data[header..size]));
        data = &data[size..];
    }
    out
}

fn child<'a>(data: &'a [u8], kind: &[u8; 4]) -> &'a [u8] {
    boxes(data)
        .into_iter()
        .find(|(k, _)| k == kind)
        .unwrap_or_else(|| panic!("no {} box", String::from_utf8_lossy(kind)))
        .1
}

struct Mp4Track {
    timescale: u32,
    sample_deltas: Vec<u32>,
    width: u16,
    height: u16,
    sps_pps_annex_b: Vec<u8>,
    /// Each sample converted to Annex B.
    samples_annex_b: Vec<Vec<u8>>,
}

fn read_mp4(file: &[u8]) -> Mp4Track {
    let top = boxes(file);
    assert_eq!(&top[0].0, b"ftyp");
    let moov = child(file, b"moov");
    let mdia = child(child(moov, b"trak"), b"mdia");
    let mdhd = child(mdia, b"mdhd");
    let timescale = if mdhd[0] == 0 {
        be32(&mdhd[12..])
    } else {
        be32(&mdhd[20..])
    };
    assert_eq!(child(mdia, b"hdlr")[8..12], *b"vide");
    let stbl = child(child(mdia, b"minf"), b"stbl");

    let stts = child(stbl, b"stts");
    let mut sample_deltas = Vec::new();
    for e in 0..be32(&stts[4..]) as usize {
        let (count, delta) = (be32(&stts[8 + 8 * e..]), be32(&stts[12 + 8 * e..]));
        sample_deltas.extend(std::iter::repeat_n(delta, count as usize));
    }

    let stsz = child(stbl, b"stsz");
    let (fixed, count) = (be32(&stsz[4..]), be32(&stsz[8..]) as usize);
    let sizes: Vec<usize> = (0..count)
        .map(|i| {
            if fixed != 0 {
                fixed as usize
            } else {
                be32(&stsz[12 + 4 * i..]) as usize
            }
        })
        .collect();
    let stco = child(stbl, b"stco");
    let chunk_offsets: Vec<usize> = (0..be32(&stco[4..]) as usize)
        .map(|i| be32(&stco[8 + 4 * i..]) as usize)
        .collect();
    let stsc = child(stbl, b"stsc");
    let stsc_entries: Vec<(usize, usize)> = (0..be32(&stsc[4..]) as usize)
        .map(|i| {
            let e = &stsc[8 + 12 * i..];
            (be32(e) as usize, be32(&e[4..]) as usize)
        })
        .collect();

    let stsd = child(stbl, b"stsd");
    let entries = boxes(&stsd[8..]);
    assert_eq!(&entries[0].0, b"avc1");
    let avc1 = entries[0].1;
    let width = u16::from_be_bytes([avc1[24], avc1[25]]);
    let height = u16::from_be_bytes([avc1[26], avc1[27]]);
    let avcc = child(&avc1[78..], b"avcC");
    let length_size = (avcc[4] & 3) as usize + 1;
    let mut sps_pps_annex_b = Vec::new();
    let mut p = 5;
    for _ in 0..2 {
        let n = (avcc[p] & 0x1f) as usize;
        p += 1;
        for _ in 0..n {
            let len = u16::from_be_bytes([avcc[p], avcc[p + 1]]) as usize;
            sps_pps_annex_b.extend([0, 0, 0, 1]);
            sps_pps_annex_b.extend(&avcc[p + 2..p + 2 + len]);
            p += 2 + len;
        }
    }

    let mut samples_annex_b = Vec::new();
    let mut sample = 0;
    for (c, &chunk_offset) in chunk_offsets.iter().enumerate() {
        let per_chunk = stsc_entries
            .iter()
            .rev()
            .find(|(first, _)| *first <= c + 1)
            .unwrap()
            .1;
        let mut offset = chunk_offset;
        for _ in 0..per_chunk {
            let data = &file[offset..offset + sizes[sample]];
            let mut annex_b = Vec::new();
            let mut q = 0;
            while q < data.len() {
                let len = data[q..q + length_size]
                    .iter()
                    .fold(0usize, |a, &b| (a << 8) | b as usize);
                annex_b.extend([0, 0, 0, 1]);
                annex_b.extend(&data[q + length_size..q + length_size + len]);
                q += length_size + len;
            }
            samples_annex_b.push(annex_b);
            offset += sizes[sample];
            sample += 1;
        }
    }
    assert_eq!(sample, count);
    Mp4Track {
        timescale,
        sample_deltas,
        width,
        height,
        sps_pps_annex_b,
        samples_annex_b,
    }
}

/// BT.709 limited-range Y'CbCr -> R'G'B' with the standard published inverse coefficients.
fn decoded_to_rgb(yuv: &impl YUVSource) -> Vec<[f64; 3]> {
    let (w, h) = yuv.dimensions();
    let (sy, su, sv) = yuv.strides();
    let mut out = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            let y = yuv.y()[j * sy + i] as f64 - 16.0;
            let cb = yuv.u()[(j / 2) * su + i / 2] as f64 - 128.0;
            let cr = yuv.v()[(j / 2) * sv + i / 2] as f64 - 128.0;
            out.push([
                1.164383 * y + 1.792741 * cr,
                1.164383 * y - 0.213249 * cb - 0.532909 * cr,
                1.164383 * y + 2.112402 * cb,
            ]);
        }
    }
    out
}

#[test]
fn mp4_decodes_back_to_every_frame_with_its_colours() {
    let (w, h, n, fps) = (64usize, 48usize, 10usize, 25.0);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("clip.mp4");
    let sources: Vec<Vec<u8>> = (0..n).map(|k| moving_gradient(w, h, k)).collect();
    let mut writer = VideoWriter::create(&path, VideoFormat::Mp4, w, h, fps).unwrap();
    for src in &sources {
        writer.push(&srgb_frame(w, h, src.clone())).unwrap();
        assert!(!path.exists(), "the MP4 must appear only on finish");
    }
    assert_eq!(writer.finish().unwrap(), n);
    // Only the MP4 is left in the folder (no temporary file).
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);

    let file = fs::read(&path).unwrap();
    let track = read_mp4(&file);
    assert_eq!((track.width as usize, track.height as usize), (w, h));
    assert_eq!(track.samples_annex_b.len(), n);
    // Constant frame rate: every sample lasts timescale / fps ticks.
    assert_eq!(track.sample_deltas.len(), n);
    let tick = track.timescale as f64 / fps;
    assert!(track.sample_deltas.iter().all(|&d| d as f64 == tick));

    let mut decoder = openh264::decoder::Decoder::new().unwrap();
    assert!(decoder.decode(&track.sps_pps_annex_b).unwrap().is_none());
    let mut decoded: Vec<Vec<[f64; 3]>> = Vec::new();
    for s in &track.samples_annex_b {
        if let Some(yuv) = decoder.decode(s).unwrap() {
            assert_eq!(yuv.dimensions(), (w, h));
            decoded.push(decoded_to_rgb(&yuv));
        }
    }
    for yuv in decoder.flush_remaining().unwrap() {
        decoded.push(decoded_to_rgb(&yuv));
    }
    assert_eq!(decoded.len(), n, "every frame decodes");

    let mut worst_rms = 0.0f64;
    for (k, (rgb, src)) in decoded.iter().zip(&sources).enumerate() {
        let mut mean_err = [0.0f64; 3];
        let mut sq = 0.0;
        for (d, s) in rgb.iter().zip(src.chunks_exact(3)) {
            for c in 0..3 {
                let e = d[c] - s[c] as f64;
                mean_err[c] += e / (w * h) as f64;
                sq += e * e;
            }
        }
        let rms = (sq / (3 * w * h) as f64).sqrt();
        // 8-bit rounding of Y'CbCr and 4:2:0 averaging of a smooth pattern stay within a
        // level or two; the bit budget (1 Mbit/s for 64x48 at 25 fps) leaves the mean alone.
        assert!(
            mean_err.iter().all(|e| e.abs() < 2.0),
            "frame {k}: mean colour error {mean_err:?}"
        );
        assert!(rms < 4.0, "frame {k}: rms error {rms}");
        worst_rms = worst_rms.max(rms);
    }
    eprintln!(
        "MP4 round trip: worst frame rms error {worst_rms:.2} levels, {} bytes",
        file.len()
    );
}

#[test]
fn mp4_rejects_odd_sizes_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("odd.mp4");
    for (w, h) in [(65, 48), (64, 47)] {
        let err = VideoWriter::create(&path, VideoFormat::Mp4, w, h, 24.0)
            .err()
            .expect("odd size must fail");
        assert!(matches!(err, VideoError::OddSize { .. }));
        let msg = err.to_string();
        assert!(msg.contains(&format!("{w}x{h}")), "{msg}");
    }
    assert!(!path.exists());
    // An MP4 that got no frame is an error and leaves nothing behind.
    let writer = VideoWriter::create(&path, VideoFormat::Mp4, 64, 48, 24.0).unwrap();
    assert!(matches!(writer.finish(), Err(VideoError::NoFrames { .. })));
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn gif_decodes_with_every_frame() {
    let (w, h, n, fps) = (40usize, 30usize, 6usize, 20.0);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("clip.gif");
    let sources: Vec<Vec<u8>> = (0..n).map(|k| moving_gradient(w, h, k)).collect();
    let mut writer = VideoWriter::create(&path, VideoFormat::Gif, w, h, fps).unwrap();
    for src in &sources {
        writer.push(&srgb_frame(w, h, src.clone())).unwrap();
    }
    assert!(!path.exists(), "the GIF must appear only on finish");
    writer.finish().unwrap();

    let file = fs::File::open(&path).unwrap();
    let decoder = image::codecs::gif::GifDecoder::new(io::BufReader::new(file)).unwrap();
    let frames = decoder.into_frames().collect_frames().unwrap();
    assert_eq!(frames.len(), n);
    for (frame, src) in frames.iter().zip(&sources) {
        // 1 / 20 fps = 5 hundredths of a second.
        assert_eq!(frame.delay().numer_denom_ms(), (50, 1));
        let buf = frame.buffer();
        assert_eq!((buf.width() as usize, buf.height() as usize), (w, h));
        // A 256-colour palette per frame: the mean colour survives within a few levels.
        let mut mean_err = [0.0f64; 3];
        for (p, s) in buf.pixels().zip(src.chunks_exact(3)) {
            for c in 0..3 {
                mean_err[c] += (p.0[c] as f64 - s[c] as f64) / (w * h) as f64;
            }
        }
        assert!(mean_err.iter().all(|e| e.abs() < 3.0), "{mean_err:?}");
    }
}

#[test]
fn png_sequence_uses_global_frame_numbers_and_exact_pixels() {
    let (w, h) = (7usize, 5usize);
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("frames");
    let mut writer = VideoWriter::create(&seq, VideoFormat::PngSequence, w, h, 24.0)
        .unwrap()
        .first_frame_index(7);
    let sources: Vec<Vec<u8>> = (0..3)
        .map(|k| {
            (0..w * h * 3)
                .map(|i| ((i * 37 + k * 11) % 256) as u8)
                .collect()
        })
        .collect();
    for src in &sources {
        writer.push(&srgb_frame(w, h, src.clone())).unwrap();
    }
    assert_eq!(writer.finish().unwrap(), 3);
    let mut names: Vec<String> = fs::read_dir(&seq)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["frame_00007.png", "frame_00008.png", "frame_00009.png"]
    );
    for (name, src) in names.iter().zip(&sources) {
        let img = image::open(seq.join(name)).unwrap().to_rgb8();
        assert_eq!((img.width() as usize, img.height() as usize), (w, h));
        assert_eq!(img.as_raw(), src);
    }
}

#[test]
fn a_sequence_appears_on_finish_and_replaces_an_earlier_one_whole() {
    let (w, h) = (4usize, 2usize);
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("frames");
    let write = |n: usize, value: u8| {
        let mut writer = VideoWriter::create(&seq, VideoFormat::PngSequence, w, h, 24.0)?;
        for _ in 0..n {
            writer.push(&srgb_frame(w, h, vec![value; w * h * 3]))?;
            assert!(!seq.exists() || value != 10, "frames appear only on finish");
        }
        writer.finish()
    };
    write(5, 10).unwrap();
    assert_eq!(fs::read_dir(&seq).unwrap().count(), 5);
    write(2, 200).unwrap();
    let mut names: Vec<String> = fs::read_dir(&seq)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["frame_00000.png", "frame_00001.png"]);
    let img = image::open(seq.join("frame_00001.png")).unwrap().to_rgb8();
    assert!(img.as_raw().iter().all(|&v| v == 200));
    // Only the sequence folder is left beside it (no temporary folder).
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    // A folder holding anything else is refused before a frame is made.
    fs::write(seq.join("notes.txt"), "mine").unwrap();
    let err = write(1, 50).expect_err("a foreign file");
    assert!(matches!(err, VideoError::NotASequence { .. }), "{err}");
    assert!(err.to_string().contains("notes.txt"), "{err}");
    assert_eq!(fs::read_dir(&seq).unwrap().count(), 3);
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    assert!(is_frame_name("frame_00042.exr") && !is_frame_name("frame_.png"));
}

#[test]
fn split_renders_of_one_sequence_add_up_and_drop_stale_frames() {
    let (w, h) = (2usize, 2usize);
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("frames");
    let render = |frames: std::ops::Range<usize>, total: usize, value: u8| {
        let mut writer = VideoWriter::create(&seq, VideoFormat::PngSequence, w, h, 24.0)
            .unwrap()
            .first_frame_index(frames.start)
            .sequence_length(total);
        for _ in frames {
            writer
                .push(&srgb_frame(w, h, vec![value; w * h * 3]))
                .unwrap();
        }
        writer.finish().unwrap();
    };
    let values = || -> Vec<(String, u8)> {
        let mut v: Vec<(String, u8)> = fs::read_dir(&seq)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                let img = image::open(e.path()).unwrap().to_rgb8();
                (
                    e.file_name().to_string_lossy().into_owned(),
                    img.as_raw()[0],
                )
            })
            .collect();
        v.sort();
        v
    };
    // An earlier sequence of 6 frames, then one of 4 rendered in two parts.
    render(0..6, 6, 1);
    render(0..2, 4, 2);
    render(2..4, 4, 3);
    let expected: Vec<(String, u8)> = [(0, 2), (1, 2), (2, 3), (3, 3)]
        .iter()
        .map(|&(k, v)| (sequence_file_name(k, VideoFormat::PngSequence), v))
        .collect();
    assert_eq!(values(), expected);
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn exr_sequence_round_trips_float_values() {
    let (w, h) = (5usize, 3usize);
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("exr");
    let mut writer = VideoWriter::create(&seq, VideoFormat::ExrSequence, w, h, 30.0).unwrap();
    // HDR values, tiny values and negatives (out-of-gamut colour) must all survive.
    let linear: Vec<f32> = (0..w * h * 3)
        .map(|i| (i as f32 - 7.0) * 1.37e-3 * (1.0 + (i % 5) as f32 * 1000.0))
        .collect();
    writer
        .push(&Frame {
            width: w,
            height: h,
            linear_rgb: linear.clone(),
            srgb8: Vec::new(),
        })
        .unwrap();
    writer.finish().unwrap();
    let path = seq.join("frame_00000.exr");
    let image = exr::prelude::read_first_rgba_layer_from_file(
        &path,
        |size, _| vec![0.0f32; size.0 * size.1 * 3],
        move |buf: &mut Vec<f32>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let o = (pos.1 * w + pos.0) * 3;
            buf[o..o + 3].copy_from_slice(&[r, g, b]);
        },
    )
    .unwrap();
    assert_eq!(image.layer_data.size.0, w);
    assert_eq!(image.layer_data.channel_data.pixels, linear);
}

#[test]
fn wrong_frames_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let seq = dir.path().join("s");
    let mut writer = VideoWriter::create(&seq, VideoFormat::PngSequence, 4, 4, 24.0)
        .unwrap()
        .first_frame_index(3);
    let err = writer.push(&srgb_frame(4, 5, vec![0; 60])).unwrap_err();
    assert!(err.to_string().contains("frame 3 is 4x5"), "{err}");
    let err = writer.push(&srgb_frame(4, 4, vec![0; 47])).unwrap_err();
    assert!(matches!(
        err,
        VideoError::FrameData {
            expected: 48,
            got: 47,
            ..
        }
    ));
    let mut exr = VideoWriter::create(&seq, VideoFormat::ExrSequence, 4, 4, 24.0).unwrap();
    let err = exr.push(&srgb_frame(4, 4, vec![0; 48])).unwrap_err();
    assert!(err.to_string().contains("linear_rgb"), "{err}");
    // Refused frames write nothing, and the sequence appears only on finish.
    assert!(!seq.exists());
    drop((writer, exr));
    assert_eq!(
        fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no temporary folder"
    );
    assert!(matches!(
        VideoWriter::create(&seq, VideoFormat::Gif, 4, 4, 0.0),
        Err(VideoError::BadFrameRate(_))
    ));
    assert!(matches!(
        VideoWriter::create(
            &dir.path().join("no/such/dir/a.gif"),
            VideoFormat::Gif,
            4,
            4,
            24.0
        ),
        Err(VideoError::Folder { .. })
    ));
}

#[test]
fn formats_parse_from_names_and_extensions() {
    assert_eq!(VideoFormat::parse("MP4").unwrap(), VideoFormat::Mp4);
    assert_eq!(VideoFormat::parse(".gif").unwrap(), VideoFormat::Gif);
    assert_eq!(VideoFormat::parse("png").unwrap(), VideoFormat::PngSequence);
    assert_eq!(VideoFormat::parse("exr").unwrap(), VideoFormat::ExrSequence);
    assert!(VideoFormat::parse("avi").is_err());
    assert_eq!(
        VideoFormat::from_path(Path::new("out/clip.mp4"))
            .unwrap()
            .unwrap(),
        VideoFormat::Mp4
    );
    assert!(VideoFormat::from_path(Path::new("out/frames")).is_none());
    assert_eq!(
        sequence_file_name(42, VideoFormat::ExrSequence),
        "frame_00042.exr"
    );
}
