//! Steps 4-7 of the pipeline for a whole row in the transient view (the view `femto view`
//! and `femto render` show by default): first, four pixels at a time ([`wide::f64x4`]), the
//! hit points, their projections into the capture camera and the bin coordinates of their
//! emission windows; then, pixel by pixel, the lookups that read memory (the nearest cube
//! pixel's surface, the taps, the prefix sums) and the colour, computed only for pixels with
//! light. A window where the capture holds no light near the point (`render::dark_span`)
//! is black without the lookups. The arithmetic is [`FrameCtx::shade`]'s, operation for operation (exactly rounded
//! lane by lane, no fused multiply-add), so the pixels are bit for bit those of
//! [`super::probe_pixel`] (tests/render.rs pins every pixel of several frames to it).

use super::{colour, ColourOutput, FrameCtx, RenderScene, RenderSettings, RowScratch};
use nalgebra::{Point3, Vector3};
use wide::f64x4;

/// One pixel's hit point, its projection `(u, v)` into the capture image (NaN when the
/// point is behind the capture camera) and the bin coordinates of the start and end of its
/// emission window.
#[derive(Clone, Copy, Default)]
pub(super) struct Projected {
    p_m: [f64; 3],
    u: f64,
    v: f64,
    coord_a: f64,
    coord_b: f64,
}

impl FrameCtx<'_> {
    /// Steps 4-7 of the transient view for one row whose world rays, Doppler factors and
    /// hit distances (`hit_t`) are known.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn shade_transient_row(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        d_world: &[Vector3<f64>],
        doppler: &[f64],
        hit_t: &[Option<f32>],
        scratch: &mut RowScratch,
        row: &mut [[f32; 3]],
    ) {
        // Pixels whose ray leaves the scene are black; the others are projected, four at a
        // time, and looked up.
        row.fill([0.0; 3]);
        scratch.hit_pixels.clear();
        scratch.hit_pixels.extend(
            hit_t
                .iter()
                .enumerate()
                .filter_map(|(i, t)| t.map(|t| (i, t))),
        );
        let projected = &mut scratch.projected;
        projected.resize(scratch.hit_pixels.len(), Projected::default());
        self.project_hits(
            scene,
            settings,
            d_world,
            doppler,
            &scratch.hit_pixels,
            projected,
        );
        let k = &scene.capture.intrinsics;
        let (width, height) = (k.width as f64, k.height as f64);
        let e = settings.effects;
        // FrameCtx::colour: the laser's colour without the Doppler shift, else the colour of
        // each pixel's drawn wavelength (the received one, times `drawn_per_received` in
        // false colour), computed four at a time for display output.
        let vector_colours = e.doppler
            && matches!(
                settings.colour,
                ColourOutput::LinearSrgb | ColourOutput::FalseColour
            );
        scratch.lit.clear();
        for (&(i, _), pr) in scratch.hit_pixels.iter().zip(projected.iter()) {
            let (px, d, dop) = (&mut row[i], &d_world[i], doppler[i]);
            let (u, v) = (pr.u, pr.v);
            // RenderScene::seen_projection (NaN fails every comparison).
            if !(u >= 0.0 && v >= 0.0 && u < width && v < height) {
                continue;
            }
            let nearest = (u as usize, v as usize);
            let d_light = if e.searchlight { dop } else { 1.0 };
            let factor = settings.radiometry.window_factor(d_light);
            // A window where the taps hold no light gives energy +0 and so the value
            // `factor * +0 * (1 / dtau)`, which is +0 too for a finite positive factor; that
            // pixel is black like one the capture does not see, with no lookup.
            if scene.hits[nearest.1 * k.width + nearest.0]
                .dark
                .holds(pr.coord_a, pr.coord_b)
                && (factor * 0.0 * self.inv_dtau_per_ps).to_bits() == 0
            {
                continue;
            }
            let p = Point3::from(pr.p_m);
            if !scene.pixel_sees(nearest.0, nearest.1, &p, d) {
                continue;
            }
            let taps = scene.taps_around(nearest, (u, v));
            let energy = scene.energy_at_coords(&taps, pr.coord_a, pr.coord_b);
            let value = factor * energy * self.inv_dtau_per_ps;
            // A pixel without light is black whatever its colour (the colour of a received
            // wavelength is finite): only lit pixels compute theirs, the Doppler-shifted ones
            // four at a time below.
            if value == 0.0 {
                *px = [value as f32; 3];
            } else if vector_colours {
                // FrameCtx::colour's `lambda_nm * drawn_per_received`, the same product.
                let drawn_nm = dop * scene.laser_nm * self.drawn_per_received;
                scratch.lit.push((i, value, drawn_nm));
            } else {
                let lambda_nm = if e.doppler {
                    dop * scene.laser_nm
                } else {
                    scene.laser_nm
                };
                *px = radiance(value, self.colour(settings, lambda_nm));
            }
        }
        for lit in scratch.lit.chunks(4) {
            let four: [(usize, f64, f64); 4] = std::array::from_fn(|k| lit[k.min(lit.len() - 1)]);
            let colours = colour::laser_colours(four.map(|(_, _, lambda_nm)| lambda_nm));
            for (&(i, value, _), c) in lit.iter().zip(colours) {
                row[i] = radiance(value, c);
            }
        }
    }

    /// The vector part of [`FrameCtx::shade_transient_row`] for the pixels `hits` (index in
    /// the row, hit distance): hit points `o + r d`, their projections into the capture
    /// camera ([`crate::camera::Calibration::project`]) and the bin coordinates of the
    /// emission windows `[t_e, t_e + dtau / D]`.
    fn project_hits(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        d_world: &[Vector3<f64>],
        doppler: &[f64],
        hits: &[(usize, f32)],
        out: &mut [Projected],
    ) {
        let s = f64x4::splat;
        let cal = &scene.capture;
        let k = &cal.intrinsics;
        let r = cal.pose.world_from_camera.matrix();
        // Column c of R, splatted.
        let r_col = [0, 1, 2].map(|c| [0, 1, 2].map(|row| s(r[(row, c)])));
        let o_c = cal.pose.position_m;
        let o = [self.origin.x, self.origin.y, self.origin.z].map(s);
        let o_c = [o_c.x, o_c.y, o_c.z].map(s);
        let (k1, k2, one) = (s(k.k1), s(k.k2), s(1.0));
        let (fx, fy, cx, cy) = (s(k.fx), s(k.fy), s(k.cx), s(k.cy));
        let e = settings.effects;
        let t_receive = s(self.t_receive_ps);
        let eta_over_c = s(self.eta_over_c_ps_per_m);
        let dtau = s(settings.dtau_ps);
        let axis = &scene.world.axis;
        let (cube_t0, time_scale) = (s(cal.t0_ps), s(cal.time_scale));
        let (axis_t0, inv_dt) = (s(axis.t0_ps), s(scene.inv_dt_per_ps));
        // RenderScene::bin_coord.
        let bin_coord = |t: f64x4| ((cube_t0 + time_scale * t) - axis_t0) * inv_dt;
        for (hits, out) in hits.chunks(4).zip(out.chunks_mut(4)) {
            // The last few pixels padded with copies of the last one. Gathers and vector
            // arithmetic written out rather than with `map`: closures left out of line turned
            // each vector operation into a call.
            let mut lanes = [[0.0; 4]; 5];
            for k in 0..4 {
                let (i, t) = hits[k.min(hits.len() - 1)];
                let d = &d_world[i];
                (lanes[0][k], lanes[1][k], lanes[2][k]) = (d.x, d.y, d.z);
                (lanes[3][k], lanes[4][k]) = (t as f64, doppler[i]);
            }
            let [dx, dy, dz, dist, dop] = [
                f64x4::new(lanes[0]),
                f64x4::new(lanes[1]),
                f64x4::new(lanes[2]),
                f64x4::new(lanes[3]),
                f64x4::new(lanes[4]),
            ];
            // FrameCtx::shade: p = o + d r; Pose::camera_from_world: R^T (p - o_c), each
            // component a column of R dotted with it as nalgebra does, `(a + b) + c`.
            let p = [o[0] + dx * dist, o[1] + dy * dist, o[2] + dz * dist];
            let w = [p[0] - o_c[0], p[1] - o_c[1], p[2] - o_c[2]];
            let cam = [
                (r_col[0][0] * w[0] + r_col[0][1] * w[1]) + r_col[0][2] * w[2],
                (r_col[1][0] * w[0] + r_col[1][1] * w[1]) + r_col[1][2] * w[2],
                (r_col[2][0] * w[0] + r_col[2][1] * w[1]) + r_col[2][2] * w[2],
            ];
            // Intrinsics::project_camera_point.
            let (x, y) = (cam[0] / cam[2], cam[1] / cam[2]);
            let r2 = x * x + y * y;
            let scale = (one + k1 * r2) + k2 * r2 * r2;
            // No projection for a point behind the camera.
            let behind = cam[2].simd_le(s(0.0));
            let nan = s(f64::NAN);
            let u = behind.select(nan, fx * scale * x + cx);
            let v = behind.select(nan, fy * scale * y + cy);
            let d_light = if e.searchlight { dop } else { one };
            let t_e = if e.unwarp {
                t_receive - eta_over_c * dist
            } else {
                t_receive
            };
            let t_b = t_e + dtau / d_light;
            let (coord_a, coord_b) = (bin_coord(t_e).to_array(), bin_coord(t_b).to_array());
            let (u, v) = (u.to_array(), v.to_array());
            let p = [p[0].to_array(), p[1].to_array(), p[2].to_array()];
            for (i, out) in out.iter_mut().enumerate() {
                *out = Projected {
                    p_m: [p[0][i], p[1][i], p[2][i]],
                    u: u[i],
                    v: v[i],
                    coord_a: coord_a[i],
                    coord_b: coord_b[i],
                };
            }
        }
    }
}

/// The pixel written for the value `value` of light of colour `c` (step 7).
#[inline(always)]
fn radiance(value: f64, c: [f64; 3]) -> [f32; 3] {
    [
        (value * c[0]) as f32,
        (value * c[1]) as f32,
        (value * c[2]) as f32,
    ]
}
