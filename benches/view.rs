//! Frames per second that `femto view` delivers to a client at 640 x 480 with every effect
//! on, including rendering, JPEG encoding and the transfer over its WebSocket: the figure an
//! explorer's user sees. The server runs in this process (the library's
//! `femto::view::server`, as `femto view` runs it) on a rayon pool of 2 threads; the client is
//! a tungstenite WebSocket on loopback that does what the page does: it sends the next state
//! as soon as the frame before has arrived, and decodes nothing.
//!
//! The scene is that of `benches/render.rs`: the built-in cube scene, a synthetic
//! single-bounce world-time cube of 64 x 48 pixels and 256 bins of 6 ps. The camera starts at
//! the capture view and plays forward at beta 0.5 along its view, one frame interval of
//! proper time per frame (the page's Play), so every frame is a new state. Three runs of
//! 300 frames are reported: full size (640 x 480, JPEG quality 85), the reduced size the page
//! asks for while the camera moves (scale 0.5), and full size as PNG stills over HTTP
//! (`/api/still`, the renderer's own output) for comparison. The client sends the server's
//! token (`Authorization: token ...`) as a script would (docs/view.md, "Access").
//!
//! With `FEMTO_VIEW_INPUTS=WORLD.h5,CAL.toml,MESH` it opens those files as `femto view
//! --cube --calibration --mesh` does (for example `femto demo --quick`'s
//! `data/world.h5,data/calibration.toml,data/capture/scene.glb`) and starts where the page
//! starts: the capture view at rest at its brightest time. It then also plays at rest (the
//! page's Play after Reset: only the time moves) before the runs at beta 0.5.
//!
//! Run: `cargo bench --bench view`.

#[path = "../tests/common/mod.rs"]
mod common;

use femto::cube::TimeAxis;
use femto::geometry::bvh::Bvh;
use femto::pipeline::render::{
    open_render_inputs, LaserWavelength, RenderInputs, SceneGeometry, WavelengthSource,
};
use femto::pyramid::Pyramid;
use femto::scene::Scene;
use femto::view::{server, Access, ViewSession, ViewState};
use std::path::Path;
use std::time::Instant;
use tungstenite::client::IntoClientRequest;
use tungstenite::Message;

const THREADS: usize = 2;
const FRAMES: usize = 300;

fn inputs() -> RenderInputs {
    if let Ok(files) = std::env::var("FEMTO_VIEW_INPUTS") {
        let f: Vec<&str> = files.split(',').collect();
        assert_eq!(f.len(), 3, "FEMTO_VIEW_INPUTS=WORLD.h5,CAL.toml,MESH");
        let geometry = SceneGeometry::Files {
            calibration: Path::new(f[1]),
            mesh: Path::new(f[2]),
        };
        return open_render_inputs(Path::new(f[0]), None, geometry, None).expect("the inputs");
    }
    let cube_scene = Scene::builtin("cube", None).expect("built-in cube scene");
    let bvh = Bvh::new(cube_scene.mesh.clone());
    let cal = cube_scene.calibration();
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 6.0,
        nt: 256,
    };
    let cube = common::world_cube(&cal, &bvh, axis, common::single_bounce_energy(&cal, 10.0));
    RenderInputs {
        pyramid: Pyramid::build(&cube),
        bvh,
        calibration: cal,
        laser: LaserWavelength {
            nm: cube_scene.laser.wavelength_nm,
            source: WavelengthSource::Given,
        },
        notes: Vec::new(),
    }
}

/// The page's Play: one frame interval of proper time along the camera's straight motion.
fn advance(state: &mut ViewState) {
    let g = state.gamma();
    state.t_world_ps += g * state.dtau_ps;
    for i in 0..3 {
        state.position_m[i] += state.beta[i] * femto::units::C_M_PER_PS * g * state.dtau_ps;
    }
}

fn start_state(session: &ViewSession, beta: f64) -> ViewState {
    let mut s = session.info().capture_state.clone();
    let f = [
        s.world_from_camera[0][2],
        s.world_from_camera[1][2],
        s.world_from_camera[2][2],
    ];
    s.beta = f.map(|x| beta * x);
    s
}

/// Frames per second and mean bytes per frame of `FRAMES` frames on the WebSocket.
fn stream(url: &str, token: &str, session: &ViewSession, scale: f64, beta: f64) -> (f64, f64) {
    let mut request = (url.replace("http://", "ws://") + "ws")
        .into_client_request()
        .unwrap();
    request
        .headers_mut()
        .insert("Authorization", format!("token {token}").parse().unwrap());
    let (mut socket, _) = tungstenite::connect(request).unwrap();
    let mut state = start_state(session, beta);
    let t_peak_ps = state.t_world_ps;
    let mut bytes = 0usize;
    let mut server_ms = 0.0;
    let mut lit = 0.0;
    let started = Instant::now();
    for seq in 0..FRAMES {
        let request = serde_json::json!({"seq": seq, "scale": scale, "state": state});
        socket.send(Message::text(request.to_string())).unwrap();
        match socket.read().unwrap() {
            Message::Binary(b) => {
                bytes += b.len();
                let n = u32::from_le_bytes(b[..4].try_into().unwrap()) as usize;
                let header: serde_json::Value = serde_json::from_slice(&b[4..4 + n]).unwrap();
                server_ms += header["hud"]["render_ms"].as_f64().unwrap();
                lit += header["hud"]["lit_fraction"].as_f64().unwrap();
            }
            other => panic!("frame {seq}: {other:?}"),
        }
        if beta == 0.0 {
            // At rest, Play loops over the light: 40 frames around the brightest time.
            let step = ((seq + 1) % 40) as f64 - 20.0;
            state.t_world_ps = t_peak_ps + step * state.dtau_ps;
        } else {
            advance(&mut state);
        }
    }
    let s = started.elapsed().as_secs_f64();
    eprintln!(
        "  (scale {scale}, beta {beta}: {:.2} ms a frame in the server's render and encode, {:.2} ms in all; mean lit fraction {:.3})",
        server_ms / FRAMES as f64,
        1e3 * s / FRAMES as f64,
        lit / FRAMES as f64
    );
    (FRAMES as f64 / s, bytes as f64 / FRAMES as f64)
}

/// Stills per second over HTTP.
fn stills(url: &str, token: &str, session: &ViewSession) -> (f64, f64) {
    let agent = ureq::Agent::new_with_defaults();
    let mut state = start_state(session, 0.5);
    let mut bytes = 0usize;
    let n = FRAMES / 3;
    let started = Instant::now();
    for _ in 0..n {
        let body = serde_json::to_vec(&state).unwrap();
        let mut r = agent
            .post(format!("{url}api/still"))
            .header("Authorization", format!("token {token}"))
            .header("Content-Type", "application/json")
            .send(&body[..])
            .unwrap();
        bytes += r.body_mut().read_to_vec().unwrap().len();
        advance(&mut state);
    }
    let s = started.elapsed().as_secs_f64();
    (n as f64 / s, bytes as f64 / n as f64)
}

fn main() {
    rayon::ThreadPoolBuilder::new()
        .num_threads(THREADS)
        .build_global()
        .expect("a rayon pool");
    let inputs = inputs();
    let session = ViewSession::new(&inputs, "--cube world.h5".into(), 1.0).expect("a session");
    let (http, addr) = server::bind("127.0.0.1:0".parse().unwrap()).expect("a port");
    let url = format!("http://{addr}/");
    let access = Access::new(addr).expect("a token");
    let token = access.token().to_string();
    std::thread::scope(|scope| {
        scope.spawn(|| server::serve(&http, &session, &access));
        // One warm-up pass (first-touch of the prefix sums, the auto exposure).
        stream(&url, &token, &session, 0.25, 0.5);
        if std::env::var_os("FEMTO_VIEW_INPUTS").is_some() {
            let (fps, bytes) = stream(&url, &token, &session, 1.0, 0.0);
            println!(
                "femto view, 640 x 480, every effect, at rest (Play after Reset), JPEG q85 over a \
                 WebSocket, {THREADS} threads: {fps:.1} frames/s ({:.1} kB a frame)",
                bytes / 1e3
            );
        }
        let (fps, bytes) = stream(&url, &token, &session, 1.0, 0.5);
        println!(
            "femto view, 640 x 480, every effect, JPEG q85 over a WebSocket, {THREADS} threads: \
             {fps:.1} frames/s ({:.1} kB a frame)",
            bytes / 1e3
        );
        let (fps, bytes) = stream(&url, &token, &session, 0.5, 0.5);
        println!(
            "femto view, 320 x 240 (while moving), JPEG q85 over a WebSocket, {THREADS} threads: \
             {fps:.1} frames/s ({:.1} kB a frame)",
            bytes / 1e3
        );
        let (fps, bytes) = stills(&url, &token, &session);
        println!(
            "femto view, 640 x 480 PNG stills over HTTP, {THREADS} threads: {fps:.1} stills/s \
             ({:.1} kB a still)",
            bytes / 1e3
        );
        std::process::exit(0);
    });
}
