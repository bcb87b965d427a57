//! The relativistic novel-view renderer (seed: Jarabo et al. 2013, Sec. 4): a virtual camera
//! moving freely, at speeds close to that of light, through a scene whose light was captured
//! in a world-time cube.
//!
//! # Pipeline (per pixel, per frame; [`frame`])
//!
//! 1. Camera ray `d'` through the pixel centre `(i + 0.5, j + 0.5)` of a pinhole with the
//!    frame's vertical field of view, in the moving camera's rest frame, rotated into world
//!    axes with `world_from_camera` (physics.md: the boost is pure, so the rest frame's axes
//!    are parallel to the world's and the aberration is done in world axes).
//! 2. Aberration into the world frame, `d = Boost::aberrate(d')` ([`crate::relativity`]), with
//!    the velocity of the pixel's own sensor area for a rotating sensor
//!    ([`crate::camera_path::FrameState::pixel_beta`], seed Sec. 4.3).
//! 3. Nearest hit `p` of the world ray with the mesh ([`crate::geometry::bvh::Bvh`]), at
//!    distance `r` from the camera.
//! 4. Emission world time `t_e = t_receive - eta r / c` (the per-view time re-warp of the
//!    seed's Fig. 4, physics.md "two clocks"), where `t_receive` is the frame's world time of
//!    reception: the camera's proper time `tau_k` mapped through the path's clock table
//!    (`dt_world = gamma dtau`).
//! 5. Image-based lookup: `p` is projected into the capture camera. Points the capture camera
//!    does not see render black, as in the seed: the nearest cube pixel's own first hit must
//!    lie on the same surface as `p` (see "Visibility" below). The signal shown is the
//!    bilinear interpolation of the up to four cube pixels around the projection that see
//!    `p` on a surface facing the nearest pixel's way ([`RenderScene::capture_taps`], the
//!    others left out and the weights renormalised: no light is smeared over an edge).
//!    The nearest pixel alone made a moire of the wavefront wherever the new view magnifies
//!    the capture: at a magnification `m` a cube pixel repeats every `1 / (m - 1)` rendered
//!    pixels, and where the pulse crosses a surface within a few bins the band broke into
//!    slanted teeth with that period (the demo's `fig6` at `beta = 0.23`).
//! 6. Searchlight accumulation with the prefix sums ([`crate::pyramid::Pyramid::integral`]):
//!    the light received during the exposure `[tau, tau + dtau]` left the surface during
//!    `[t_e, t_e + dtau / D]`, and the frame value is
//!    [`crate::relativity::Radiometry::frame_value`], `D^-3 (P(t_e + dtau/D) - P(t_e)) / dtau`
//!    (physics.md, "Time-resolved accumulation").
//! 7. Doppler-shifted wavelength `lambda' = D lambda_laser`, its colour by the CIE 1931
//!    matching functions, gamut-mapped to linear sRGB with luminance 1, grey outside the
//!    visible range ([`crate::color::laser_colour`]); the pixel is `value * colour`.
//! 8. Exposure, tone mapping and sRGB encoding happen when a frame is displayed
//!    ([`encode_srgb8`], [`crate::color::tone_map`]); [`render_frame`] writes scene-linear RGB
//!    (cube signal per picosecond of proper time).
//!
//! # Clocks and the time origin
//!
//! All times inside the renderer are **physical world time**, in ps, with 0 at the moment
//! the laser pulse leaves the diffuser spot. A camera path's `t_world_ps`
//! ([`crate::camera_path`]) is on that clock, shifted by [`RenderSettings::time_offset_ps`]
//! (world time of path time 0; 0 for a path file unless asked otherwise). The world-time
//! cube's axis is cube time: `t_cube = capture.t0_ps + capture.time_scale * t_world`
//! (the calibration's `t0_ps` is the cube time at which the pulse leaves the spot, and the
//! unwarp keeps that offset, [`crate::unwarp`]). [`RenderScene::cube_time_ps`] converts.
//!
//! # Doppler factor
//!
//! `D = 1 / (gamma (1 + beta . d))` with `d` the traced world-frame ray: with aberration on
//! this is `gamma (1 - beta . d')` (physics.md), and with aberration switched off it is still
//! the Doppler factor of the light that actually reaches the camera from the point it shows.
//!
//! # Radiometry
//!
//! [`crate::relativity::Radiometry::Consistent`] (the default) multiplies the window average
//! by `D^-3`: the display shows the wavelength-integrated radiance of a monochromatic laser,
//! which transforms as `D^-4`, and one of those four powers is the compression of emission
//! time that the accumulation window `dtau / D` already supplies. Constant light then gives
//! the classic `D^-4 L`. [`crate::relativity::Radiometry::Paper`] applies the seed's
//! formulas literally: the spectral `D^-5` factor *and* the window, which counts the time
//! compression twice and applies a per-wavelength bandwidth factor that has no place for a
//! line source; constant light gives `D^-6 L`. It exists only to compare with the seed's
//! pictures.
//!
//! # Effects ([`Effects`])
//!
//! Each effect switches off on its own, so every row of the seed's Fig. 5 can be made:
//! - `unwarp` off: `t_e = t_receive` (no per-view re-warp: every point is shown at the
//!   world time of reception).
//! - `aberration` off: the world ray is the camera ray `d'` (the image geometry of a camera at
//!   rest at the same place).
//! - `doppler` off: colour at the laser wavelength; a laser outside the visible range at its
//!   nearest end, 380 or 780 nm ([`crate::color::nearest_visible_nm`]), so that its light is
//!   drawn in colour, not in the grey of invisible wavelengths.
//! - `searchlight` off: `D = 1` in the accumulation window and the radiometric factor.
//! - `dilation` off: `t_receive = tau` (world time advancing at the proper time's rate; the
//!   path's two clocks agree at its start).
//! - `rotation` off: every pixel gets the camera's velocity (no rotating sensor).
//!
//! # Views ([`View`], [`views`])
//!
//! - [`View::Transient`]: the pipeline above.
//! - [`View::Naive`]: re-projection that keeps the capture camera's time warp (seed Fig. 4
//!   top left). A capture camera at `o_c` records, at camera time `t`, the light that left
//!   `p` at `t - eta |p - o_c| / c`. Showing those camera-time frames from the new viewpoint
//!   (frame at `t_receive` shows the capture's camera-time frame `t_receive`, re-projected
//!   through the geometry) means sampling the world cube at
//!   `t_e = t_receive - eta |p - o_c| / c`: the capture camera's distance, not the new
//!   camera's. The error of the naive view is therefore `eta (|p - o_c| - r) / c` per pixel.
//!   Everything else (aberration, Doppler, searchlight) is as in the transient view; the
//!   `unwarp` effect does not apply.
//! - [`View::Isochrones`]: per pixel, the time of first arrival at the camera of the direct
//!   light, `eta (|laser - p| + r) / c` (world time of first arrival at `p` plus the flight to
//!   the camera; with `unwarp` off, the world time alone), colour-coded from blue (early) to
//!   red (late) over [`Isochrones`]' range with dark contour lines every `contour_ps` (seed
//!   Fig. 4 bottom). Points the laser spot does not see directly (no direct pulse reaches them) are a neutral
//!   mid-grey ([`views::UNLIT_ISOCHRONE_RGB`]). The values are
//!   display colours, not tone mapped.
//! - [`View::Integrated`]: the time-integrated (classic, steady-state) image: the whole
//!   integral of the capture pixel's signal, times the constant-light factor
//!   ([`crate::relativity::constant_light_factor`]) with Doppler colour (seed Fig. 2 right).
//!
//! # Entry points
//!
//! Resolve, then compute: [`RenderScene::new`] (geometry, capture calibration, prefix sums,
//! wavelength), a [`crate::camera_path::CameraPath`] (a file, or [`paths::shortcut_path`] for
//! a dolly, an orbit or the capture camera's view), [`RenderSettings`] (with
//! [`auto_exposure`] and, for isochrones, [`isochrone_range`]); then [`render_sequence`] (or
//! [`render_frame`] per frame) and [`encode_srgb8`] for display.
//!
//! # Visibility
//!
//! [`RenderScene::new`] casts one ray through every capture pixel centre once and keeps its
//! first hit `q` and the surface normal `n` there (a G-buffer). A point `p` is seen by cube
//! pixel `(x, y)` when `p` lies on the plane of `q` (`|n . (p - q)|` below a tolerance of
//! 0.1 mm plus two pixel footprints at `q`'s depth) and is approached from the same side of
//! that surface by both cameras. An occluded `p` fails the test because the capture pixel's
//! ray stops on the occluder. This is the ray cast from the capture camera of the design,
//! done once per capture pixel instead of once per rendered pixel; it differs from the
//! per-point cast only within one capture pixel of an occlusion edge, where the nearest cube
//! pixel records the occluder anyway.

pub mod coverage;
pub mod dark;
mod dark_span;
pub mod exposure;
pub mod frame;
pub mod ibr_error;
pub mod paths;
pub mod truth;
pub mod views;

pub use exposure::{auto_exposure, exposure_for, lit_exposure, LitExposure};
pub use frame::{probe_pixel, render_frame, render_frame_reusing_rays, FrameRays, PixelSample};
pub use views::Isochrones;

use crate::camera::Calibration;
use crate::camera_path::CameraPath;
use crate::color;
use crate::geometry::bvh::Bvh;
use crate::geometry::Ray;
use crate::pyramid::{PrefixCoord, PrefixRead, Pyramid};
use crate::relativity::Radiometry;
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use std::fmt;
use std::ops::Range;

/// Errors of the renderer's validation (rendering itself cannot fail).
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The world cube's image size differs from the calibrated capture camera's.
    #[error(
        "the world cube is {cube_nx} x {cube_ny} pixels but the calibration's camera is {cal_width} x {cal_height}"
    )]
    CaptureSize {
        cube_nx: usize,
        cube_ny: usize,
        cal_width: usize,
        cal_height: usize,
    },
    /// The camera path passes through the scene geometry.
    #[error(
        "the camera path passes through the scene geometry between proper times {tau_a_ps:.3} and {tau_b_ps:.3} ps, near ({:.4}, {:.4}, {:.4}) m",
        point_m[0], point_m[1], point_m[2]
    )]
    PathThroughGeometry {
        tau_a_ps: f64,
        tau_b_ps: f64,
        point_m: [f64; 3],
    },
    /// A frame range that is empty or outside the path's frames.
    #[error("frames {start}..{end} are not a non-empty part of the path's frames 0..{count}")]
    Frames {
        start: usize,
        end: usize,
        count: usize,
    },
    /// A setting is out of range (`name` is the setting, `message` says why).
    #[error("{name}: {message}")]
    Setting { name: &'static str, message: String },
    /// An effect name that is not one of the six (or `all`, `none`).
    #[error("unknown effect '{0}': expected a comma-separated list of unwarp, aberration, doppler, searchlight, dilation, rotation, or all, or none")]
    UnknownEffect(String),
    /// A camera path could not be built (a shortcut's path; names the reason).
    #[error(transparent)]
    Path(#[from] crate::camera_path::CameraPathError),
    /// A view name that is not one of the four.
    #[error("unknown view '{0}': expected transient, naive, isochrones or integrated")]
    UnknownView(String),
}

/// Which relativistic effects are applied (all on by default). As JSON (`femto view`'s
/// state): an object of the six booleans, every one required.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Effects {
    /// Per-view time re-warp `t_e = t_receive - eta r / c`.
    pub unwarp: bool,
    /// Aberration of camera rays into the world frame.
    pub aberration: bool,
    /// Doppler shift of the colour, `lambda' = D lambda`.
    pub doppler: bool,
    /// Searchlight: accumulation window `dtau / D` and radiometric factor.
    pub searchlight: bool,
    /// Time dilation: `t_receive` from the path's clock table rather than `tau`.
    pub dilation: bool,
    /// Per-pixel velocity of a rotating sensor.
    pub rotation: bool,
}

impl Default for Effects {
    fn default() -> Self {
        Effects::ALL
    }
}

impl Effects {
    /// Every effect on.
    pub const ALL: Effects = Effects {
        unwarp: true,
        aberration: true,
        doppler: true,
        searchlight: true,
        dilation: true,
        rotation: true,
    };
    /// Every effect off (a classic renderer of the world-time cube).
    pub const NONE: Effects = Effects {
        unwarp: false,
        aberration: false,
        doppler: false,
        searchlight: false,
        dilation: false,
        rotation: false,
    };

    /// The effect names as [`Effects::parse`] reads them.
    pub const NAMES: [&'static str; 6] = [
        "unwarp",
        "aberration",
        "doppler",
        "searchlight",
        "dilation",
        "rotation",
    ];

    fn flags(&self) -> [bool; 6] {
        [
            self.unwarp,
            self.aberration,
            self.doppler,
            self.searchlight,
            self.dilation,
            self.rotation,
        ]
    }

    /// Parse a comma-separated list of effect names (the effects that are on), or `all`, or
    /// `none`. Whitespace around names is ignored; an empty list is `none`.
    pub fn parse(list: &str) -> Result<Effects, RenderError> {
        let list = list.trim();
        match list {
            "all" => return Ok(Effects::ALL),
            "none" | "" => return Ok(Effects::NONE),
            _ => {}
        }
        let mut e = Effects::NONE;
        for name in list.split(',').map(str::trim) {
            match name {
                "unwarp" => e.unwarp = true,
                "aberration" => e.aberration = true,
                "doppler" => e.doppler = true,
                "searchlight" => e.searchlight = true,
                "dilation" => e.dilation = true,
                "rotation" => e.rotation = true,
                _ => return Err(RenderError::UnknownEffect(name.to_string())),
            }
        }
        Ok(e)
    }

    /// Whether any effect that needs the Lorentz boost (aberration, Doppler, searchlight) is
    /// on.
    pub fn needs_boost(&self) -> bool {
        self.aberration || self.doppler || self.searchlight
    }
}

impl fmt::Display for Effects {
    /// The list [`Effects::parse`] reads back (`all`, `none`, or names joined by commas).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if *self == Effects::ALL {
            return f.write_str("all");
        }
        if *self == Effects::NONE {
            return f.write_str("none");
        }
        let on: Vec<&str> = Effects::NAMES
            .iter()
            .zip(self.flags())
            .filter(|(_, on)| *on)
            .map(|(n, _)| *n)
            .collect();
        f.write_str(&on.join(","))
    }
}

/// What a frame shows (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum View {
    /// Light in flight seen by the moving camera (the seed's renderer).
    #[default]
    Transient,
    /// Re-projection keeping the capture camera's time warp (seed Fig. 4 top left).
    Naive,
    /// Time of first arrival, colour-coded (seed Fig. 4 bottom).
    Isochrones(Isochrones),
    /// Time-integrated steady-state image (seed Fig. 2 right).
    Integrated,
}

impl View {
    /// Parse `transient`, `naive`, `isochrones` or `integrated`. Isochrones get the range
    /// `isochrones` (the caller resolves it, e.g. with [`isochrone_range`]).
    pub fn parse(name: &str, isochrones: Isochrones) -> Result<View, RenderError> {
        match name.trim().to_ascii_lowercase().as_str() {
            "transient" => Ok(View::Transient),
            "naive" => Ok(View::Naive),
            "isochrones" => Ok(View::Isochrones(isochrones)),
            "integrated" => Ok(View::Integrated),
            _ => Err(RenderError::UnknownView(name.to_string())),
        }
    }

    /// Whether the frame values are scene-linear radiance to be exposed and tone mapped
    /// (false for isochrones, which are display colours).
    pub fn is_radiance(&self) -> bool {
        !matches!(self, View::Isochrones(_))
    }

    pub fn name(&self) -> &'static str {
        match self {
            View::Transient => "transient",
            View::Naive => "naive",
            View::Isochrones(_) => "isochrones",
            View::Integrated => "integrated",
        }
    }
}

/// In which colour space [`render_frame`] writes its pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColourOutput {
    /// Linear sRGB, monochromatic colours gamut-mapped (luminance kept): for display.
    #[default]
    LinearSrgb,
    /// CIE 1931 XYZ of the received wavelength before any gamut mapping, `Y = value` (grey
    /// outside the visible range is D65 white). For measuring chromaticities.
    Xyz,
    /// Linear sRGB in false colour relative to the laser: light received at `D` times the
    /// laser's wavelength is drawn in the colour of `D` times [`FALSE_COLOUR_LASER_NM`], so
    /// the laser itself is green and an infrared or ultraviolet laser is drawn in colour
    /// (grey only past a shift of 380/550 or 780/550). `femto render --false-colour`.
    FalseColour,
}

/// The wavelength [`ColourOutput::FalseColour`] draws the laser's own light at, nm (green).
pub const FALSE_COLOUR_LASER_NM: f64 = 550.0;

/// Everything about how frames are rendered, resolved before rendering.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: usize,
    pub height: usize,
    pub effects: Effects,
    pub radiometry: Radiometry,
    pub view: View,
    pub colour: ColourOutput,
    /// Multiplier applied before tone mapping ([`encode_srgb8`]); see [`auto_exposure`].
    pub exposure: f64,
    /// Exposure window of each frame, ps of the camera's proper time (normally the path's
    /// frame interval).
    pub dtau_ps: f64,
    /// Physical world time (0 = the pulse leaves the laser spot) at the path's time 0, ps:
    /// added to every frame's `t_world_ps` (and to `tau_ps` with dilation off).
    pub time_offset_ps: f64,
}

impl RenderSettings {
    /// Settings for `path`: its frame size and interval, every effect, the consistent
    /// radiometry, the transient view, exposure 1, no time offset.
    pub fn for_path(path: &CameraPath) -> RenderSettings {
        let spec = path.spec();
        RenderSettings {
            width: spec.width,
            height: spec.height,
            effects: Effects::ALL,
            radiometry: Radiometry::Consistent,
            view: View::Transient,
            colour: ColourOutput::LinearSrgb,
            exposure: 1.0,
            dtau_ps: spec.dtau_ps,
            time_offset_ps: 0.0,
        }
    }

    /// Check the ranges of the settings.
    pub fn validate(&self) -> Result<(), RenderError> {
        let bad = |name, message: String| Err(RenderError::Setting { name, message });
        if self.width == 0 || self.height == 0 {
            return bad(
                "size",
                format!(
                    "{}x{}: width and height must be positive",
                    self.width, self.height
                ),
            );
        }
        if !(self.dtau_ps.is_finite() && self.dtau_ps > 0.0) {
            return bad(
                "dtau_ps",
                format!("{} is not a positive number of picoseconds", self.dtau_ps),
            );
        }
        if !(self.exposure.is_finite() && self.exposure > 0.0) {
            return bad(
                "exposure",
                format!("{} is not a positive number", self.exposure),
            );
        }
        if !self.time_offset_ps.is_finite() {
            return bad(
                "time_offset_ps",
                format!("{} is not a finite number", self.time_offset_ps),
            );
        }
        if let View::Isochrones(iso) = self.view {
            iso.validate()?;
        }
        Ok(())
    }
}

/// One capture pixel as a lookup reads it, in one cache line: its first hit (point and unit
/// normal, `f32::NAN` where the ray misses), whether the cube's mask keeps it, its links and
/// its dark span.
#[derive(Clone, Copy, Debug)]
#[repr(align(64))]
struct CaptureHit {
    point: [f32; 3],
    normal: [f32; 3],
    /// `|n . (p - q)|` allowed for a point `p` on the same surface, metres.
    tolerance_m: f32,
    /// `n . (o_c - q)`: which side of the surface the capture camera at `o_c` is on.
    capture_side: f64,
    /// Whether the cube's mask keeps the pixel (true without a mask).
    kept: bool,
    /// Bit `k` set when the neighbour `NEIGHBOURS[k]` records the same surface
    /// (`surface_links`): the pixels [`RenderScene::capture_taps`] interpolates between.
    links: u8,
    /// Where the prefix sums of the pixel's 3 x 3 neighbourhood are flat: a window there is
    /// black without a lookup (module `dark_span`).
    dark: dark_span::DarkSpan,
}

/// The scene as the renderer sees it: geometry, the capture camera, the world-time cube's
/// prefix sums and the laser wavelength, plus the capture camera's G-buffer.
pub struct RenderScene<'a> {
    /// The mesh in world metres.
    pub bvh: &'a Bvh,
    /// The capture camera, laser spot, medium and time origin.
    pub capture: Calibration,
    /// Prefix sums of the **world-time** cube (cube time, see the module doc).
    pub world: &'a Pyramid,
    /// Laser wavelength in its rest frame, nm.
    pub laser_nm: f64,
    /// Per cube pixel, its first hit, mask, links and dark span.
    hits: Vec<CaptureHit>,
    /// `world`'s prefix sums expanded to f64, `nt + 1` values per pixel (`P[i]` = sum of bins
    /// `0 .. i`): an interpolated `P(t)` then reads one cache line, not one of each of the
    /// stored two levels (`Pyramid::prefix`), which made a 640 x 480 frame 5 % slower
    /// (benches/render_results.md).
    prefix: Vec<f64>,
    /// `1 / dt` of the cube's axis, per ps.
    inv_dt_per_ps: f64,
    /// [`auto_exposure`] of the transient and naive views, and of the integrated view, once
    /// computed (they depend on the cube only; `femto view` asks for every frame).
    auto_exposures: [std::sync::OnceLock<f64>; 2],
}

impl<'a> RenderScene<'a> {
    /// Resolve a scene: checks that the cube matches the capture camera and that the
    /// wavelength is positive, and casts the capture camera's G-buffer (one ray per capture
    /// pixel, in parallel).
    pub fn new(
        bvh: &'a Bvh,
        capture: Calibration,
        world: &'a Pyramid,
        laser_nm: f64,
    ) -> Result<RenderScene<'a>, RenderError> {
        let k = &capture.intrinsics;
        if world.nx != k.width || world.ny != k.height {
            return Err(RenderError::CaptureSize {
                cube_nx: world.nx,
                cube_ny: world.ny,
                cal_width: k.width,
                cal_height: k.height,
            });
        }
        if !(laser_nm.is_finite() && laser_nm > 0.0) {
            return Err(RenderError::Setting {
                name: "laser_nm",
                message: format!("{laser_nm} is not a positive wavelength in nm"),
            });
        }
        let o = capture.pose.position_m;
        let origin = Point3::new(o.x as f32, o.y as f32, o.z as f32);
        let footprint = 1.0 / k.fx.min(k.fy);
        let mut hits = vec![
            CaptureHit {
                point: [f32::NAN; 3],
                normal: [f32::NAN; 3],
                tolerance_m: 0.0,
                capture_side: f64::NAN,
                kept: true,
                links: 0,
                dark: dark_span::DarkSpan::NEVER,
            };
            k.width * k.height
        ];
        hits.par_chunks_mut(k.width)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, h) in row.iter_mut().enumerate() {
                    let d = capture.world_ray(x as f64 + 0.5, y as f64 + 0.5);
                    let dir = Vector3::new(d.x as f32, d.y as f32, d.z as f32);
                    if let Some(hit) = bvh.intersect(&Ray::new(origin, dir), 0.0, f32::INFINITY) {
                        let p = origin + dir * hit.t;
                        let q = Point3::new(p.x as f64, p.y as f64, p.z as f64);
                        let n = hit.normal.cast::<f64>();
                        *h = CaptureHit {
                            point: [p.x, p.y, p.z],
                            normal: [hit.normal.x, hit.normal.y, hit.normal.z],
                            tolerance_m: (1e-4 + 2.0 * footprint * hit.t as f64) as f32,
                            capture_side: n.dot(&(capture.pose.position_m - q)),
                            ..*h
                        };
                    }
                }
            });
        let links = surface_links(&hits, k.width, k.height, world.mask.as_deref());
        let nt = world.axis.nt;
        let mut prefix = vec![0.0f64; world.nx * world.ny * (nt + 1)];
        prefix
            .par_chunks_mut(nt + 1)
            .enumerate()
            .for_each(|(pix, out)| {
                let p = world.prefix.pixel(pix);
                out.iter_mut().enumerate().for_each(|(i, o)| *o = p.get(i));
            });
        let dark = dark_span::dark_spans(&prefix, world.nx, world.ny, nt);
        for (i, h) in hits.iter_mut().enumerate() {
            h.kept = world.mask.as_ref().is_none_or(|m| m[i] != 0);
            (h.links, h.dark) = (links[i], dark[i]);
        }
        Ok(RenderScene {
            bvh,
            capture,
            world,
            laser_nm,
            hits,
            prefix,
            inv_dt_per_ps: 1.0 / world.axis.dt_ps,
            auto_exposures: Default::default(),
        })
    }

    /// Signal of cube pixel `(x, y)` emitted during the physical world times
    /// `[t_a_ps, t_b_ps]`: `P(cube(t_b)) - P(cube(t_a))` from the prefix sums, the same value
    /// as [`Pyramid::integral`] on the cube times (piecewise-linear `P`, zero before the axis,
    /// the total after it), with the bin coordinate computed by one multiplication.
    #[inline]
    pub fn emitted_energy(&self, x: usize, y: usize, t_a_ps: f64, t_b_ps: f64) -> f64 {
        let p = self.pixel_prefix(x, y);
        p.at_coord(self.bin_coord(t_b_ps)) - p.at_coord(self.bin_coord(t_a_ps))
    }

    /// The fractional bin coordinate of the cube's axis (0 at its start) at physical world
    /// time `t_ps`.
    #[inline(always)]
    fn bin_coord(&self, t_ps: f64) -> f64 {
        (self.cube_time_ps(t_ps) - self.world.axis.t0_ps) * self.inv_dt_per_ps
    }

    /// [`RenderScene::emitted_energy`] of the pixels of `taps`, weighted: the signal shown at
    /// a point ([`RenderScene::capture_taps`]). The bin coordinates are computed once.
    #[inline]
    pub fn emitted_energy_of(&self, taps: &CaptureTaps, t_a_ps: f64, t_b_ps: f64) -> f64 {
        self.energy_at_coords(taps, self.bin_coord(t_a_ps), self.bin_coord(t_b_ps))
    }

    /// [`RenderScene::emitted_energy_of`] between the bin coordinates `ca` and `cb` (each
    /// resolved once for the up to four pixels, [`PrefixCoord`]).
    #[inline(always)]
    fn energy_at_coords(&self, taps: &CaptureTaps, ca: f64, cb: f64) -> f64 {
        let nt = self.world.axis.nt;
        let (a, b) = (PrefixCoord::new(ca, nt), PrefixCoord::new(cb, nt));
        taps.iter()
            .map(|((x, y), weight)| {
                let p = self.pixel_prefix(x, y);
                weight * (b.read(p) - a.read(p))
            })
            .sum()
    }

    /// The time integral of cube pixel `(x, y)`'s signal (its prefix's last value).
    #[inline]
    pub fn pixel_total(&self, x: usize, y: usize) -> f64 {
        self.pixel_prefix(x, y).total()
    }

    /// The first hit of capture pixel `(x, y)`'s centre ray with the mesh (the G-buffer of
    /// "Visibility" in the module doc), world metres; None where the ray leaves the scene.
    #[inline]
    pub fn capture_hit_m(&self, x: usize, y: usize) -> Option<Point3<f64>> {
        let h = &self.hits[y * self.capture.intrinsics.width + x];
        (!h.point[0].is_nan())
            .then(|| Point3::new(h.point[0] as f64, h.point[1] as f64, h.point[2] as f64))
    }

    /// The end of the last bin, over the pixels the cube's mask keeps, that holds a non-zero
    /// value, in physical world time; None when every bin is zero. Weak late light counts
    /// as much as the direct pulse here, unlike [`coverage::LightProfile::span`].
    pub fn last_signal_world_ps(&self) -> Option<f64> {
        let n = self.world.axis.nt + 1;
        let mask = self.world.mask.as_deref();
        let last_bin = self
            .prefix
            .par_chunks(n)
            .enumerate()
            .filter(|(pix, _)| mask.is_none_or(|m| m[*pix] != 0))
            .filter_map(|(_, p)| p.windows(2).rposition(|w| w[1] != w[0]))
            .max()?;
        let a = &self.world.axis;
        Some(self.world_time_ps(a.t0_ps + (last_bin + 1) as f64 * a.dt_ps))
    }

    /// Pixel `(x, y)`'s expanded prefix sums, `nt + 1` values.
    #[inline]
    fn pixel_prefix(&self, x: usize, y: usize) -> &[f64] {
        let n = self.world.axis.nt + 1;
        let o = (y * self.world.nx + x) * n;
        &self.prefix[o..o + n]
    }

    /// Cube time of a physical world time: `capture.t0_ps + capture.time_scale * t_world_ps`.
    #[inline]
    pub fn cube_time_ps(&self, t_world_ps: f64) -> f64 {
        self.capture.t0_ps + self.capture.time_scale * t_world_ps
    }

    /// Physical world time of a cube time (inverse of [`RenderScene::cube_time_ps`]).
    #[inline]
    pub fn world_time_ps(&self, t_cube_ps: f64) -> f64 {
        (t_cube_ps - self.capture.t0_ps) / self.capture.time_scale
    }

    /// The physical world times covered by the cube's axis, ps.
    pub fn world_span_ps(&self) -> (f64, f64) {
        let a = &self.world.axis;
        (self.world_time_ps(a.t0_ps), self.world_time_ps(a.end_ps()))
    }

    /// The cube pixel that records `p_m` for a viewer looking along `d_world` (unit, towards
    /// `p_m`): the nearest pixel to `p_m`'s projection, or None when the capture camera does
    /// not see that side of that point or the pixel is masked out.
    #[inline(always)]
    pub fn capture_pixel(
        &self,
        p_m: &Point3<f64>,
        d_world: &Vector3<f64>,
    ) -> Option<(usize, usize)> {
        self.seen_projection(p_m, d_world)
            .map(|(nearest, _)| nearest)
    }

    /// `p_m`'s nearest cube pixel and its projection `(u, v)` into the capture image, when
    /// that pixel sees it ([`RenderScene::pixel_sees`]).
    #[inline(always)]
    fn seen_projection(
        &self,
        p_m: &Point3<f64>,
        d_world: &Vector3<f64>,
    ) -> Option<((usize, usize), (f64, f64))> {
        let (u, v) = self.capture.project(p_m)?;
        let k = &self.capture.intrinsics;
        if !(u >= 0.0 && v >= 0.0 && u < k.width as f64 && v < k.height as f64) {
            return None;
        }
        let (x, y) = (u as usize, v as usize);
        self.pixel_sees(x, y, p_m, d_world)
            .then_some(((x, y), (u, v)))
    }

    /// The cube pixels whose signal is shown at `p_m` (module doc, step 5): None when its
    /// nearest pixel ([`RenderScene::capture_pixel`]) does not see it; else the up to four
    /// pixels around its projection with their bilinear weights, those that do not record
    /// the nearest pixel's surface left out (another surface: a first hit off the nearest
    /// pixel's plane, or one turned by more than [`TAP_MAX_ANGLE_DEG`]; masked; outside the
    /// image; computed once per scene) and the others' weights scaled to sum to 1.
    #[inline(always)]
    pub fn capture_taps(&self, p_m: &Point3<f64>, d_world: &Vector3<f64>) -> Option<CaptureTaps> {
        let (nearest, uv) = self.seen_projection(p_m, d_world)?;
        Some(self.taps_around(nearest, uv))
    }

    /// [`RenderScene::capture_taps`] of a point whose projection `(u, v)` (inside the image)
    /// has the nearest pixel `nearest`, which sees the point.
    #[inline(always)]
    fn taps_around(&self, nearest: (usize, usize), (u, v): (f64, f64)) -> CaptureTaps {
        let k = &self.capture.intrinsics;
        // Pixel centres sit at half-integer coordinates; the nearest pixel is one of the four
        // and its weight is at least 1/4.
        let (fu, fv) = (u - 0.5, v - 0.5);
        let (x0, y0) = (floor_small(fu), floor_small(fv));
        let (ax, ay) = (fu - x0 as f64, fv - y0 as f64);
        let mut taps = CaptureTaps {
            nearest,
            pixels: [nearest; 4],
            weights: [0.0; 4],
            count: 0,
        };
        let corners = [
            (0, 0, (1.0 - ax) * (1.0 - ay)),
            (1, 0, ax * (1.0 - ay)),
            (0, 1, (1.0 - ax) * ay),
            (1, 1, ax * ay),
        ];
        // The corners in whole pixels: the bounds and the links compared as integers (with
        // float coordinates compared and converted, a 640 x 480 frame of `femto view` at rest
        // took 13.1 ms instead of 11.1 in benches/view).
        let (width, height) = (k.width as i64, k.height as i64);
        let (nx, ny) = (nearest.0 as i64, nearest.1 as i64);
        let links = self.hits[nearest.1 * k.width + nearest.0].links;
        let mut sum = 0.0;
        for (dx, dy, w) in corners {
            let (x, y) = (x0 + dx, y0 + dy);
            if w <= 0.0 || x < 0 || y < 0 || x >= width || y >= height {
                continue;
            }
            if (x, y) != (nx, ny) {
                // The corners are at most one pixel from the nearest in each axis.
                let cell = 3 * (y + 1 - ny) + (x + 1 - nx);
                let bit = cell - i64::from(cell > 4);
                if links & (1 << bit) == 0 {
                    continue;
                }
            }
            let (x, y) = (x as usize, y as usize);
            taps.pixels[taps.count] = (x, y);
            taps.weights[taps.count] = w;
            taps.count += 1;
            sum += w;
        }
        let inv = 1.0 / sum;
        taps.weights[..taps.count]
            .iter_mut()
            .for_each(|w| *w *= inv);
        taps
    }

    /// For a point `p_m` that the nearest pixel of its projection would record without the
    /// cube's mask (for a viewer looking along `d_world`), whether the mask keeps that pixel;
    /// None when no pixel would record it ([`dark::DarkKind`]).
    pub fn nearest_pixel_unmasked(
        &self,
        p_m: &Point3<f64>,
        d_world: &Vector3<f64>,
    ) -> Option<bool> {
        let (u, v) = self.capture.project(p_m)?;
        let k = &self.capture.intrinsics;
        if !(u >= 0.0 && v >= 0.0 && u < k.width as f64 && v < k.height as f64) {
            return None;
        }
        let (x, y) = (u as usize, v as usize);
        self.surface_holds(x, y, p_m, d_world).then(|| {
            self.world
                .mask
                .as_ref()
                .is_none_or(|mask| mask[y * k.width + x] != 0)
        })
    }

    /// Whether cube pixel `(x, y)` (inside the image) records `p_m` for a viewer looking
    /// along `d_world`: its first hit's surface holds `p_m` (module doc, "Visibility"), both
    /// cameras face the same side of it, and the cube's mask keeps the pixel.
    #[inline(always)]
    fn pixel_sees(&self, x: usize, y: usize, p_m: &Point3<f64>, d_world: &Vector3<f64>) -> bool {
        let width = self.capture.intrinsics.width;
        self.surface_holds(x, y, p_m, d_world) && self.hits[y * width + x].kept
    }

    /// [`RenderScene::pixel_sees`] without the mask.
    #[inline(always)]
    fn surface_holds(&self, x: usize, y: usize, p_m: &Point3<f64>, d_world: &Vector3<f64>) -> bool {
        let width = self.capture.intrinsics.width;
        let h = &self.hits[y * width + x];
        if h.point[0].is_nan() {
            return false;
        }
        let q = Point3::new(h.point[0] as f64, h.point[1] as f64, h.point[2] as f64);
        let n = Vector3::new(h.normal[0] as f64, h.normal[1] as f64, h.normal[2] as f64);
        if n.dot(&(p_m - q)).abs() > h.tolerance_m as f64 {
            return false;
        }
        // Same side: the capture camera and the viewer both face the same face.
        let viewer_side = -n.dot(d_world);
        if h.capture_side * viewer_side <= 0.0 {
            return false;
        }
        true
    }
}

/// `x.floor()` as an integer, for finite `|x| < 2^52`, without the libm call that `floor`
/// is on x86-64's baseline (no `roundsd`): truncation, one less where it rounded a negative
/// `x` up. [`RenderScene::taps_around`]'s coordinates are finite and at least `-0.5`.
#[inline(always)]
fn floor_small(x: f64) -> i64 {
    let t = x as i64;
    if t as f64 > x {
        t - 1
    } else {
        t
    }
}

/// The largest angle between the surface normals of two cube pixels that
/// [`RenderScene::capture_taps`] interpolates between, degrees: a tessellated curved surface
/// turns by a few degrees from pixel to pixel, a crease by tens.
pub const TAP_MAX_ANGLE_DEG: f64 = 10.0;
/// `cos(TAP_MAX_ANGLE_DEG)`.
const TAP_MIN_COS: f64 = 0.984_807_753_012_208;

/// The eight neighbours of a cube pixel, `(dx, dy)`, in the bit order of the links.
const NEIGHBOURS: [(isize, isize); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// For each cube pixel of a `width x height` G-buffer, the neighbours that record the same
/// surface: bit `k` is set when neighbour [`NEIGHBOURS`]`[k]` is inside the image, kept by
/// the cube's `mask`, has a first hit that lies on the plane of the pixel's own (within the
/// pixel's visibility tolerance, module doc "Visibility") and whose normal turns from the
/// pixel's by at most [`TAP_MAX_ANGLE_DEG`]. A neighbour across a crease (a box's edge, where
/// it stands on the floor) or a depth step holds another surface's light, which interpolation
/// would smear over the edge. Computed once per scene, so that a lookup tests one bit per
/// neighbour instead of each neighbour's plane (`benches/render.rs`, 640 x 480, all effects:
/// 58.6 CPU ms per frame with the planes tested per rendered pixel, 55.9 with the links,
/// against 43.4 for the nearest pixel alone; benches/render_results.md).
fn surface_links(hits: &[CaptureHit], width: usize, height: usize, mask: Option<&[u8]>) -> Vec<u8> {
    let kept = |i: usize| mask.is_none_or(|m| m[i] != 0) && !hits[i].point[0].is_nan();
    let f64s = |a: [f32; 3]| Vector3::new(a[0] as f64, a[1] as f64, a[2] as f64);
    let mut links = vec![0u8; width * height];
    links
        .par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, l) in row.iter_mut().enumerate() {
                let i = y * width + x;
                if !kept(i) {
                    continue;
                }
                let h = &hits[i];
                let (q, n) = (f64s(h.point), f64s(h.normal));
                for (bit, &(dx, dy)) in NEIGHBOURS.iter().enumerate() {
                    let (xn, yn) = (x as isize + dx, y as isize + dy);
                    if xn < 0 || yn < 0 || xn >= width as isize || yn >= height as isize {
                        continue;
                    }
                    let j = yn as usize * width + xn as usize;
                    if !kept(j) {
                        continue;
                    }
                    let (qn, nn) = (f64s(hits[j].point), f64s(hits[j].normal));
                    if n.dot(&(qn - q)).abs() <= h.tolerance_m as f64
                        && n.dot(&nn).abs() >= TAP_MIN_COS
                    {
                        *l |= 1 << bit;
                    }
                }
            }
        });
    links
}

/// The cube pixels shown at a point and their weights ([`RenderScene::capture_taps`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CaptureTaps {
    /// The nearest pixel to the point's projection (always among the taps).
    pub nearest: (usize, usize),
    /// The pixels, `count` of them; the rest repeat `nearest` with weight 0.
    pub pixels: [(usize, usize); 4],
    /// Their weights, summing to 1.
    pub weights: [f64; 4],
    /// How many of the four are used (1 to 4).
    pub count: usize,
}

impl CaptureTaps {
    /// The pixels and their weights.
    #[inline(always)]
    pub fn iter(&self) -> impl Iterator<Item = ((usize, usize), f64)> + '_ {
        self.pixels[..self.count]
            .iter()
            .copied()
            .zip(self.weights[..self.count].iter().copied())
    }
}

/// Check that the camera path does not pass through the scene: segments between
/// `4 * frames + 1` (at least 65) positions evenly spaced in proper time are cast against the
/// mesh.
pub fn check_path_clear(bvh: &Bvh, path: &CameraPath) -> Result<(), RenderError> {
    let frames = path.spec().frames;
    let n = (4 * frames + 1).max(65);
    let points = path.sample_positions(n);
    let (tau0, tau1) = (path.tau_ps(0), path.tau_ps(frames - 1));
    for (s, w) in points.windows(2).enumerate() {
        let seg = w[1] - w[0];
        let len = seg.norm();
        if len <= 0.0 {
            continue;
        }
        let dir = seg / len;
        let ray = Ray::new(
            Point3::new(w[0].x as f32, w[0].y as f32, w[0].z as f32),
            Vector3::new(dir.x as f32, dir.y as f32, dir.z as f32),
        );
        if let Some(hit) = bvh.intersect(&ray, 0.0, len as f32) {
            let p = w[0] + dir * hit.t as f64;
            let tau_at = |i: usize| tau0 + (tau1 - tau0) * i as f64 / (n - 1) as f64;
            return Err(RenderError::PathThroughGeometry {
                tau_a_ps: tau_at(s),
                tau_b_ps: tau_at(s + 1),
                point_m: [p.x, p.y, p.z],
            });
        }
    }
    Ok(())
}

/// Check a frame range against the path.
pub fn check_frames(path: &CameraPath, frames: &Range<usize>) -> Result<(), RenderError> {
    let count = path.spec().frames;
    if frames.start >= frames.end || frames.end > count {
        return Err(RenderError::Frames {
            start: frames.start,
            end: frames.end,
            count,
        });
    }
    Ok(())
}

/// Render frames `frames` of `path`, calling `sink(k, pixels)` with each frame's scene-linear
/// pixels (row-major from the top row) in order. Validates the settings, the frame range and
/// that the path does not pass through the geometry first. Frame `k` depends only on `k`, so
/// any split of a sequence into ranges gives the same frames, bit for bit. Frames whose rays
/// are those of the frame before (a dolly) reuse them ([`render_frame_reusing_rays`]: the same
/// pixels).
pub fn render_sequence<E: From<RenderError>>(
    scene: &RenderScene,
    settings: &RenderSettings,
    path: &CameraPath,
    frames: Range<usize>,
    mut sink: impl FnMut(usize, &[[f32; 3]]) -> Result<(), E>,
) -> Result<(), E> {
    let mut rays = FrameRays::default();
    render_sequence_reusing(scene, settings, path, frames, &mut rays, |k, pixels, _| {
        sink(k, pixels)
    })
}

/// [`render_sequence`] with the rays (and hits) of the frame rendered before, from `rays`:
/// a caller that renders one frame at a time of the same scene (`femto view`) keeps `rays`
/// between calls, and a camera at rest whose time alone moves skips steps 1-3. The frames
/// are those of [`render_sequence`], bit for bit. `sink` gets each frame with the rays it
/// was rendered with (for [`dark::draw_dark_marks`]).
pub fn render_sequence_reusing<E: From<RenderError>>(
    scene: &RenderScene,
    settings: &RenderSettings,
    path: &CameraPath,
    frames: Range<usize>,
    rays: &mut FrameRays,
    mut sink: impl FnMut(usize, &[[f32; 3]], &FrameRays) -> Result<(), E>,
) -> Result<(), E> {
    settings.validate()?;
    check_frames(path, &frames)?;
    check_path_clear(scene.bvh, path)?;
    let mut pixels = vec![[0.0f32; 3]; settings.width * settings.height];
    for k in frames {
        render_frame_reusing_rays(scene, settings, &path.frame(k), rays, &mut pixels);
        sink(k, &pixels, rays)?;
    }
    Ok(())
}

/// The range of first-arrival times that [`View::Isochrones`] colour-codes for `path`:
/// the smallest and largest arrival time over the pixels of frame 0 (whatever range is
/// rendered, so split renders agree), with contour lines every `contour_ps` (None: a round
/// spacing giving 10 to 25 intervals, [`views::round_contour_ps`]). The pixels are probed
/// in the isochrone view whatever view `settings` holds (only that view computes arrival
/// times; probing another gave no time at all and the fallback range 0..1 ps, which drew
/// every pixel red under contour lines 0.1 ps apart). Falls back to 0..1 ps only when no
/// pixel of frame 0 sees the scene.
pub fn isochrone_range(
    scene: &RenderScene,
    settings: &RenderSettings,
    path: &CameraPath,
    contour_ps: Option<f64>,
) -> Isochrones {
    let settings = &RenderSettings {
        view: View::Isochrones(Isochrones {
            t_min_ps: 0.0,
            t_max_ps: 1.0,
            contour_ps: 1.0,
        }),
        ..*settings
    };
    let state = path.frame(0);
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for j in 0..settings.height {
        for i in 0..settings.width {
            let s = probe_pixel(scene, settings, &state, i, j);
            if let Some(t) = s.t_arrival_ps {
                lo = lo.min(t);
                hi = hi.max(t);
            }
        }
    }
    if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
        lo = 0.0;
        hi = 1.0;
    }
    Isochrones {
        t_min_ps: lo,
        t_max_ps: hi,
        contour_ps: contour_ps.unwrap_or_else(|| views::round_contour_ps(hi - lo)),
    }
}

/// Encode scene-linear frame pixels for display into 8-bit sRGB (`3 * pixels.len()` bytes):
/// radiance views are multiplied by `settings.exposure` and tone mapped
/// ([`crate::color::tone_map`]); isochrones are display colours and only encoded. Returns
/// the number of lit pixels ([`color::is_lit`]).
pub fn encode_srgb8(settings: &RenderSettings, pixels: &[[f32; 3]], out_rgb8: &mut [u8]) -> usize {
    if settings.view.is_radiance() {
        color::encode_frame(pixels, settings.exposure, out_rgb8)
    } else {
        assert_eq!(
            out_rgb8.len(),
            3 * pixels.len(),
            "encode_srgb8: output size"
        );
        let mut lit = 0;
        for (px, out) in pixels.iter().zip(out_rgb8.chunks_exact_mut(3)) {
            let rgb = [px[0] as f64, px[1] as f64, px[2] as f64];
            let code = color::encode_u8(rgb);
            lit += usize::from(color::is_lit(code));
            out.copy_from_slice(&code);
        }
        lit
    }
}

#[cfg(test)]
mod tests {
    use super::NEIGHBOURS;

    #[test]
    fn neighbour_bits_follow_the_row_major_cells_without_the_centre() {
        // RenderScene::capture_taps computes a neighbour's bit from its cell in the 3 x 3
        // block around the nearest pixel; surface_links sets it from NEIGHBOURS.
        for (bit, &(dx, dy)) in NEIGHBOURS.iter().enumerate() {
            let cell = (3 * (dy + 1) + (dx + 1)) as usize;
            assert_eq!(cell - usize::from(cell > 4), bit, "({dx}, {dy})");
        }
    }
}
