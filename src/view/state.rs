//! The viewer's camera state: what the page sends for every frame, as JSON, and the
//! one-frame camera path and render options that `femto render` would take for it.
//!
//! A state is one instant of a camera (seed Sec. 4): where it is, how it is turned, its
//! velocity, the world time at which it receives the frame's light, and how the frame is
//! rendered. [`ViewState::path_file`] writes it as a camera path of one keyframe (with the
//! state's `beta`: uniform motion, docs/camera-path.md) and one frame at that keyframe's
//! time, so that its frame is exactly the state; the still of a state is rendered from that
//! path's TOML text, read back exactly as `femto render --path` reads the file.

use crate::camera_path::{
    CameraPath, CameraPathFile, Clock, KeyframeFile, RotationFile, MAX_COORD_M,
};
use crate::pipeline::render::{RenderOptions, ViewKind};
use crate::relativity::{Radiometry, RotationAxis};
use crate::render::Effects;
use crate::video::VideoFormat;
use serde::{Deserialize, Serialize};

/// Largest frame side a state may ask for, pixels.
pub const MAX_VIEW_SIDE: usize = 4096;

/// A camera state of the viewer (the JSON of the HTTP API, docs/view.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewState {
    /// Camera centre, world metres.
    pub position_m: [f64; 3],
    /// Camera-to-world rotation as rows: its columns are the camera's x (right), y (down)
    /// and z (forward) axes in world axes (as in camera paths and calibrations).
    pub world_from_camera: [[f64; 3]; 3],
    /// Vertical field of view, degrees.
    pub vfov_deg: f64,
    /// Camera velocity over c, world axes; `|beta| < 1`.
    pub beta: [f64; 3],
    /// World time at which the camera receives the frame's light, ps after the pulse leaves
    /// the laser spot.
    pub t_world_ps: f64,
    /// Frame interval and exposure window, ps of the camera's proper time.
    pub dtau_ps: f64,
    /// Frame size, pixels.
    pub width: usize,
    pub height: usize,
    /// A rotating sensor (seed Sec. 4.3), or none.
    #[serde(default)]
    pub rotation: Option<SensorSpin>,
    /// The six effects, each on or off (`femto render --effects`).
    pub effects: Effects,
    pub view: ViewName,
    pub radiometry: Radiometry,
    /// Multiplier of the automatic exposure.
    pub exposure: f64,
    /// Laser wavelength in its rest frame, nm.
    pub laser_nm: f64,
    /// Draw the unseen and masked dark pixels apart (`femto render --dark-marks`,
    /// [`crate::render::dark`]); absent: off, as `femto render` without the flag.
    #[serde(default)]
    pub dark_marks: bool,
    /// Draw the light in false colour relative to the laser (`femto render --false-colour`,
    /// [`crate::render::ColourOutput::FalseColour`]); absent: off.
    #[serde(default)]
    pub false_colour: bool,
}

/// A rotating sensor: its axis and the speed over c of its farthest point from the axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpin {
    pub axis: RotationAxis,
    pub beta_edge: f64,
}

/// What a frame shows (`femto render --view`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ViewName {
    Transient,
    Naive,
    Isochrones,
    Integrated,
}

impl From<ViewName> for ViewKind {
    fn from(v: ViewName) -> ViewKind {
        match v {
            ViewName::Transient => ViewKind::Transient,
            ViewName::Naive => ViewKind::Naive,
            ViewName::Isochrones => ViewKind::Isochrones,
            ViewName::Integrated => ViewKind::Integrated,
        }
    }
}

impl ViewName {
    pub fn as_str(self) -> &'static str {
        match self {
            ViewName::Transient => "transient",
            ViewName::Naive => "naive",
            ViewName::Isochrones => "isochrones",
            ViewName::Integrated => "integrated",
        }
    }
}

/// A state the viewer refuses, with the field and the reason (the HTTP API's 400).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct BadState {
    pub field: String,
    pub message: String,
}

pub(super) fn bad(field: &str, message: String) -> BadState {
    BadState {
        field: field.to_string(),
        message,
    }
}

/// Default JPEG quality of interactive frames.
pub const DEFAULT_JPEG_QUALITY: i64 = 85;

/// The size and JPEG quality of an interactive frame: the query of `/api/frame` and the
/// fields of a frame request on the WebSocket, checked by one function for both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameOptions {
    /// Fraction of the state's size, in (0, 1].
    pub scale: f64,
    /// JPEG quality, 1 to 100 (wider than `u8` so that every number a client may send is
    /// refused with the same words).
    pub quality: i64,
}

impl Default for FrameOptions {
    fn default() -> Self {
        FrameOptions {
            scale: 1.0,
            quality: DEFAULT_JPEG_QUALITY,
        }
    }
}

impl FrameOptions {
    /// The range checks of the HTTP API and the WebSocket: `scale` in (0, 1], `quality`
    /// from 1 to 100.
    pub fn check(&self) -> Result<(), BadState> {
        if !(self.scale.is_finite() && self.scale > 0.0 && self.scale <= 1.0) {
            return Err(bad(
                "scale",
                format!("{}: must be a number in (0, 1]", self.scale),
            ));
        }
        if !(1..=100).contains(&self.quality) {
            return Err(bad(
                "quality",
                format!("{}: must be an integer from 1 to 100", self.quality),
            ));
        }
        Ok(())
    }
}

/// Largest world time a state may name, ps (a hundred seconds: far beyond any capture).
const MAX_TIME_PS: f64 = 1e14;

impl ViewState {
    /// Parse a state from JSON, refusing unknown fields, missing fields and values out of
    /// range with a one-line reason.
    pub fn from_json(text: &[u8]) -> Result<ViewState, BadState> {
        let state: ViewState =
            serde_json::from_slice(text).map_err(|e| bad("state", e.to_string()))?;
        state.check()?;
        Ok(state)
    }

    /// Check every number (the path and render checks repeat some, naming the path).
    pub fn check(&self) -> Result<(), BadState> {
        for (i, x) in self.position_m.iter().enumerate() {
            if !(x.is_finite() && x.abs() <= MAX_COORD_M) {
                return Err(bad(
                    &format!("position_m[{i}]"),
                    format!("{x}: must be a finite coordinate of at most {MAX_COORD_M} m"),
                ));
            }
        }
        for (i, row) in self.world_from_camera.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                if !x.is_finite() {
                    return Err(bad(
                        &format!("world_from_camera[{i}][{j}]"),
                        format!("{x}: must be finite"),
                    ));
                }
            }
        }
        if !(self.vfov_deg.is_finite() && self.vfov_deg > 0.0 && self.vfov_deg < 180.0) {
            return Err(bad(
                "vfov_deg",
                format!("{}: must be between 0 and 180 degrees", self.vfov_deg),
            ));
        }
        let speed = self.beta.iter().map(|b| b * b).sum::<f64>().sqrt();
        if !(speed.is_finite() && speed < 1.0) {
            return Err(bad(
                "beta",
                format!("|beta| = {speed}: the camera must move slower than light (|beta| < 1)"),
            ));
        }
        if !(self.t_world_ps.is_finite() && self.t_world_ps.abs() <= MAX_TIME_PS) {
            return Err(bad(
                "t_world_ps",
                format!(
                    "{}: must be a finite time of at most {MAX_TIME_PS} ps",
                    self.t_world_ps
                ),
            ));
        }
        if !(self.dtau_ps.is_finite() && self.dtau_ps > 0.0 && self.dtau_ps <= MAX_TIME_PS) {
            return Err(bad(
                "dtau_ps",
                format!("{}: must be a positive number of picoseconds", self.dtau_ps),
            ));
        }
        for (name, side) in [("width", self.width), ("height", self.height)] {
            if side == 0 || side > MAX_VIEW_SIDE {
                return Err(bad(
                    name,
                    format!("{side}: must be between 1 and {MAX_VIEW_SIDE} pixels"),
                ));
            }
        }
        if let Some(spin) = self.rotation {
            if !(spin.beta_edge.is_finite() && spin.beta_edge.abs() < 1.0) {
                return Err(bad(
                    "rotation.beta_edge",
                    format!(
                        "{}: the sensor edge must move slower than light",
                        spin.beta_edge
                    ),
                ));
            }
        }
        if !(self.exposure.is_finite() && self.exposure > 0.0 && self.exposure <= 1e12) {
            return Err(bad(
                "exposure",
                format!("{}: must be a positive number", self.exposure),
            ));
        }
        if !(self.laser_nm.is_finite() && self.laser_nm > 0.0 && self.laser_nm <= 1e6) {
            return Err(bad(
                "laser_nm",
                format!(
                    "{}: must be a wavelength in nm above 0 and at most 1e6 (1 mm)",
                    self.laser_nm
                ),
            ));
        }
        Ok(())
    }

    /// The same state at another frame size (the interactive frames' reduced resolution).
    pub fn scaled(&self, scale: f64) -> ViewState {
        let side = |s: usize| ((s as f64 * scale).round() as usize).clamp(1, s);
        ViewState {
            width: side(self.width),
            height: side(self.height),
            ..self.clone()
        }
    }

    /// The state as a keyframe of a path on the world clock (its time the state's world
    /// time, its velocity given).
    pub fn keyframe(&self) -> KeyframeFile {
        KeyframeFile {
            time_ps: self.t_world_ps,
            position_m: self.position_m,
            look_at_m: None,
            up: None,
            world_from_camera: Some(self.world_from_camera),
            vfov_deg: self.vfov_deg,
            beta: Some(self.beta),
        }
    }

    /// The one-frame camera path of this state: one keyframe at the state's world time, the
    /// frame at that time.
    pub fn path_file(&self) -> CameraPathFile {
        CameraPathFile {
            width: self.width,
            height: self.height,
            frames: 1,
            dtau_ps: self.dtau_ps,
            tau0_ps: Some(self.t_world_ps),
            clock: Some(Clock::World),
            interpolation: None,
            rotation: self.rotation.map(|r| RotationFile {
                axis: r.axis,
                beta_edge: r.beta_edge,
            }),
            keyframe: Some(vec![self.keyframe()]),
            orbit: None,
        }
    }

    /// The one-frame path as TOML, headed by the `femto render` flags that render it as the
    /// viewer does (`inputs`: the `--cube ... --mesh ...` part).
    pub fn path_toml(&self, inputs: &str) -> String {
        let body = toml::to_string(&self.path_file()).expect("a camera path serialises");
        format!(
            "# femto view: one camera state as a one-frame camera path (docs/view.md). Its frame is\n\
             # the viewer's still of the state, bit for bit:\n\
             #   femto render {inputs} --path THIS.toml {} --out still/\n{body}",
            self.render_flags()
        )
    }

    /// The `femto render` flags of the state's render options (the path file has the rest).
    pub fn render_flags(&self) -> String {
        format!(
            "--view {} --effects {} --radiometry {} --exposure {} --laser-nm {}{}{}",
            self.view.as_str(),
            self.effects,
            match self.radiometry {
                Radiometry::Consistent => "consistent",
                Radiometry::Paper => "paper",
            },
            self.exposure,
            self.laser_nm,
            if self.dark_marks { " --dark-marks" } else { "" },
            if self.false_colour {
                " --false-colour"
            } else {
                ""
            },
        )
    }

    /// The one-frame camera path, resolved from its TOML text as `femto render --path`
    /// resolves the file.
    pub fn path(&self) -> Result<CameraPath, BadState> {
        let text = toml::to_string(&self.path_file()).expect("a camera path serialises");
        CameraPath::from_toml(&text, "state").map_err(|e| bad("state", e.to_string()))
    }

    /// The render options `femto render --path` gets from [`ViewState::render_flags`].
    pub fn render_options(&self) -> RenderOptions {
        RenderOptions {
            effects: self.effects,
            radiometry: self.radiometry,
            view: self.view.into(),
            exposure: self.exposure,
            format: VideoFormat::PngSequence,
            dark_marks: self.dark_marks,
            false_colour: self.false_colour,
            ..RenderOptions::default()
        }
    }

    /// Lorentz factor of the camera's speed.
    pub fn gamma(&self) -> f64 {
        let b2: f64 = self.beta.iter().map(|b| b * b).sum();
        1.0 / (1.0 - b2).sqrt()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn example() -> ViewState {
        ViewState {
            position_m: [0.0, 0.22, 0.85],
            world_from_camera: [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]],
            vfov_deg: 20.0,
            beta: [0.0, 0.0, -0.5],
            t_world_ps: 3230.0,
            dtau_ps: 11.9,
            width: 64,
            height: 48,
            rotation: None,
            effects: Effects::ALL,
            view: ViewName::Transient,
            radiometry: Radiometry::Consistent,
            exposure: 1.0,
            laser_nm: 670.0,
            dark_marks: false,
            false_colour: false,
        }
    }

    #[test]
    fn frame_options_out_of_range_are_refused_naming_the_field() {
        assert!(FrameOptions::default().check().is_ok());
        for (scale, quality, field) in [
            (0.0, 85, "scale"),
            (1.5, 85, "scale"),
            (f64::NAN, 85, "scale"),
            (1.0, 0, "quality"),
            (1.0, 101, "quality"),
            (1.0, 255, "quality"),
            (1.0, -1, "quality"),
        ] {
            let e = FrameOptions { scale, quality }.check().unwrap_err();
            assert_eq!(e.field, field, "{e}");
        }
        assert!(FrameOptions {
            scale: 0.25,
            quality: 1
        }
        .check()
        .is_ok());
        assert!(FrameOptions {
            scale: 1.0,
            quality: 100
        }
        .check()
        .is_ok());
    }

    #[test]
    fn a_state_reads_back_from_its_json_and_its_path_is_the_state() {
        let s = example();
        let json = serde_json::to_vec(&s).unwrap();
        assert_eq!(ViewState::from_json(&json).unwrap(), s);
        let f = s.path().unwrap().frame(0);
        assert_eq!(f.position_m.coords.as_slice(), &s.position_m);
        assert_eq!(f.beta.as_slice(), &s.beta);
        assert_eq!(f.t_world_ps, s.t_world_ps);
        assert_eq!(f.vfov_deg, s.vfov_deg);
    }

    #[test]
    fn bad_states_are_refused_naming_the_field() {
        type Mutation = Box<dyn Fn(&mut ViewState)>;
        let cases: Vec<(&str, Mutation)> = vec![
            ("beta", Box::new(|s| s.beta = [0.0, 0.0, 1.0])),
            ("beta", Box::new(|s| s.beta = [0.8, 0.8, 0.0])),
            ("width", Box::new(|s| s.width = 4097)),
            ("height", Box::new(|s| s.height = 0)),
            ("vfov_deg", Box::new(|s| s.vfov_deg = 180.0)),
            ("dtau_ps", Box::new(|s| s.dtau_ps = 0.0)),
            ("exposure", Box::new(|s| s.exposure = -1.0)),
            ("laser_nm", Box::new(|s| s.laser_nm = 0.0)),
            ("t_world_ps", Box::new(|s| s.t_world_ps = 1e300)),
            ("position_m[1]", Box::new(|s| s.position_m[1] = 1e9)),
        ];
        for (field, mutate) in cases {
            let mut s = example();
            mutate(&mut s);
            let e = s.check().unwrap_err();
            assert_eq!(e.field, field, "{e}");
        }
        // Not a rotation: refused when the path is built, naming the key.
        let mut s = example();
        s.world_from_camera[0][0] = 2.0;
        let e = s.path().unwrap_err().to_string();
        assert!(
            e.contains("world_from_camera") && e.contains("not a rotation"),
            "{e}"
        );
    }

    #[test]
    fn malformed_json_unknown_fields_and_huge_numbers_are_refused() {
        let good = serde_json::to_value(example()).unwrap();
        let mut unknown = good.clone();
        unknown["zoom"] = serde_json::json!(2);
        for body in [
            b"{".to_vec(),
            b"[]".to_vec(),
            b"null".to_vec(),
            serde_json::to_vec(&unknown).unwrap(),
            br#"{"position_m": [1e999, 0, 0]}"#.to_vec(),
        ] {
            let e = ViewState::from_json(&body).unwrap_err();
            assert_eq!(e.field, "state");
            assert!(!e.to_string().contains('\n'));
        }
        let mut huge = good;
        huge["width"] = serde_json::json!(1u64 << 60);
        assert!(ViewState::from_json(&serde_json::to_vec(&huge).unwrap()).is_err());
    }
}
