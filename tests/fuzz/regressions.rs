//! The fuzzers' findings in the readers, each kept as a hand-made reproducer: the input that
//! broke the reader, and what the reader must do with it now.

use super::seeds::{file, scanlines};
use super::{alloc_bound, with_peak};
use std::path::Path;

fn write(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// HPD-TA `num_images` of -2^31 was accepted as a single image (issue 16).
#[test]
fn img_negative_image_count_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let seed = scanlines("img", 1).remove(0);
    assert_eq!(
        &seed[14..18],
        &0i32.to_le_bytes(),
        "the writer stores 0 images"
    );
    let mut bytes = seed.clone();
    bytes[14..18].copy_from_slice(&i32::MIN.to_le_bytes());
    let p = write(dir.path(), "neg.img", &bytes);
    let e = femto::formats::read_streak(&p, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("number of images") && e.contains("-2147483648"),
        "{e}"
    );
    assert!(e.contains("neg.img"), "{e}");
    // 1 (one image) still reads, like 0.
    bytes[14..18].copy_from_slice(&1i32.to_le_bytes());
    let p = write(dir.path(), "one.img", &bytes);
    femto::formats::read_streak(&p, false).unwrap();
}

/// An infinite value in an HPD-TA time table gave a time axis ending at +inf.
#[test]
fn img_infinite_time_table_value_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = scanlines("img", 1).remove(0);
    let good = femto::formats::read_streak(&write(dir.path(), "good.img", &bytes), false).unwrap();
    assert!(
        good.time_axis_ps.is_some(),
        "the writer stores a time table"
    );
    // The writer puts the float32 table last: its last entry is the last row's time.
    let n = bytes.len();
    bytes[n - 4..].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let p = write(dir.path(), "inf.img", &bytes);
    let e = femto::formats::read_streak(&p, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("ScalingYScalingFile") && e.contains("inf"),
        "{e}"
    );
}

fn glb_with_length(declared: u32) -> Vec<u8> {
    let mut bytes = file("cap/scene.glb");
    bytes[8..12].copy_from_slice(&declared.to_le_bytes());
    bytes
}

/// A 2 kB glb whose header claims 0xFFFFFFF0 bytes made the loader allocate 4 GB (issue 16);
/// a length below the 12-byte header underflowed in the glTF crate.
#[test]
fn glb_header_length_is_checked_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    for declared in [0xFFFF_FFF0, 4, 0] {
        let bytes = glb_with_length(declared);
        let p = write(dir.path(), "big.glb", &bytes);
        let (result, peak) = with_peak(|| femto::geometry::load::load_mesh(&p));
        let e = result.unwrap_err().to_string();
        assert!(
            e.contains(&format!("declares {declared} bytes")) && e.contains("big.glb"),
            "{e}"
        );
        assert!(
            peak <= alloc_bound(bytes.len()),
            "{peak} bytes for {declared}"
        );
    }
    // The true length reads.
    let good = file("cap/scene.glb");
    let p = write(dir.path(), "good.glb", &good);
    assert!(
        femto::geometry::load::load_mesh(&p)
            .unwrap()
            .triangle_count()
            > 0
    );
}

fn gltf_with_uri(uri: &str) -> Vec<u8> {
    let text = String::from_utf8(super::seeds::gltf_from_glb(&file("cap/scene.glb"))).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    doc["buffers"][0]["uri"] = serde_json::Value::String(uri.into());
    serde_json::to_vec(&doc).unwrap()
}

/// A buffer URI whose percent-decoding is not UTF-8 panicked in the glTF importer
/// (`urlencoding::decode(uri).unwrap()`); one naming a device read without end.
#[test]
fn gltf_buffer_uris_that_cannot_be_read_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "bad.gltf", &gltf_with_uri("mesh%FF.bin"));
    let e = femto::geometry::load::load_mesh(&p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not UTF-8") && e.contains("bad.gltf"), "{e}");
    let p = write(dir.path(), "dev.gltf", &gltf_with_uri("file:///dev/zero"));
    let e = femto::geometry::load::load_mesh(&p)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("not a regular file") && e.contains("dev.gltf"),
        "{e}"
    );
    // The data URI the seed carries reads.
    let p = write(
        dir.path(),
        "good.gltf",
        &super::seeds::gltf_from_glb(&file("cap/scene.glb")),
    );
    assert!(
        femto::geometry::load::load_mesh(&p)
            .unwrap()
            .triangle_count()
            > 0
    );
}

fn gltf_edited(edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let seed = super::seeds::gltf_from_glb(&file("cap/scene.glb"));
    let mut doc: serde_json::Value = serde_json::from_slice(&seed).unwrap();
    edit(&mut doc);
    serde_json::to_vec(&doc).unwrap()
}

/// Accessor and buffer-view spans the glTF crate computes unchecked (overflow panics in the
/// `gltf` target's first 1,000 cases), sparse spans likewise, an index accessor of floats
/// (`unreachable!()` in the crate), a `POSITION` accessor that is not `VEC3` of f32 or a
/// stride below the element size (assertions in the crate, seed 18), and a `POSITION` index
/// past the accessor list (index out of bounds in `gltf-json`'s validation): each is refused
/// with one line.
#[test]
fn gltf_accessors_are_checked_before_the_crate_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: [(&str, Edit); 10] = [
        (
            "leaves its",
            Box::new(|d| d["bufferViews"][0]["byteLength"] = u64::MAX.into()),
        ),
        (
            "do not fit",
            Box::new(|d| d["accessors"][0]["count"] = (1u64 << 62).into()),
        ),
        (
            "count is 0",
            Box::new(|d| d["accessors"][0]["count"] = 0.into()),
        ),
        (
            "(SCALAR of u8, u16 or u32)",
            Box::new(|d| d["accessors"][1]["componentType"] = 5126.into()),
        ),
        (
            "(SCALAR of u8, u16 or u32)",
            Box::new(|d| {
                d["accessors"][1]["type"] = "VEC2".into();
                d["accessors"][1]["componentType"] = 5121.into();
            }),
        ),
        // The `gltf` target's case 8508 of seed 18 (an assertion in the crate: 12 != 8).
        (
            "POSITION accessor 0 holds Vec2 of F32 (VEC3 of f32)",
            Box::new(|d| d["accessors"][0]["type"] = "VEC2".into()),
        ),
        (
            "POSITION accessor 0 holds Vec3 of U16 (VEC3 of f32)",
            Box::new(|d| d["accessors"][0]["componentType"] = 5123.into()),
        ),
        (
            "a stride of 4 bytes, less than its 12-byte elements",
            Box::new(|d| d["bufferViews"][0]["byteStride"] = 4.into()),
        ),
        (
            "sparse indices: 4611686018427387904 elements",
            Box::new(|d| {
                d["accessors"][0]["sparse"] = serde_json::json!({
                    "count": 1u64 << 62,
                    "indices": {"bufferView": 1, "componentType": 5125},
                    "values": {"bufferView": 0}
                })
            }),
        ),
        (
            "does not exist",
            Box::new(|d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 999.into()),
        ),
    ];
    for (want, edit) in cases {
        let p = write(dir.path(), "bad.gltf", &gltf_edited(edit));
        let e = femto::geometry::load::load_mesh(&p)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(want) && e.contains("bad.gltf") && !e.contains('\n'),
            "{want}: {e}"
        );
    }
}

/// Face indices that `tobj` turns into a huge `usize` and multiplies unchecked (overflow in
/// the dev profile): a texture index of -2^63 (the `obj` target's case 97 of seed 16), a
/// relative index reaching before the first texture coordinate or normal (cases 2915 and
/// 17585 of seed 18), index 0, and a huge index on a line before one that is not UTF-8
/// (case 34469 of seed 18, which the check had left to `tobj`).
#[test]
fn obj_face_indices_that_overflow_in_tobj_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let huge = "f 5/1/9223372036854775807 6/1/1 7/1/1\nv -1\u{0}\u{0}";
    let cases: [(&str, String, &str); 5] = [
        ("f 5/1/1", "f 5/-9223372036854775808/1".into(), "line 17: index -9223372036854775808: it reaches before the first of the 1 texture coordinates"),
        ("f 5/1/1", "f 5/1/-3".into(), "line 17: index -3: it reaches before the first of the 1 normals declared so far"),
        ("f 5/1/1", "f 5/-2/1".into(), "index -2: it reaches before"),
        ("f 5/1/1", "f 5/0/1".into(), "index 0: OBJ counts from 1"),
        ("f 5/1/1 6/1/1 7/1/1 8/1/1", huge.into(), "index 9223372036854775807: it is beyond the file's"),
    ];
    for (from, to, want) in cases {
        let mut bytes = super::seeds::OBJ.replacen(from, &to, 1).into_bytes();
        if to.contains('\u{0}') {
            bytes.extend_from_slice(b"\xff\xfe 0 0\n"); // a later line that is not UTF-8
        }
        let p = write(dir.path(), "bad.obj", &bytes);
        let e = femto::geometry::load::load_mesh(&p)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want) && e.contains("bad.obj"), "{want}: {e}");
    }
    // A relative index within what is declared still reads (the seed ends with `f -1 -2 -3`).
    let p = write(dir.path(), "good.obj", super::seeds::OBJ.as_bytes());
    femto::geometry::load::load_mesh(&p).unwrap();
}

/// A simulated EXR scanline with its `dataWindow` widened to `x_max` (the attribute is
/// `name\0box2i\0`, a 4-byte size of 16, then xMin, yMin, xMax, yMax as i32).
fn exr_with_x_max(x_max: i32) -> Vec<u8> {
    let mut bytes = scanlines("exr", 1).remove(0);
    let key = b"dataWindow\0box2i\0";
    let at = bytes
        .windows(key.len())
        .position(|w| w == key)
        .expect("a dataWindow attribute")
        + key.len()
        + 4
        + 8;
    bytes[at..at + 4].copy_from_slice(&x_max.to_le_bytes());
    bytes
}

#[test]
fn exr_data_window_is_checked_before_allocating() {
    // Seed 18, case 20673 of the `exr` target asked 4.3 GB for a 6.5 kB file.
    let dir = tempfile::tempdir().unwrap();
    let bytes = exr_with_x_max(16_777_193);
    let p = write(dir.path(), "wide.exr", &bytes);
    let (result, peak) = with_peak(|| femto::formats::read_streak(&p, false));
    let e = result.unwrap_err().to_string();
    assert!(e.contains("wide.exr") && e.contains("data window"), "{e}");
    assert!(peak <= alloc_bound(bytes.len()), "{peak} bytes");
    // The seed itself reads.
    let good = write(dir.path(), "good.exr", &scanlines("exr", 1).remove(0));
    assert!(femto::formats::read_streak(&good, false).is_ok());
}

/// The first (16-bit) TIFF seed with the entry of `tag` in its first directory rewritten:
/// `count` values, and `inline` as its (first) inline value.
fn tiff_with_entry(tag: u16, count: u32, inline: u32) -> Vec<u8> {
    tiff_with_entry_of(super::seeds::tiffs().remove(0), tag, count, inline)
}

/// [`tiff_with_entry`] on the TIFF `bytes`.
fn tiff_with_entry_of(mut bytes: Vec<u8>, tag: u16, count: u32, inline: u32) -> Vec<u8> {
    assert_eq!(
        &bytes[..4],
        b"II*\0",
        "the seed is a little-endian classic TIFF"
    );
    let u32_at = |b: &[u8], at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let dir = u32_at(&bytes, 4) as usize;
    let n = u16::from_le_bytes([bytes[dir], bytes[dir + 1]]) as usize;
    let at = (0..n)
        .map(|i| dir + 2 + 12 * i)
        .find(|&at| u16::from_le_bytes([bytes[at], bytes[at + 1]]) == tag)
        .expect("the seed has the tag");
    bytes[at + 4..at + 8].copy_from_slice(&count.to_le_bytes());
    let value_bytes = match u16::from_le_bytes([bytes[at + 2], bytes[at + 3]]) {
        3 => 2,
        _ => 4,
    };
    bytes[at + 8..at + 12].fill(0);
    bytes[at + 8..at + 8 + value_bytes].copy_from_slice(&inline.to_le_bytes()[..value_bytes]);
    bytes
}

/// A 3 kB TIFF whose `SamplesPerPixel` claimed 8,323,073 shorts made the `tiff` crate
/// allocate 266 MB, and one whose strip claimed 100 MB made it allocate that (the `tiff`
/// target's cases 45, 14166, 16977, 36074, 36730 and 38172 of seed 18); an image of
/// 100000 x 100000 pixels in a small file is refused before it is decoded.
#[test]
fn tiff_sizes_are_checked_before_the_crate_allocates_them() {
    let dir = tempfile::tempdir().unwrap();
    let seed = super::seeds::tiffs().remove(0);
    let cases = [
        (
            tiff_with_entry(277, 8_323_073, 1),
            "TIFF tag 277 claims 8323073 values",
        ),
        (
            tiff_with_entry(279, 1, 100_000_000),
            "a strip or tile that claims more bytes",
        ),
        (
            // One strip of 60000 rows, so that the directory is consistent.
            [(257, 60_000), (278, 60_000)]
                .into_iter()
                .fold(tiff_with_entry(256, 1, 60_000), |b, (tag, v)| {
                    tiff_with_entry_of(b, tag, 1, v)
                }),
            "an image of 60000 x 60000 pixels",
        ),
    ];
    for (bytes, want) in cases {
        let p = write(dir.path(), "bad.tif", &bytes);
        let (result, peak) = with_peak(|| femto::formats::read_streak(&p, false));
        let e = result.unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("bad.tif"), "{want}: {e}");
        assert!(
            peak <= alloc_bound(bytes.len()),
            "{want}: asked for {peak} bytes"
        );
    }
    // The unedited seed still reads.
    let p = write(dir.path(), "good.tif", &seed);
    femto::formats::read_streak(&p, false).unwrap();
}
