//! Valid inputs for the fuzzers, written by femto itself, built once per run: a tiny
//! simulated capture in three scanline formats (`femto simulate --realistic --format
//! png16,exr,img32`, and a 16-bit `.img` from the library's writer), its ingested, calibrated cube, the unwarped cube with its pyramid,
//! plus files from the library's writers (glb, a glTF with an embedded buffer, an OBJ, TIFF
//! and HDR scanlines) and the examples under `examples/paths` and `examples/points`.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pub struct Seeds {
    _dir: tempfile::TempDir,
    pub root: PathBuf,
}

use super::cli::{arg, femto_ok as femto};

/// The seed folder, built on first use.
pub fn seeds() -> &'static Seeds {
    static SEEDS: OnceLock<Seeds> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let root = dir.path().to_path_buf();
        let cap = root.join("cap");
        femto(&[
            "simulate",
            "--scene",
            "cube",
            "--size",
            "24x16",
            "--nt",
            "64",
            "--spp",
            "4",
            "--realistic",
            "--format",
            "png16,exr,img32",
            "--out",
            arg(&cap),
        ]);
        super::cli::chain_after_capture(&root, &cap);
        Seeds { _dir: dir, root }
    })
}

/// The bytes of a seed file (relative to the seed folder).
pub fn file(name: &str) -> Vec<u8> {
    let path = seeds().root.join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The bytes of a file of this repository (relative to its root).
pub fn repo_file(name: &str) -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every scanline of the capture with extension `ext`, up to `n`, in name order.
pub fn scanlines(ext: &str, n: usize) -> Vec<Vec<u8>> {
    let mut paths: Vec<PathBuf> = walk(&seeds().root.join("cap"))
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    paths.sort();
    let step = (paths.len() / n.max(1)).max(1);
    paths
        .iter()
        .step_by(step)
        .take(n)
        .map(|p| std::fs::read(p).unwrap())
        .collect()
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

/// The streak image of the first PNG scanline, for the writers of other formats.
fn first_streak() -> femto::formats::StreakImage {
    let mut pngs: Vec<PathBuf> = walk(&seeds().root.join("cap"))
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    pngs.sort();
    femto::formats::read_streak(&pngs[0], false).unwrap()
}

/// A 16-bit HPD-TA scanline (the capture's are 32-bit), by the library's writer.
pub fn img16() -> Vec<u8> {
    let img = first_streak();
    let dt_ps = 2.0;
    let times: Vec<f64> = (0..img.nt).map(|i| 100.0 + i as f64 * dt_ps).collect();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.img");
    femto::formats::hamamatsu::write_img(&p, &img, 16, &times).unwrap();
    std::fs::read(p).unwrap()
}

/// 16-bit grey and 32-bit float TIFF scanlines (the `image` crate's encoder).
pub fn tiffs() -> Vec<Vec<u8>> {
    let img = first_streak();
    let (w, h) = (img.nx as u32, img.nt as u32);
    let u16s: Vec<u16> = img.data.iter().map(|&v| v.min(65535.0) as u16).collect();
    let a = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, u16s).unwrap();
    let rgb: Vec<f32> = img.data.iter().flat_map(|&v| [v, v, v]).collect();
    let b = image::ImageBuffer::<image::Rgb<f32>, _>::from_raw(w, h, rgb).unwrap();
    [
        image::DynamicImage::ImageLuma16(a),
        image::DynamicImage::ImageRgb32F(b),
    ]
    .into_iter()
    .map(|d| {
        let mut out = std::io::Cursor::new(Vec::new());
        d.write_to(&mut out, image::ImageFormat::Tiff).unwrap();
        out.into_inner()
    })
    .collect()
}

/// A Radiance HDR scanline.
pub fn hdr() -> Vec<u8> {
    let img = first_streak();
    let pixels: Vec<image::Rgb<f32>> = img.data.iter().map(|&v| image::Rgb([v; 3])).collect();
    let mut out = Vec::new();
    image::codecs::hdr::HdrEncoder::new(&mut out)
        .encode(&pixels, img.nx, img.nt)
        .unwrap();
    out
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A `.gltf` holding the scene's glb document with its BIN chunk as a data URI.
pub fn gltf_from_glb(glb: &[u8]) -> Vec<u8> {
    let u32_at = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let json = &glb[20..20 + json_len];
    let bin_at = 20 + json_len;
    let bin = &glb[bin_at + 8..bin_at + 8 + u32_at(bin_at)];
    let mut doc: serde_json::Value = serde_json::from_slice(json).unwrap();
    doc["buffers"][0]["uri"] = serde_json::Value::String(format!(
        "data:application/octet-stream;base64,{}",
        base64(bin)
    ));
    serde_json::to_vec_pretty(&doc).unwrap()
}

/// A small OBJ: a box with two materials and a quad face.
pub const OBJ: &str = "# box\nmtllib none.mtl\no box\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
vn 0 0 -1\nvt 0.5 0.5\n\
usemtl a\nf 1 2 3\nf 1 3 4\nf 5/1/1 6/1/1 7/1/1 8/1/1\n\
usemtl b\nf 1 2 6\nf 1 6 5\nf -1 -2 -3\n";

#[test]
fn base64_matches_the_rfc_examples() {
    assert_eq!(base64(b"foob"), "Zm9vYg==");
    assert_eq!(base64(b"fooba"), "Zm9vYmE=");
    assert_eq!(base64(b"foobar"), "Zm9vYmFy");
}
