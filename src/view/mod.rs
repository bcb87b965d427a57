//! `femto view`: the interactive explorer of a world-time cube in the browser (the seed's
//! "real-time framework which allows interactive visualization of relativistic effects",
//! Sec. 1 and Sec. 5), over HTTP and a WebSocket, so that it works through an SSH tunnel
//! with the data staying on the machine that holds it.
//!
//! Every frame is rendered by the render stage ([`crate::pipeline::render::plan`] and
//! [`crate::render::render_sequence`], seed Eqs. 2-9 as physics.md states them) for a one-
//! frame camera path made from the page's camera state ([`state::ViewState::path`]); the
//! still of a state is therefore exactly the frame `femto render --path` writes for that
//! path. Interactive frames are the same pixels, at a reduced size while the camera moves,
//! sent as JPEG.
//!
//! # Layout
//!
//! - `state`: the camera state (JSON) and its one-frame path and render options;
//! - `session`: the opened scene, the keyframes, stills, frames and heads-up numbers;
//! - `light`, `curve`: the light curve of the current view, its lit range and the room to
//!   travel (what the page is told; how it is measured);
//! - `probe`: what one pixel shows and why;
//! - `video_export`, `progress`: the keyframes' path saved as MP4 or GIF, and its progress;
//! - `keyframes`: keyframes to a camera path, a camera path to states;
//! - `api`: the HTTP API as a function from request to reply (docs/view.md);
//! - `access`: who is answered (token, `Host`, `Origin`, content type);
//! - `admission`: how many frames render at once, within the memory budget;
//! - `server`: the sockets (tiny_http, tungstenite);
//! - `assets`: the embedded page.

pub mod access;
pub mod admission;
pub mod api;
pub mod assets;
pub mod curve;
pub mod jpeg;
pub mod keyframes;
pub mod light;
pub mod probe;
pub mod progress;
pub mod server;
pub mod session;
pub mod state;
pub mod video_export;

pub use access::Access;
pub use session::{Hud, ViewError, ViewSession};
pub use state::{FrameOptions, ViewState};
