//! Keyframes of the viewer as a camera path, and camera paths as the viewer's states.
//!
//! The exported path (docs/camera-path.md) has the keyframes, in order of world time, on
//! the world clock with cubic interpolation and each keyframe's velocity given; its frames
//! start at the first keyframe (frame 0 is that keyframe's state exactly, so its frame is
//! the viewer's still of it) and follow one another at the first keyframe's frame interval
//! up to the last keyframe.

use super::state::{BadState, SensorSpin, ViewState};
use crate::camera_path::{CameraPath, CameraPathFile, MAX_FRAMES};

/// Most keyframes a session keeps.
pub const MAX_KEYFRAMES: usize = 1000;

/// Most frames of a path loaded into the viewer to be played.
pub const MAX_LOADED_FRAMES: usize = 100_000;

fn bad(field: &str, message: String) -> BadState {
    BadState {
        field: field.into(),
        message,
    }
}

/// The camera path through `keyframes` (sorted by world time) as TOML, headed by the
/// `femto render` command that renders it (`inputs`: the flags naming the inputs).
pub fn export_path(keyframes: &[ViewState], inputs: &str) -> Result<String, BadState> {
    let mut sorted = keyframes.to_vec();
    sorted.sort_by(|a, b| a.t_world_ps.total_cmp(&b.t_world_ps));
    let Some(first) = sorted.first() else {
        return Err(bad(
            "keyframes",
            "no keyframes: add at least one to export a path".into(),
        ));
    };
    let mut file = first.path_file();
    file.keyframe = Some(sorted.iter().map(ViewState::keyframe).collect());
    let resolve = |file: &CameraPathFile| {
        let text = toml::to_string(file).expect("a camera path serialises");
        CameraPath::from_toml(&text, "their path")
            .map(|_| text)
            .map_err(|e| bad("keyframes", e.to_string()))
    };
    let path = CameraPath::from_toml(&resolve(&file)?, "their path")
        .map_err(|e| bad("keyframes", e.to_string()))?;
    let (tau_a, tau_b) = path
        .keyframe_tau_span_ps()
        .expect("a keyframe path has a keyframe span");
    let intervals = ((tau_b - tau_a) / first.dtau_ps).floor();
    if !(intervals.is_finite() && intervals < MAX_FRAMES as f64) {
        return Err(bad(
            "keyframes",
            format!(
                "{:.1} ps of proper time between the first and last keyframe at {} ps a frame \
                 is more than {MAX_FRAMES} frames; raise the frame interval",
                tau_b - tau_a,
                first.dtau_ps
            ),
        ));
    }
    file.frames = intervals as usize + 1;
    let body = resolve(&file)?;
    Ok(format!(
        "# femto view: {} keyframes as a camera path (docs/view.md); frame 0 is the first keyframe.\n\
         #   femto render {inputs} --path THIS.toml {} --out frames/\n{body}",
        sorted.len(),
        first.render_flags()
    ))
}

/// A camera path loaded into the viewer: every frame as a state.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LoadedPath {
    pub frames: Vec<ViewState>,
}

/// The frames of `path` as states with the render settings of `like` (view, effects,
/// radiometry, exposure, laser).
pub fn frames_of_path(path: &CameraPath, like: &ViewState) -> Result<LoadedPath, BadState> {
    let spec = path.spec();
    if spec.frames > MAX_LOADED_FRAMES {
        return Err(bad(
            "path",
            format!(
                "{} frames: the viewer plays at most {MAX_LOADED_FRAMES}",
                spec.frames
            ),
        ));
    }
    let frames = (0..spec.frames)
        .map(|k| {
            let f = path.frame(k);
            let m = f.world_from_camera.matrix();
            ViewState {
                position_m: f.position_m.coords.into(),
                world_from_camera: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])),
                vfov_deg: f.vfov_deg,
                beta: f.beta.into(),
                t_world_ps: f.t_world_ps,
                dtau_ps: spec.dtau_ps,
                width: spec.width,
                height: spec.height,
                rotation: f.rotation.map(|r| SensorSpin {
                    axis: r.axis,
                    beta_edge: r.beta_edge,
                }),
                ..like.clone()
            }
        })
        .collect();
    Ok(LoadedPath { frames })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::state::tests::example;

    #[test]
    fn exported_keyframes_read_back_and_frame_0_is_the_first_keyframe() {
        let a = example();
        let mut b = example();
        b.t_world_ps += 1000.0;
        // 0.5 c for 1000 ps along -z: about 0.15 m.
        b.position_m[2] -= 0.5 * crate::units::C_M_PER_PS * 1000.0;
        // Recorded out of order: sorted by world time.
        let text = export_path(&[b.clone(), a.clone()], "--cube c.h5").unwrap();
        assert!(text.contains("femto render --cube c.h5 --path THIS.toml --view transient"));
        let path = CameraPath::from_toml(&text, "t").unwrap();
        assert_eq!(path.frame(0), a.path().unwrap().frame(0));
        // Frames up to the last keyframe: 1000 ps of world time at gamma 1.1547 is 866 ps
        // of proper time, 72 intervals of 11.9 ps.
        assert_eq!(path.spec().frames, 73);
        let loaded = frames_of_path(&path, &a).unwrap();
        assert_eq!(loaded.frames.len(), 73);
        assert_eq!(loaded.frames[0].position_m, a.position_m);
        assert!(
            (loaded.frames[72].t_world_ps - (a.t_world_ps + 72.0 * 11.9 * 1.1547005)).abs() < 0.1
        );
    }

    #[test]
    fn impossible_keyframes_are_refused_with_the_paths_reason() {
        assert!(export_path(&[], "")
            .unwrap_err()
            .message
            .contains("no keyframes"));
        let a = example();
        let mut b = example();
        b.t_world_ps += 10.0;
        b.position_m[0] += 1.0; // 1 m in 10 ps: faster than light
        let e = export_path(&[a.clone(), b], "").unwrap_err().to_string();
        assert!(e.contains("speed of light"), "{e}");
        let e = export_path(&[a.clone(), a], "").unwrap_err().to_string();
        assert!(e.contains("does not increase"), "{e}");
    }
}
