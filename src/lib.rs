//! femto: a toolkit for femto-photography (transient imaging of light in flight).
//!
//! The library holds every algorithm; the `femto` binary only parses flags, opens files,
//! draws progress bars and calls into it. Conventions (units, clocks, signs) follow
//! `physics.md`: lengths in metres, times in picoseconds, camera frame x right / y down /
//! z forward, pixel `(x, y)` covering `[x, x+1) x [y, y+1)` with its centre at `(x+0.5, y+0.5)`.
//!
//! # Where the seed's equations live
//!
//! The seed is Jarabo et al. 2013, "Rendering relativistic effects in transient imaging".
//! Where its conventions and `physics.md` disagree (the angle of Eqs. 3-4, the radiometry),
//! the code follows `physics.md`, which says why.
//!
//! | seed | what | functions |
//! |---|---|---|
//! | Eq. 1 | transient rendering: arrival time of a path, `sum eta l_i / c` | [`tracer::trace`], [`tracer::Tracer::render_rows`] (per path: `tracer/path.rs`); streak capture: [`simulate::simulate_capture`] |
//! | Eq. 2 | time unwarp, `t_world = t_camera - eta abs(p - o) / c` | [`unwarp::unwarp_rows`], [`unwarp::unwarp_cube`], [`unwarp::covering_axis`]; the stage: [`pipeline::unwarp::unwarp_file`] |
//! | Eqs. 3-4 | aberration of a camera ray into the world frame | [`relativity::Boost::aberrate`] |
//! | Eqs. 5-7 | Doppler factor `D = gamma (1 - beta mu')`, shifted wavelength `lambda' = D lambda` and its colour | [`relativity::Boost::doppler_factor`], [`relativity::Boost::aberrate_with_doppler`], [`color::laser_colour`] |
//! | Eqs. 5-7 | searchlight and time-resolved accumulation, `D^-3 (P(t_e + dtau / D) - P(t_e)) / dtau` | [`relativity::Radiometry::frame_value`] over the prefix sums of [`pyramid::Pyramid::integral`] |
//! | Eqs. 5-7 | time dilation, `dt_world = gamma dtau` (the camera's proper-time clock) | [`camera_path::CameraPath::frame`], [`camera_path::CameraPath::at_proper_time`] (the clock table: `camera_path/clock.rs`) |
//! | Sec. 4.3 | rotation: each sensor area moves with `omega x r` | [`relativity::SensorRotation`], [`relativity::sensor_velocity`], [`camera_path::FrameState::pixel_beta`] |
//! | Sec. 4 | one frame: ray, aberration, hit, emission time, lookup, accumulation, colour | [`render::render_frame`] (the steps: [`render`] module doc) |
//! | Sec. 1, 5 | the real-time, interactive explorer of a captured scene | [`view::ViewSession`] (frames: [`view::ViewSession::render_srgb8`], through [`pipeline::render::plan`]), [`view::server::serve`], [`view::api::handle`] |
//! | interop | y-tal captures both ways (`t_start`, `delta_t` in optical path, the clock conventions), mitransient renders in | [`interop::export_tal`], [`interop::ingest_tal`], [`interop::ingest_mitransient`], [`interop::tal::TalCapture`] |
//! | capture | calibration of `t0` from the first arrivals (`physics.md`, two clocks) | [`calibrate::temporal::calibrate_time`], [`calibrate::temporal::fit_time_offset`] |

pub mod atomic;
pub mod calibrate;
pub mod camera;
pub mod camera_path;
pub mod color;
pub mod container;
pub mod cpu_time;
pub mod cube;
pub mod demo;
pub mod formats;
pub mod geometry;
pub mod ingest;
pub mod interop;
pub mod interrupt;
pub mod limits;
pub mod manifest;
pub mod pipeline;
pub mod pyramid;
pub mod ranges;
pub mod readers;
pub mod relativity;
pub mod render;
pub mod resample;
pub mod row_offset;
pub mod saturation;
pub mod scene;
pub mod simulate;
pub mod stats;
pub mod store;
pub mod tracer;
pub mod units;
pub mod unwarp;
pub mod video;
pub mod view;
