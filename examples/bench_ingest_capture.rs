//! Writes a synthetic streak capture for the ingest benchmark (`tools/bench_ingest.sh`):
//! `N` scanlines of `NX x NT` 16-bit grey PNG, `DIR/scan_%04d.png`, each a direct pulse whose
//! arrival curves across x and moves with the scanline, a weaker indirect tail, a dark offset
//! and Poisson-like noise, so the files compress like a real capture (not like zeros).
//!
//! Usage: `cargo run --release --example bench_ingest_capture -- DIR [N] [NX] [NT]`
//! (defaults 600 x 672 x 512, the seed paper's capture).

use femto::formats::{raster, StreakImage};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::path::PathBuf;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = PathBuf::from(
        args.get(1)
            .expect("usage: bench_ingest_capture DIR [N] [NX] [NT]"),
    );
    let arg = |i: usize, default: usize| {
        args.get(i)
            .map(|s| s.parse().expect("a positive integer"))
            .unwrap_or(default)
    };
    let (ny, nx, nt) = (arg(2, 600), arg(3, 672), arg(4, 512));
    std::fs::create_dir_all(&dir).expect("create the output folder");
    let value_per_count = 1.0;
    (0..ny).into_par_iter().for_each(|y| {
        let mut rng = Pcg64::seed_from_u64(y as u64);
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        let mut data = vec![0.0f32; nx * nt];
        let yf = (y as f64 - ny as f64 / 2.0) / ny as f64;
        for x in 0..nx {
            let xf = (x as f64 - nx as f64 / 2.0) / nx as f64;
            // Arrival (in time rows) curving with x and y; amplitude falling off to the sides.
            let t_direct = 120.0 + 160.0 * (xf * xf + yf * yf).sqrt();
            let amplitude = 20000.0 * (1.0 - 0.6 * xf * xf);
            for t in 0..nt {
                let dt = t as f64 - t_direct;
                let direct = amplitude * (-0.5 * (dt / 3.0).powi(2)).exp();
                let tail = if dt > 0.0 {
                    0.15 * amplitude * (-dt / 60.0).exp() * (1.0 - (-dt / 4.0).exp())
                } else {
                    0.0
                };
                let mean = 200.0 + direct + tail;
                // Gaussian approximation of Poisson noise plus read noise.
                let v = mean + (mean + 25.0).sqrt() * unit.sample(&mut rng);
                data[t * nx + x] = v.max(0.0) as f32;
            }
        }
        let img = StreakImage::new(nx, nt, data);
        raster::write_png16(&dir.join(format!("scan_{y:04}.png")), &img, value_per_count)
            .expect("write a scanline");
    });
    println!("wrote {ny} scanlines of {nx} x {nt} to {}", dir.display());
}
