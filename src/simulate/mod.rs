//! `femto simulate`: a simulated streak-camera capture of a scene, with ground truth.
//!
//! The streak camera is the scene's pinhole camera ([`crate::scene::StreakCamera`]) behind a
//! scanning mirror: image row `y` of the true x-y-t cube (rendered by the transient path
//! tracer, seed Eq. 1, physics.md "Transient path tracing") is one streak image, `nx`
//! columns (x along the slit) by `nt` rows (time, down), the seed's capture format. Each
//! scanline goes through the imperfections of [`flaws`] (sweep non-linearity, trigger jitter,
//! laser power, vignetting, photon noise, dark signal, saturation, 16-bit quantisation) and is
//! written by [`capture::simulate_capture`] as a capture folder:
//!
//! | file                          | content                                                   |
//! |-------------------------------|-----------------------------------------------------------|
//! | `scanlines/scanline_NNNN.png` | 16-bit counts (signal = counts x `png_value_per_count`)     |
//! | `scanlines/scanline_NNNN.exr` | f32 signal (the same quantised values)                    |
//! | `scanlines/scanline_NNNN.img` | Hamamatsu HPD-TA, 16- or 32-bit counts, nominal time table |
//! | `manifest.toml`               | [`crate::manifest::Manifest`]: axis, scale, files, every imperfection with its true parameters |
//! | `scene.glb`                   | the scene mesh, metres, one material per entry             |
//! | `calibration.toml`            | the true [`crate::camera::Calibration`] (`t0_ps = 0`: cube time counts from the pulse leaving the laser spot, the clock of the cube's axis) |
//! | `fiducials.toml`              | 2D-3D correspondences ([`fiducials`]), true pixel positions |
//! | `truth_camera.h5`             | true cube, camera time (all light)                        |
//! | `truth_world.h5`              | true cube, world time: the same light binned at the time it is at the surface seen by the pixel (`t_world = t_camera - eta d / c`) |
//! | `truth_direct.h5`             | true one-bounce light, camera time                        |
//! | `flat.exr`                    | true flat field (`nx` x `ny` gains), with vignetting      |
//! | `dark.exr`                    | a dark frame (`nx` x `nt`, signal units), with a dark signal |
//!
//! With `transient_only` ([`transient`]) the folder holds only `truth_camera.h5` and the
//! render's counters, `render.json`.
//!
//! A capture can also be made in bands of rows by separate processes ([`band`]:
//! `simulate --rows A..B`, then `merge`), bit-identical to the capture of one process.
//!
//! Determinism: the tracer and every imperfection draw from streams seeded by the seed and
//! the pixel or scanline, so a capture is bit-identical whatever the thread count.

pub mod band;
pub mod budget;
pub mod capture;
pub mod fiducials;
pub mod flaws;
pub mod options;
pub mod transient;

pub use capture::{simulate_capture, SimulateSummary};
pub use flaws::{CaptureModel, Flaw, FlawError, Flaws};
pub use options::{SimulateError, SimulateOption, SimulateOptions, Stage};
