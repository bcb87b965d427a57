//! Writing a [`TriangleMesh`] as binary glTF 2.0 (`.glb`), so that scenes built or edited by
//! femto can be opened in other tools and read back by [`super::load::load_mesh`].
//!
//! Layout (glTF 2.0 §4.4): a 12-byte header, a JSON chunk padded with spaces and a BIN chunk
//! padded with zeros, both to 4 bytes. The document has one scene with one node and one mesh.
//! The mesh has one primitive per material index, in increasing material order; primitive `k`
//! refers to material `m_k` of a `materials` array that holds one placeholder entry
//! (`"material_<m>"`) per index up to the largest used, so [`super::load::load_mesh`] gives
//! every triangle back its material. Each primitive stores only the vertices its triangles use:
//! `f32` VEC3 positions (with the `min`/`max` the specification requires) and `u32` indices.

use super::TriangleMesh;
use nalgebra::Point3;
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Failure to write a `.glb` file.
#[derive(Debug, thiserror::Error)]
pub enum GlbError {
    /// Creating, writing or renaming the output failed.
    #[error("{path}: cannot write glTF binary: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A material index above [`MAX_MATERIAL`] (the file lists one material entry per index).
    #[error("{path}: material index {material} too large (at most {MAX_MATERIAL})")]
    MaterialIndex { path: PathBuf, material: u32 },
    /// A triangle refers to a vertex the mesh does not have.
    #[error("{path}: triangle {triangle} refers to vertex {index}, but the mesh has {vertices}")]
    IndexOutOfRange {
        path: PathBuf,
        triangle: usize,
        index: u32,
        vertices: usize,
    },
    /// The file would exceed the 4 GiB that the GLB header can describe.
    #[error("{path}: mesh too large for a glTF binary ({bytes} bytes, limit 4 GiB)")]
    TooLarge { path: PathBuf, bytes: u64 },
}

/// Largest material index [`write_glb`] accepts.
pub const MAX_MATERIAL: u32 = 65_535;

const GLB_MAGIC: u32 = 0x4654_6C67; // "glTF"
const CHUNK_JSON: u32 = 0x4E4F_534A; // "JSON"
const CHUNK_BIN: u32 = 0x004E_4942; // "BIN\0"
const TARGET_ARRAY_BUFFER: u32 = 34962;
const TARGET_ELEMENT_ARRAY_BUFFER: u32 = 34963;
const COMPONENT_FLOAT: u32 = 5126;
const COMPONENT_UNSIGNED_INT: u32 = 5125;
const MODE_TRIANGLES: u32 = 4;

/// Write `mesh` to `path` as binary glTF 2.0, atomically (nothing is left at `path` on failure).
pub fn write_glb(mesh: &TriangleMesh, path: &Path) -> Result<(), GlbError> {
    let bytes = encode_glb(mesh, path)?;
    crate::atomic::write_atomically(path, |tmp| std::fs::write(tmp, &bytes)).map_err(|source| {
        GlbError::Io {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// The `.glb` bytes of `mesh` (`path` only names the file in errors).
fn encode_glb(mesh: &TriangleMesh, path: &Path) -> Result<Vec<u8>, GlbError> {
    for (triangle, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= mesh.positions.len()) {
            return Err(GlbError::IndexOutOfRange {
                path: path.to_path_buf(),
                triangle,
                index,
                vertices: mesh.positions.len(),
            });
        }
    }
    let groups = material_groups(mesh);

    if let Some(&material) = groups.keys().next_back().filter(|&&m| m > MAX_MATERIAL) {
        return Err(GlbError::MaterialIndex {
            path: path.to_path_buf(),
            material,
        });
    }

    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut primitives = Vec::new();
    for (&material, tris) in &groups {
        let (local_positions, indices) = compact_vertices(mesh, tris);
        let mut min = [f32::INFINITY; 3];
        let mut max = [f32::NEG_INFINITY; 3];
        let pos_offset = bin.len();
        for p in &local_positions {
            for a in 0..3 {
                min[a] = min[a].min(p[a]);
                max[a] = max[a].max(p[a]);
                bin.extend_from_slice(&p[a].to_le_bytes());
            }
        }
        let pos_len = bin.len() - pos_offset;
        let idx_offset = bin.len();
        for i in &indices {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let idx_len = bin.len() - idx_offset;

        let pos_view = views.len();
        views.push(
            json!({"buffer": 0, "byteOffset": pos_offset, "byteLength": pos_len,
                          "target": TARGET_ARRAY_BUFFER}),
        );
        views.push(
            json!({"buffer": 0, "byteOffset": idx_offset, "byteLength": idx_len,
                          "target": TARGET_ELEMENT_ARRAY_BUFFER}),
        );
        let pos_accessor = accessors.len();
        accessors.push(
            json!({"bufferView": pos_view, "componentType": COMPONENT_FLOAT,
                              "count": local_positions.len(), "type": "VEC3",
                              "min": min, "max": max}),
        );
        accessors.push(json!({"bufferView": pos_view + 1,
                              "componentType": COMPONENT_UNSIGNED_INT,
                              "count": indices.len(), "type": "SCALAR"}));
        primitives.push(json!({"attributes": {"POSITION": pos_accessor},
                               "indices": pos_accessor + 1, "material": material,
                               "mode": MODE_TRIANGLES}));
    }

    let asset = json!({"version": "2.0", "generator": "femto"});
    let doc = if primitives.is_empty() {
        // glTF forbids empty meshes and zero-length buffers: an empty scene stands for no mesh.
        json!({"asset": asset, "scene": 0, "scenes": [{"nodes": []}]})
    } else {
        let material_count = groups.keys().next_back().map_or(0, |&m| m as usize + 1);
        let materials: Vec<_> = (0..material_count)
            .map(|m| json!({"name": format!("material_{m}")}))
            .collect();
        json!({
            "asset": asset,
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": primitives}],
            "materials": materials,
            "accessors": accessors,
            "bufferViews": views,
            "buffers": [{"byteLength": bin.len()}],
        })
    };
    let mut json_bytes = serde_json::to_vec(&doc).map_err(|e| GlbError::Io {
        path: path.to_path_buf(),
        source: e.into(),
    })?;
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let bin_chunk = if bin.is_empty() { 0 } else { 8 + bin.len() };
    let total = 12 + 8 + json_bytes.len() + bin_chunk;
    let total_u32 = u32::try_from(total).map_err(|_| GlbError::TooLarge {
        path: path.to_path_buf(),
        bytes: total as u64,
    })?;

    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&GLB_MAGIC.to_le_bytes());
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total_u32.to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(&json_bytes);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
        out.extend_from_slice(&bin);
    }
    Ok(out)
}

/// The triangles of `mesh` grouped by material, in increasing material order; triangles
/// beyond the material list (a malformed mesh) get material 0.
fn material_groups(mesh: &TriangleMesh) -> BTreeMap<u32, Vec<usize>> {
    let mut groups: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (i, &m) in mesh.material.iter().enumerate().take(mesh.triangles.len()) {
        groups.entry(m).or_default().push(i);
    }
    // Triangles beyond the material list (a malformed mesh) get material 0.
    for i in mesh.material.len()..mesh.triangles.len() {
        groups.entry(0).or_default().push(i);
    }
    groups
}

/// The vertices the triangles `tris` of `mesh` use, compacted in order of first use, and
/// the triangles' corners as indices into them.
fn compact_vertices(mesh: &TriangleMesh, tris: &[usize]) -> (Vec<Point3<f32>>, Vec<u32>) {
    let mut remap: BTreeMap<u32, u32> = BTreeMap::new();
    let mut local_positions = Vec::new();
    let mut indices = Vec::with_capacity(3 * tris.len());
    for &t in tris {
        for &v in &mesh.triangles[t] {
            let next = remap.len() as u32;
            let local = *remap.entry(v).or_insert_with(|| {
                local_positions.push(mesh.positions[v as usize]);
                next
            });
            indices.push(local);
        }
    }
    (local_positions, indices)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh() -> TriangleMesh {
        TriangleMesh {
            positions: (0..5).map(|i| Point3::new(i as f32, 0.0, 0.0)).collect(),
            triangles: vec![[0, 1, 2], [2, 3, 4], [4, 1, 0]],
            // The third triangle has no material: 0.
            material: vec![3, 0],
        }
    }

    #[test]
    fn triangles_are_grouped_by_material_in_order() {
        let g = material_groups(&mesh());
        let groups: Vec<(u32, Vec<usize>)> = g.into_iter().collect();
        assert_eq!(groups, [(0, vec![1, 2]), (3, vec![0])]);
    }

    #[test]
    fn vertices_are_compacted_in_order_of_first_use() {
        let m = mesh();
        let (positions, indices) = compact_vertices(&m, &[1, 2]);
        let xs: Vec<f32> = positions.iter().map(|p| p.x).collect();
        assert_eq!(xs, [2.0, 3.0, 4.0, 1.0, 0.0]);
        assert_eq!(indices, [0, 1, 2, 2, 3, 4]);
        let (positions, indices) = compact_vertices(&m, &[0]);
        assert_eq!(positions.len(), 3);
        assert_eq!(indices, [0, 1, 2]);
    }
}
