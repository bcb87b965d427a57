//! Where a PNG frame sits in the sequence its render planned: `frame K of N`, in a PNG text
//! chunk ([`PLACE_KEYWORD`]) of every frame a sequence writer writes. `femto encode` reads it
//! to refuse a set of part folders that holds fewer frames than the render planned (a part
//! left out, or its job still running), which would otherwise make a shorter video.

use super::VideoError;
use std::io::{BufReader, Write};
use std::path::Path;

/// The PNG `tEXt` keyword of a frame's place.
pub const PLACE_KEYWORD: &str = "femto-frame";

/// Frame `index` of a sequence of `frames` frames (numbered from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SequencePlace {
    pub index: usize,
    pub frames: usize,
}

impl SequencePlace {
    /// The chunk's text: `frame K of N`.
    pub fn text(self) -> String {
        format!("frame {} of {}", self.index, self.frames)
    }

    /// The place a chunk's text names, if it is one.
    pub fn parse(text: &str) -> Option<SequencePlace> {
        let (index, frames) = text.strip_prefix("frame ")?.split_once(" of ")?;
        let place = SequencePlace {
            index: index.parse().ok()?,
            frames: frames.parse().ok()?,
        };
        (place.index < place.frames).then_some(place)
    }
}

/// Encode an 8-bit sRGB frame as PNG into `out` (the image crate's settings: fast deflate,
/// adaptive filters), with its `place` as a text chunk when given.
pub fn encode_png(
    srgb8: &[u8],
    width: usize,
    height: usize,
    place: Option<SequencePlace>,
    out: &mut impl Write,
) -> Result<(), png::EncodingError> {
    let mut encoder = png::Encoder::new(out, width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_compression(png::Compression::Fast);
    encoder.set_filter(png::Filter::Adaptive);
    if let Some(place) = place {
        encoder.add_text_chunk(PLACE_KEYWORD.into(), place.text())?;
    }
    encoder.write_header()?.write_image_data(srgb8)
}

/// The place recorded in the PNG file `path`, or None when it records none (a frame of
/// another tool, or of a femto before frames recorded their place).
pub fn read_place(path: &Path) -> Result<Option<SequencePlace>, VideoError> {
    let file = std::fs::File::open(path).map_err(|source| VideoError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let reader = png::Decoder::new(BufReader::new(file))
        .read_info()
        .map_err(|e| VideoError::Image {
            path: path.to_path_buf(),
            source: image::ImageError::IoError(std::io::Error::other(e)),
        })?;
    Ok(reader
        .info()
        .uncompressed_latin1_text
        .iter()
        .find(|t| t.keyword == PLACE_KEYWORD)
        .and_then(|t| SequencePlace::parse(&t.text)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_records_its_place_and_reads_back_as_the_same_pixels() {
        let dir = tempfile::tempdir().unwrap();
        let pixels: Vec<u8> = (0..4 * 3 * 3).map(|i| (i * 7) as u8).collect();
        let path = dir.path().join("frame_00002.png");
        let place = SequencePlace {
            index: 2,
            frames: 5,
        };
        let mut bytes = Vec::new();
        encode_png(&pixels, 4, 3, Some(place), &mut bytes).unwrap();
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(read_place(&path).unwrap(), Some(place));
        assert_eq!(image::open(&path).unwrap().to_rgb8().into_raw(), pixels);
        let mut plain = Vec::new();
        encode_png(&pixels, 4, 3, None, &mut plain).unwrap();
        std::fs::write(&path, &plain).unwrap();
        assert_eq!(read_place(&path).unwrap(), None);
        assert_eq!(SequencePlace::parse("frame 5 of 5"), None);
        assert_eq!(SequencePlace::parse("frame 1 of"), None);
    }
}
