//! Steps 1-2 of the pipeline for a whole row, four pixels at a time ([`wide::f64x4`]): the
//! camera rays through the pixel centres, their aberration into the world frame and the
//! Doppler factors, for a frame with one boost in vacuum (every frame but a rotating
//! sensor's or one in a medium, which take [`FrameCtx::ray`] pixel by pixel). Each lane does
//! [`FrameCtx::ray_at`]'s exactly rounded operations (IEEE add, sub, mul, div, sqrt; no fused
//! multiply-add) in the same order, so the rays are bit for bit the scalar ones (the test
//! below). The scalar code spent most of its time waiting on its two divisions and square
//! root per pixel (benches/render_results.md).

use super::{FrameCtx, RenderSettings};
use nalgebra::Vector3;
use wide::f64x4;

impl FrameCtx<'_> {
    /// The world rays and Doppler factors of the pixels of row `j`, written to `d_world` and
    /// `doppler` (one per pixel of the row; both of the frame's width).
    pub(super) fn row_rays(
        &self,
        settings: &RenderSettings,
        j: usize,
        d_world: &mut [Vector3<f64>],
        doppler: &mut [f64],
    ) {
        let boost = match self.boost {
            Some(b) if self.eta == 1.0 => b,
            _ => {
                for (i, (d, dop)) in d_world.iter_mut().zip(doppler.iter_mut()).enumerate() {
                    let r = self.ray(settings, i, j);
                    (*d, *dop) = (r.d_world, r.doppler);
                }
                return;
            }
        };
        let s = f64x4::splat;
        let m = &self.world_from_camera;
        // `local = (x, y, 1)`; `d = M local`, each row of `M` summed as nalgebra does:
        // `(m0 x + m1 y) + m2`.
        let y = ((j as f64 + 0.5) - self.half.y) * self.inv_focal_px;
        let m_y = [0, 1, 2].map(|r| s(m[(r, 1)] * y));
        let m_x = [0, 1, 2].map(|r| s(m[(r, 0)]));
        let m_z = [0, 1, 2].map(|r| s(m[(r, 2)]));
        let beta = [0, 1, 2].map(|a| s(boost.beta[a]));
        let (inv_gamma, k, gamma) = (s(boost.inv_gamma), s(boost.k), s(boost.gamma));
        let (half_x, inv_focal) = (s(self.half.x), s(self.inv_focal_px));
        let (one, centres) = (s(1.0), f64x4::new([0.5, 1.5, 2.5, 3.5]));
        let aberration = settings.effects.aberration;
        for (c, (d_out, dop_out)) in d_world.chunks_mut(4).zip(doppler.chunks_mut(4)).enumerate() {
            let u = s((4 * c) as f64) + centres;
            let x = (u - half_x) * inv_focal;
            // Written out rather than with `map`: closures left out of line turned each
            // vector operation into a call.
            let d = [
                (m_x[0] * x + m_y[0]) + m_z[0],
                (m_x[1] * x + m_y[1]) + m_z[1],
                (m_x[2] * x + m_y[2]) + m_z[2],
            ];
            let norm = ((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]).sqrt();
            let inv_norm = one / norm;
            let cam = [d[0] * inv_norm, d[1] * inv_norm, d[2] * inv_norm];
            let b_dot_d = (beta[0] * cam[0] + beta[1] * cam[1]) + beta[2] * cam[2];
            let (world, dop) = if aberration {
                // PixelBoost::aberrate_with_doppler.
                let inv = one / (one - b_dot_d);
                let shift = k * b_dot_d - one;
                let world = [
                    (cam[0] * inv_gamma + beta[0] * shift) * inv,
                    (cam[1] * inv_gamma + beta[1] * shift) * inv,
                    (cam[2] * inv_gamma + beta[2] * shift) * inv,
                ];
                (world, gamma * (one - b_dot_d))
            } else {
                // PixelBoost::doppler_of_world_ray.
                (cam, one / (gamma * (one + b_dot_d)))
            };
            let world = [
                world[0].to_array(),
                world[1].to_array(),
                world[2].to_array(),
            ];
            let dop = dop.to_array();
            for (lane, (d, p)) in d_out.iter_mut().zip(dop_out.iter_mut()).enumerate() {
                *d = Vector3::new(world[0][lane], world[1][lane], world[2][lane]);
                *p = dop[lane];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{FrameCtx, RenderSettings};
    use crate::camera_path::FrameState;
    use crate::relativity::{Radiometry, RotationAxis, SensorRotation};
    use crate::render::{ColourOutput, Effects, View};
    use nalgebra::{Point3, Rotation3, Vector3};

    /// The rays of a row, four at a time, are the scalar pixel rays bit for bit: several
    /// orientations, velocities (none, slow, fast, backwards), fields of view and widths
    /// (a multiple of four and not), with aberration on and off, in vacuum; and, through
    /// the scalar fallback, a medium and a rotating sensor.
    #[test]
    fn row_rays_are_the_scalar_rays_bit_for_bit() {
        let betas = [
            Vector3::zeros(),
            Vector3::new(0.01, -0.02, 0.03),
            Vector3::new(0.3, 0.5, -0.6),
            Vector3::new(-0.1, 0.0, 0.95),
        ];
        let mut checked = 0;
        for (n, beta) in betas.into_iter().enumerate() {
            for (width, height, vfov_deg) in [(16, 9, 40.0), (23, 7, 75.0), (5, 3, 10.0)] {
                for (effects, eta, rotation) in [
                    (Effects::ALL, 1.0, None),
                    (Effects::parse("doppler,searchlight").unwrap(), 1.0, None),
                    (Effects::NONE, 1.0, None),
                    (Effects::ALL, 1.33, None),
                    (
                        Effects::ALL,
                        1.0,
                        Some(SensorRotation {
                            axis: RotationAxis::Roll,
                            beta_edge: 0.3,
                        }),
                    ),
                ] {
                    let state = FrameState {
                        index: 0,
                        tau_ps: 0.0,
                        t_world_ps: 0.0,
                        position_m: Point3::new(0.1, -0.2, 1.5),
                        world_from_camera: Rotation3::from_euler_angles(
                            0.3 * n as f64,
                            -0.7,
                            1.1 + n as f64,
                        ),
                        vfov_deg,
                        beta: beta / eta,
                        rotation,
                    };
                    let settings = RenderSettings {
                        width,
                        height,
                        effects,
                        radiometry: Radiometry::Consistent,
                        view: View::Transient,
                        colour: ColourOutput::LinearSrgb,
                        exposure: 1.0,
                        dtau_ps: 1.0,
                        time_offset_ps: 0.0,
                    };
                    let ctx = FrameCtx::in_medium(&settings, &state, eta, 532.0);
                    let mut d = vec![Vector3::repeat(f64::NAN); width];
                    let mut dop = vec![f64::NAN; width];
                    for j in 0..height {
                        ctx.row_rays(&settings, j, &mut d, &mut dop);
                        for i in 0..width {
                            let r = ctx.ray(&settings, i, j);
                            assert_eq!(
                                (d[i].map(f64::to_bits), dop[i].to_bits()),
                                (r.d_world.map(f64::to_bits), r.doppler.to_bits()),
                                "beta {beta:?} {effects} eta {eta} {width}x{height} pixel ({i}, {j})"
                            );
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 1000);
    }
}
