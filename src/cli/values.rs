//! The typed values of the command line, shared by every subcommand (ripgrep's
//! `flags/defs.rs`: each value one unit with its doc, parser and test). Closed sets of names
//! are clap `ValueEnum`s, whose doc comments are the values' help; open values (a size, a
//! frame range, a positive number, a point, a region, a compression level) have one parser
//! each. A refused value gives clap's one-line error naming the flag
//! (`invalid value '64' for '--size <WxH>': ...`, see [`super::clap_error_line`]).
//!
//! Limits that depend on the command (the largest frame of `femto render`, the largest
//! capture of `femto simulate`) are not checked here but by the library stage that knows
//! them ([`femto::pipeline::render::MAX_SIDE`], [`femto::simulate::budget::MAX_SIDE`]).

use clap::builder::{EnumValueParser, PossibleValue, TypedValueParser};
use clap::ValueEnum;
use femto::container::CubeCompression;
use femto::ingest::plan::{PowerRef, SaturationInput};
use femto::manifest::StreakFormat;
use femto::pipeline::render::ViewKind;
use femto::relativity::Radiometry;
use femto::render::Effects;
use femto::video::VideoFormat;
use std::ffi::OsStr;
use std::marker::PhantomData;
use std::ops::Range;
use std::str::FromStr;

/// `WxH` (or `WXH`): an image or frame size in pixels, both sides at least 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Size {
    pub width: usize,
    pub height: usize,
}

impl Size {
    pub fn pair(self) -> (usize, usize) {
        (self.width, self.height)
    }
}

impl FromStr for Size {
    type Err = String;
    fn from_str(text: &str) -> Result<Size, String> {
        let parsed = text.split_once(['x', 'X']).and_then(|(w, h)| {
            Some((
                w.trim().parse::<usize>().ok()?,
                h.trim().parse::<usize>().ok()?,
            ))
        });
        match parsed {
            Some((width, height)) if width > 0 && height > 0 => Ok(Size { width, height }),
            _ => Err("expected WIDTHxHEIGHT with both at least 1, e.g. 640x480".into()),
        }
    }
}

/// `A..B`: frames A to B of a sequence, B excluded, A < B.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameRange(pub Range<usize>);

impl FromStr for FrameRange {
    type Err = String;
    fn from_str(text: &str) -> Result<FrameRange, String> {
        let parsed = text.split_once("..").and_then(|(a, b)| {
            Some(a.trim().parse::<usize>().ok()?..b.trim().parse::<usize>().ok()?)
        });
        match parsed {
            Some(r) if r.start < r.end => Ok(FrameRange(r)),
            _ => Err("expected A..B with A < B, frame B excluded, e.g. 0..50".into()),
        }
    }
}

/// `A..B`: image rows A to B, B excluded (a band of `simulate --rows`).
pub fn row_range(text: &str) -> Result<std::ops::Range<usize>, String> {
    text.parse::<FrameRange>()
        .map(|r| r.0)
        .map_err(|_| "expected A..B with A < B, row B excluded, e.g. 0..100".into())
}

/// A finite number > 0 (a bin width, a spacing).
pub fn positive_finite(text: &str) -> Result<f64, String> {
    let v: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err("must be finite and > 0".into())
    }
}

/// `OFFSET,SIGMA`: two numbers (simulate's dark signal; the library checks their ranges).
pub fn offset_sigma(text: &str) -> Result<(f64, f64), String> {
    let bad = || "expected OFFSET,SIGMA (two numbers)".to_string();
    let (o, sd) = text.split_once(',').ok_or_else(bad)?;
    Ok((
        o.trim().parse().map_err(|_| bad())?,
        sd.trim().parse().map_err(|_| bad())?,
    ))
}

/// `X,Y,Z`: a point in metres, three finite numbers.
pub fn point(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("'{s}' is not X,Y,Z in metres: {e}"))?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("'{s}' is not three finite numbers X,Y,Z")),
    }
}

/// `none` or a deflate level 0-9 (with shuffle).
pub fn compression(s: &str) -> Result<CubeCompression, String> {
    CubeCompression::parse(s)
}

/// `auto` or a level in value units (the library checks its range).
pub fn saturation(s: &str) -> Result<SaturationInput, String> {
    SaturationInput::parse(s)
}

/// `auto` or `x0:x1,t0:t1` (ingest's laser power reference).
pub fn power_ref(s: &str) -> Result<PowerRef, String> {
    PowerRef::parse(s)
}

/// A [`ValueEnum`] parsed after trimming the value's whitespace (and, for
/// [`EnumArg::extension`], a leading dot), so that `--format 'png16, exr'` and
/// `--format .mp4` read as before; case is ignored where the flag sets `ignore_case`.
#[derive(Clone)]
pub struct EnumArg<E> {
    strip_dot: bool,
    kind: PhantomData<fn() -> E>,
}

impl<E> EnumArg<E> {
    pub fn new() -> Self {
        EnumArg {
            strip_dot: false,
            kind: PhantomData,
        }
    }

    /// Also accepts the name with a leading dot (a file extension).
    pub fn extension() -> Self {
        EnumArg {
            strip_dot: true,
            kind: PhantomData,
        }
    }
}

impl<E: ValueEnum + Clone + Send + Sync + 'static> TypedValueParser for EnumArg<E> {
    type Value = E;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<E, clap::Error> {
        let text = value.to_string_lossy();
        let mut name = text.trim();
        if self.strip_dot {
            name = name.trim_start_matches('.');
        }
        EnumValueParser::<E>::new().parse_ref(cmd, arg, OsStr::new(name))
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(
            E::value_variants()
                .iter()
                .filter_map(ValueEnum::to_possible_value),
        ))
    }
}

/// `femto render --radiometry`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RadiometryArg {
    /// Radiance times D^-3, accumulated over the exposure window dtau/D (docs/physics.md).
    Consistent,
    /// Jarabo et al. 2013's D^-5, literally.
    Paper,
}

impl From<RadiometryArg> for Radiometry {
    fn from(r: RadiometryArg) -> Radiometry {
        match r {
            RadiometryArg::Consistent => Radiometry::Consistent,
            RadiometryArg::Paper => Radiometry::Paper,
        }
    }
}

/// `femto render --view`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ViewArg {
    /// Light in flight seen by the moving camera.
    Transient,
    /// Re-projection that keeps the capture's time warp.
    Naive,
    /// Time of first arrival, colour-coded.
    Isochrones,
    /// The time-integrated image.
    Integrated,
}

impl From<ViewArg> for ViewKind {
    fn from(v: ViewArg) -> ViewKind {
        match v {
            ViewArg::Transient => ViewKind::Transient,
            ViewArg::Naive => ViewKind::Naive,
            ViewArg::Isochrones => ViewKind::Isochrones,
            ViewArg::Integrated => ViewKind::Integrated,
        }
    }
}

/// `femto render --format`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum VideoFormatArg {
    /// Frame sequence, 8-bit sRGB PNG files in the folder --out.
    Png,
    /// Frame sequence, 32-bit float linear EXR files in the folder --out.
    Exr,
    /// One H.264 MP4 file.
    Mp4,
    /// One animated GIF file.
    Gif,
}

impl From<VideoFormatArg> for VideoFormat {
    fn from(f: VideoFormatArg) -> VideoFormat {
        match f {
            VideoFormatArg::Png => VideoFormat::PngSequence,
            VideoFormatArg::Exr => VideoFormat::ExrSequence,
            VideoFormatArg::Mp4 => VideoFormat::Mp4,
            VideoFormatArg::Gif => VideoFormat::Gif,
        }
    }
}

/// `femto simulate --format` (one item of the list).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum StreakFormatArg {
    /// 16-bit grey PNG.
    #[value(alias = "png")]
    Png16,
    /// Single-channel f32 OpenEXR.
    Exr,
    /// Hamamatsu HPD-TA .img, 16-bit.
    #[value(alias = "img")]
    Img16,
    /// Hamamatsu HPD-TA .img, 32-bit.
    Img32,
}

impl From<StreakFormatArg> for StreakFormat {
    fn from(f: StreakFormatArg) -> StreakFormat {
        match f {
            StreakFormatArg::Png16 => StreakFormat::Png16,
            StreakFormatArg::Exr => StreakFormat::ExrF32,
            StreakFormatArg::Img16 => StreakFormat::Img16,
            StreakFormatArg::Img32 => StreakFormat::Img32,
        }
    }
}

/// `femto simulate --time-filter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TimeFilterArg {
    /// The laser pulse and the streak sensor's response (femto's cubes).
    Sensor,
    /// A histogram of arrival times (mitransient's box time bins).
    Box,
}

impl From<TimeFilterArg> for femto::tracer::TimeFilter {
    fn from(f: TimeFilterArg) -> femto::tracer::TimeFilter {
        match f {
            TimeFilterArg::Sensor => femto::tracer::TimeFilter::Sensor,
            TimeFilterArg::Box => femto::tracer::TimeFilter::Box,
        }
    }
}

/// One relativistic effect of `femto render --effects` (the list's items; the parser is
/// [`Effects::parse`], and a test keeps the two lists of names equal).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Effect {
    /// Per-view time re-warp t_e = t_receive - eta r / c.
    Unwarp,
    /// Aberration of the camera rays into the world frame.
    Aberration,
    /// Doppler shift of the colour.
    Doppler,
    /// Searchlight: accumulation window dtau/D and radiometric factor.
    Searchlight,
    /// Time dilation of the camera's clock.
    Dilation,
    /// Per-pixel velocity of a rotating sensor.
    Rotation,
}

/// `femto render --effects`: a comma-separated list of [`Effect`]s, or `all`, or `none`.
#[derive(Clone, Copy, Debug, Default)]
pub struct EffectsArg;

impl TypedValueParser for EffectsArg {
    type Value = Effects;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<Effects, clap::Error> {
        let text = value.to_string_lossy();
        Effects::parse(&text).map_err(|e| {
            let flag = arg.map_or_else(|| "--effects".to_string(), ToString::to_string);
            clap::Error::raw(
                clap::error::ErrorKind::ValueValidation,
                format!("invalid value '{text}' for '{flag}': {e}\n"),
            )
            .with_cmd(cmd)
        })
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        let words = [
            PossibleValue::new("all").help("Every effect"),
            PossibleValue::new("none").help("No effect: a classic render of the world-time cube"),
        ];
        Some(Box::new(
            words.into_iter().chain(
                Effect::value_variants()
                    .iter()
                    .filter_map(ValueEnum::to_possible_value),
            ),
        ))
    }
}

/// `femto unwarp --to`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Clock {
    /// World time: when light is at the surface point.
    World,
    /// Camera time: when light reaches the sensor.
    Camera,
}

/// `AXIS=I` of `--select`: an axis (number or name) and the index kept.
pub fn axis_index(s: &str) -> Result<(femto::readers::AxisRef, usize), String> {
    let (axis, index) = s
        .split_once('=')
        .ok_or_else(|| format!("'{s}' is not AXIS=I (frame=0, C=12, 3=1)"))?;
    let index: usize = index
        .trim()
        .parse()
        .map_err(|_| format!("'{s}': the index after '=' must be a whole number >= 0"))?;
    if axis.trim().is_empty() {
        return Err(format!("'{s}': name the axis before '='"));
    }
    Ok((femto::readers::AxisRef::parse(axis), index))
}

/// `AXIS` of `--sum`: an axis number or name.
pub fn axis_ref(s: &str) -> Result<femto::readers::AxisRef, String> {
    if s.trim().is_empty() {
        return Err("name an axis (a number or a name)".into());
    }
    Ok(femto::readers::AxisRef::parse(s))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names<E: ValueEnum>() -> Vec<String> {
        E::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value())
            .map(|p| p.get_name().to_string())
            .collect()
    }

    #[test]
    fn sizes_parse_and_refuse_zero_or_malformed() {
        assert_eq!("640x480".parse::<Size>().unwrap().pair(), (640, 480));
        assert_eq!("64X48".parse::<Size>().unwrap().pair(), (64, 48));
        assert_eq!(" 8 x 6 ".parse::<Size>().unwrap().pair(), (8, 6));
        for bad in ["640", "0x10", "10x0", "ax4", "10x-2", "x", ""] {
            assert!(bad.parse::<Size>().is_err(), "{bad}");
        }
    }

    #[test]
    fn frame_ranges_need_a_before_b() {
        assert_eq!("3..9".parse::<FrameRange>().unwrap().0, 3..9);
        for bad in ["3..3", "9..3", "3-9", "..4", "1.."] {
            assert!(bad.parse::<FrameRange>().is_err(), "{bad}");
        }
    }

    #[test]
    fn positive_numbers_refuse_zero_negative_and_non_finite() {
        assert_eq!(positive_finite("1.71").unwrap(), 1.71);
        for bad in ["0", "-1", "nan", "inf", "-inf", "x"] {
            assert!(positive_finite(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn open_values_parse() {
        assert_eq!(offset_sigma("0.02, 0.004").unwrap(), (0.02, 0.004));
        assert!(offset_sigma("0.1").is_err());
        assert_eq!(point("1, -2,3").unwrap(), [1.0, -2.0, 3.0]);
        assert!(point("0,nan,0").is_err() && point("1,2").is_err());
        assert_eq!(compression("none").unwrap(), CubeCompression::None);
        assert_eq!(compression("4").unwrap(), CubeCompression::Deflate(4));
        assert!(compression("10").is_err());
        assert_eq!(saturation("auto").unwrap(), SaturationInput::Auto);
        assert_eq!(saturation("-5").unwrap(), SaturationInput::Level(-5.0));
        assert!(saturation("high").is_err());
        assert_eq!(power_ref("auto").unwrap(), PowerRef::Auto);
        assert_eq!(
            power_ref("1:5,2:9").unwrap(),
            PowerRef::Region(femto::ingest::corrections::RefRegion {
                x0: 1,
                x1: 5,
                t0_bin: 2,
                t1_bin: 9
            })
        );
        assert!(power_ref("1:5").is_err() && power_ref("1:a,2:3").is_err());
    }

    #[test]
    fn effect_names_are_those_the_library_parses() {
        assert_eq!(names::<Effect>(), Effects::NAMES);
        for name in Effects::NAMES {
            let one = Effects::parse(name).unwrap();
            assert_eq!(one.to_string(), name);
        }
    }

    #[test]
    fn enum_names_map_to_the_library_values() {
        // Each name is the one the library prints (or parses) for the value it maps to.
        for v in ViewArg::value_variants() {
            let name = v.to_possible_value().unwrap().get_name().to_string();
            let kind: ViewKind = (*v).into();
            assert_eq!(format!("{kind:?}").to_lowercase(), name);
        }
        for f in VideoFormatArg::value_variants() {
            let name = f.to_possible_value().unwrap().get_name().to_string();
            assert_eq!(VideoFormat::parse(&name).unwrap(), VideoFormat::from(*f));
        }
        for f in StreakFormatArg::value_variants() {
            let name = f.to_possible_value().unwrap().get_name().to_string();
            let json = serde_json::to_string(&StreakFormat::from(*f)).unwrap();
            assert_eq!(json, format!("\"{name}\""));
        }
        assert_eq!(names::<RadiometryArg>(), ["consistent", "paper"]);
        assert_eq!(
            Radiometry::from(RadiometryArg::Consistent),
            Radiometry::default()
        );
    }

    #[test]
    fn enum_values_are_trimmed_and_may_carry_a_dot() {
        let cmd = clap::Command::new("t");
        let arg = clap::Arg::new("format").ignore_case(true);
        let parse = |p: &EnumArg<VideoFormatArg>, s: &str| {
            p.parse_ref(&cmd, Some(&arg), OsStr::new(s)).ok()
        };
        let ext = EnumArg::<VideoFormatArg>::extension();
        assert_eq!(parse(&ext, ".MP4"), Some(VideoFormatArg::Mp4));
        assert_eq!(parse(&ext, " gif"), Some(VideoFormatArg::Gif));
        assert_eq!(parse(&EnumArg::new(), ".mp4"), None);
        assert_eq!(parse(&ext, "avi"), None);
        let streak = EnumArg::<StreakFormatArg>::new()
            .parse_ref(&cmd, Some(&arg), OsStr::new(" PNG "))
            .unwrap();
        assert_eq!(streak, StreakFormatArg::Png16);
    }

    #[test]
    fn effects_parse_through_the_library_and_refusals_name_the_flag() {
        let cmd = || {
            clap::Command::new("t").arg(
                clap::Arg::new("effects")
                    .long("effects")
                    .value_name("LIST")
                    .value_parser(EffectsArg),
            )
        };
        let m = cmd()
            .try_get_matches_from(["t", "--effects", "doppler, searchlight"])
            .unwrap();
        let e = *m.get_one::<Effects>("effects").unwrap();
        assert!(e.doppler && e.searchlight && !e.unwarp);
        let err = cmd()
            .try_get_matches_from(["t", "--effects", "doppler,warp"])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("'--effects <LIST>'") && err.contains("'warp'"),
            "{err}"
        );
        let listed: Vec<String> = EffectsArg
            .possible_values()
            .unwrap()
            .map(|p| p.get_name().to_string())
            .collect();
        assert_eq!(listed.len(), 2 + Effects::NAMES.len());
    }

    #[test]
    fn select_takes_an_axis_and_an_index() {
        use femto::readers::AxisRef;
        assert_eq!(
            axis_index("frame=2"),
            Ok((AxisRef::Name("frame".into()), 2))
        );
        assert_eq!(axis_index("3=0"), Ok((AxisRef::Index(3), 0)));
        assert!(axis_index("C").is_err());
        assert!(axis_index("C=-1").is_err());
        assert!(axis_index("=1").is_err());
        assert_eq!(axis_ref("0"), Ok(AxisRef::Index(0)));
    }
}
