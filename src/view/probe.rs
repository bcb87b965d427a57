//! The pixel probe (`POST /api/probe?x=I&y=J`, docs/view.md "Pixel probe"): what one pixel
//! of the page's frame shows and why. For pixel `(i, j)` of a state's frame it gives every
//! intermediate quantity of the renderer's pipeline ([`crate::render::probe_pixel`], steps
//! 1-7 of [`crate::render`]): the surface point and its distance, the Doppler factor and the
//! received wavelength, the emission time, the capture pixel that records the point and
//! [`DarkKind`]; and two time profiles:
//!
//! - `capture`: the world-time signal of that capture pixel in the world-time cube (per bin,
//!   at each bin's centre), the light the point emitted;
//! - `received`: the value this pixel of the moving camera shows at each reception time over
//!   the light curve's range, the same light shifted by the flight time and weighted by the
//!   searchlight factor.

use super::session::{ViewError, ViewSession};
use super::state::{bad, ViewState};
use crate::pyramid::PrefixRead;
use crate::render::dark::DarkKind;
use crate::render::probe_pixel;
use serde::Serialize;

/// Samples of the probe's received profile.
pub const RECEIVED_SAMPLES: usize = 128;

/// A time profile: values at times, ps.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Profile {
    pub t_ps: Vec<f64>,
    pub value: Vec<f64>,
}

/// What a pixel shows, and why (module doc).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PixelProbe {
    /// The pixel, `[i, j]` from the top-left corner of the frame.
    pub pixel: [usize; 2],
    pub kind: DarkKind,
    /// [`DarkKind::describe`].
    pub kind_text: &'static str,
    /// The surface point the pixel shows, world metres; None when its ray leaves the scene.
    pub point_m: Option<[f64; 3]>,
    /// Its distance from the camera, m.
    pub distance_m: Option<f64>,
    /// Doppler factor `D` of the light received along the pixel's ray.
    pub doppler: f64,
    /// Received wavelength, nm.
    pub lambda_nm: f64,
    /// World time of reception, ps.
    pub t_receive_ps: f64,
    /// World time at which the light shown left the point, ps.
    pub t_emit_ps: Option<f64>,
    /// The capture pixel that records the point, `[x, y]`.
    pub capture_pixel: Option<[usize; 2]>,
    /// The pixel's value before exposure now (scene-linear).
    pub value: f64,
    /// The capture pixel's signal in world time (None: no capture pixel records the point).
    pub capture: Option<Profile>,
    /// The value this pixel shows at each reception time over `range_ps`.
    pub received: Profile,
}

impl ViewSession<'_> {
    /// Probe pixel `(i, j)` of `state`'s frame; the received profile spans `range_ps`
    /// (the page's light-curve range).
    pub fn probe(
        &self,
        state: &ViewState,
        i: usize,
        j: usize,
        range_ps: [f64; 2],
    ) -> Result<PixelProbe, ViewError> {
        state.check()?;
        if i >= state.width || j >= state.height {
            return Err(bad(
                "pixel",
                format!(
                    "{i}, {j}: outside the {} x {} frame",
                    state.width, state.height
                ),
            )
            .into());
        }
        let [t0, t1] = range_ps;
        if !(t0.is_finite() && t1.is_finite() && t1 > t0) {
            return Err(bad("range", format!("{t0} .. {t1}: not an interval of ps")).into());
        }
        self.with_planned(state, |scene, plan| {
            let frame = plan.path.frame(0);
            let s = probe_pixel(scene, &plan.settings, &frame, i, j);
            let kind = DarkKind::of(scene, &s);
            let capture = s.capture_pixel.map(|(x, y)| {
                let w = scene.world;
                let prefix = w.prefix.pixel(y * w.nx + x);
                let dt = w.axis.dt_ps;
                let (t_ps, value) = (0..w.axis.nt)
                    .map(|b| {
                        let t_cube = w.axis.t0_ps + (b as f64 + 0.5) * dt;
                        (scene.world_time_ps(t_cube), prefix.bin(b))
                    })
                    .unzip();
                Profile { t_ps, value }
            });
            let mut moved = frame;
            let step = (t1 - t0) / RECEIVED_SAMPLES as f64;
            let (t_ps, value) = (0..RECEIVED_SAMPLES)
                .map(|k| {
                    let t = t0 + step * (k as f64 + 0.5);
                    // The frame's own clock: the reception time moves, the camera does not.
                    moved.t_world_ps = frame.t_world_ps + (t - s.t_receive_ps);
                    moved.tau_ps = frame.tau_ps + (t - s.t_receive_ps);
                    (t, probe_pixel(scene, &plan.settings, &moved, i, j).value)
                })
                .unzip();
            PixelProbe {
                pixel: [i, j],
                kind,
                kind_text: kind.describe(),
                point_m: s.hit_m.map(|(p, _)| p.into()),
                distance_m: s.hit_m.map(|(_, d)| d),
                doppler: s.doppler,
                lambda_nm: s.lambda_nm,
                t_receive_ps: s.t_receive_ps,
                t_emit_ps: s.t_emit_ps,
                capture_pixel: s.capture_pixel.map(|(x, y)| [x, y]),
                value: s.value,
                capture,
                received: Profile { t_ps, value },
            }
        })
    }
}
