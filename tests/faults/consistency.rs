//! Fault cases: inconsistent checks (issue 16). A capture whose scanlines are stored at
//! different bit depths, NaN or infinity inside an HDF5 cube or pyramid, clap's parse errors
//! (one line, like every other error), and messages that must name the file or flag at
//! fault. Each bad input is written by hand here from a copy of the fixture's files.

use super::{case, cli};
use cli::refused_unchanged;
use std::path::Path;

// ---------------------------------------------------------------------------------------------
// Mixed bit depths.

/// The capture's scanline files, sorted (PNG16 in the fixture).
fn scanlines(cap: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(cap.join("scanlines"))
        .expect("the capture's scanlines folder")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    files.sort();
    assert!(files.len() > 3, "{files:?}");
    files
}

/// Rewrite a 16-bit grey PNG as the 8-bit PNG a user would get from a converter that keeps
/// the top byte.
fn to_png8(path: &Path) {
    let img = image::open(path).unwrap().into_luma16();
    let img8 = image::GrayImage::from_fn(img.width(), img.height(), |x, y| {
        image::Luma([(img.get_pixel(x, y)[0] >> 8) as u8])
    });
    img8.save(path).unwrap();
    let back = image::open(path).unwrap();
    assert_eq!(back.color(), image::ColorType::L8);
}

/// An 8-bit PNG among the 16-bit scanlines (read through the general reader) is refused,
/// naming the file, its depth and the capture's; so is the converse, an 8-bit first
/// scanline followed by 16-bit ones (read through ingest's 16-bit fast path). Before,
/// both were ingested with exit 0, the 8-bit rows 256 times too dim.
#[test]
fn a_scanline_of_another_bit_depth_is_refused() {
    for which in [2usize, 0] {
        let dir = case(&["cap"]);
        let files = scanlines(&dir.path().join("cap"));
        let odd = &files[which];
        to_png8(odd);
        let name = odd.file_name().unwrap().to_str().unwrap();
        let (found, capture) = if which == 0 {
            ("16-bit integer", "8-bit integer")
        } else {
            ("8-bit integer", "16-bit integer")
        };
        let culprit = if which == 0 {
            files[1].file_name().unwrap().to_str().unwrap()
        } else {
            name
        };
        let err = refused_unchanged(
            dir.path(),
            &["ingest", "cap", "-o", "cube.h5"],
            &[],
            &[culprit, found, capture],
        );
        assert!(err.contains(&format!("{found} samples, but the capture's are {capture}")));
    }
}
