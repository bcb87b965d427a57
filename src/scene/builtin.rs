//! The built-in scenes (`cube`, `cornell`, `bunny`), kept as scene files in `builtin/` and
//! compiled in with `include_str!`. Metres, y up. The window start `t0_ps` of each is set just
//! before the earliest direct arrival seen by a pixel (checked by a test). The Cornell box is
//! three pieces: its head (name, laser, camera), its walls, and either its two objects
//! (`cornell`) or a mesh file fitted into it (`bunny`, whose file path replaces `@PATH@`).

use super::{Scene, SceneError};
use std::path::Path;

/// Names accepted by [`Scene::builtin`].
pub const BUILTIN_NAMES: [&str; 3] = ["cube", "cornell", "bunny"];

const CUBE_TOML: &str = include_str!("builtin/cube.toml");
const CORNELL_HEAD: &str = include_str!("builtin/cornell_head.toml");
const CORNELL_WALLS: &str = include_str!("builtin/cornell_walls.toml");
const CORNELL_OBJECTS: &str = include_str!("builtin/cornell_objects.toml");
const BUNNY_ENTRY: &str = include_str!("builtin/bunny_entry.toml");

impl Scene {
    /// A built-in scene by name (`cube`, `cornell`, `bunny`); `bunny_mesh` is the mesh file
    /// the `bunny` scene places in the Cornell box (ignored by the others).
    pub fn builtin(name: &str, bunny_mesh: Option<&Path>) -> Result<Scene, SceneError> {
        let text = Scene::builtin_toml(name, bunny_mesh)?;
        Scene::from_toml(&text, &format!("built-in scene '{name}'"), Path::new("."))
    }

    /// The scene file text of a built-in scene (what [`Scene::builtin`] parses).
    pub fn builtin_toml(name: &str, bunny_mesh: Option<&Path>) -> Result<String, SceneError> {
        match name {
            "cube" => Ok(CUBE_TOML.to_string()),
            "cornell" => Ok(format!("{CORNELL_HEAD}{CORNELL_WALLS}{CORNELL_OBJECTS}")),
            "bunny" => {
                let path = bunny_mesh.ok_or(SceneError::BunnyNeedsMesh)?;
                let quoted = toml::Value::String(path.display().to_string()).to_string();
                Ok(format!(
                    "{}{CORNELL_WALLS}{}",
                    CORNELL_HEAD.replace("name = \"cornell\"", "name = \"bunny\""),
                    BUNNY_ENTRY.replace("@PATH@", &quoted)
                ))
            }
            _ => Err(SceneError::UnknownBuiltin {
                name: name.to_string(),
            }),
        }
    }
}
