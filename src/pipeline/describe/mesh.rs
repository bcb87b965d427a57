//! Describing a triangle mesh (.obj, .gltf, .glb) as [`crate::geometry::load::load_mesh`]
//! loads it: counts, bounds in metres, surface area per material. The JSON form is the `mesh`
//! object of docs/cube-format.md.

use super::{extension, line, serialize_path};
use crate::geometry::load::load_mesh;
use crate::geometry::Aabb;
use crate::pipeline::StageError;
use serde::{Serialize, Serializer};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// A triangle mesh, as loaded (OBJ faces triangulated; glTF node transforms applied).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeshDescription {
    #[serde(serialize_with = "serialize_path")]
    pub file: PathBuf,
    /// The extension, lower case: `obj`, `gltf` or `glb`.
    pub format: String,
    pub triangles: usize,
    pub vertices: usize,
    /// Bounds of the vertices used by triangles, metres (None for a mesh of no triangles).
    #[serde(serialize_with = "serialize_bounds")]
    pub bounds_m: Option<Aabb>,
    /// Total triangle area, square metres.
    pub surface_area_m2: f64,
    /// Triangles and area per material index, in increasing index order.
    pub materials: Vec<MaterialArea>,
}

/// The triangles of one material index (OBJ `usemtl` id, glTF material index; 0 when none).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MaterialArea {
    pub index: u32,
    pub triangles: usize,
    pub area_m2: f64,
}

/// Load and describe the mesh at `path`.
pub(super) fn describe_mesh(path: &Path) -> Result<MeshDescription, StageError> {
    let mesh = load_mesh(path)?;
    let b = mesh.bounds();
    let mut by_index: BTreeMap<u32, (usize, f64)> = BTreeMap::new();
    for (i, &m) in mesh.material.iter().enumerate() {
        let e = by_index.entry(m).or_default();
        e.0 += 1;
        e.1 += mesh.area(i) as f64;
    }
    let materials: Vec<MaterialArea> = by_index
        .into_iter()
        .map(|(index, (triangles, area_m2))| MaterialArea {
            index,
            triangles,
            area_m2,
        })
        .collect();
    Ok(MeshDescription {
        file: path.to_path_buf(),
        format: extension(path),
        triangles: mesh.triangle_count(),
        vertices: mesh.positions.len(),
        bounds_m: (!b.is_empty()).then_some(b),
        surface_area_m2: materials.iter().map(|m| m.area_m2).sum(),
        materials,
    })
}

/// `{"min": [x, y, z], "max": [...], "size": [...]}` or null.
fn serialize_bounds<S: Serializer>(bounds: &Option<Aabb>, s: S) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    struct Bounds {
        min: [f32; 3],
        max: [f32; 3],
        size: [f32; 3],
    }
    bounds
        .map(|b| Bounds {
            min: b.min.into(),
            max: b.max.into(),
            size: (b.max - b.min).into(),
        })
        .serialize(s)
}

impl fmt::Display for MeshDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        line(f, "file", self.file.display())?;
        line(f, "kind", format!("triangle mesh ({})", self.format))?;
        line(
            f,
            "triangles",
            format!("{} ({} vertices)", self.triangles, self.vertices),
        )?;
        match self.bounds_m {
            None => line(f, "bounds", "empty")?,
            Some(b) => {
                let size = b.max - b.min;
                line(
                    f,
                    "bounds",
                    format!(
                        "({:.6}, {:.6}, {:.6}) .. ({:.6}, {:.6}, {:.6}) m, size {:.6} x {:.6} x \
                         {:.6} m",
                        b.min.x,
                        b.min.y,
                        b.min.z,
                        b.max.x,
                        b.max.y,
                        b.max.z,
                        size.x,
                        size.y,
                        size.z
                    ),
                )?;
            }
        }
        line(f, "area", format!("{:.6} m^2", self.surface_area_m2))?;
        for m in &self.materials {
            line(
                f,
                "material",
                format!(
                    "{}: {} triangles, {:.6} m^2",
                    m.index, m.triangles, m.area_m2
                ),
            )?;
        }
        Ok(())
    }
}
