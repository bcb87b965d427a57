//! Triangle meshes from files: Wavefront OBJ (via `tobj`) and glTF 2.0 (`.gltf` and `.glb`, via
//! `gltf`), resolved into one [`TriangleMesh`] in metres.
//!
//! glTF: every primitive of every mesh instanced by the default scene (or the first scene when
//! none is marked default), with the node transforms composed down the hierarchy
//! (`world_from_node = world_from_parent * parent_from_node`, glTF 2.0 §3.5.3). Primitives must
//! have mode `TRIANGLES`. A node whose world transform has a negative determinant mirrors its
//! meshes, which per §3.7.2.1 reverses their winding; the loader swaps two corners of each of
//! their triangles so that `(v1 - v0) x (v2 - v0)` still points out of the front face. The
//! material of a triangle is its primitive's material index (0 when the primitive has none).
//!
//! OBJ: all faces, triangulated, positions as written (OBJ has no unit; femto reads metres).
//! The material of a triangle is the `usemtl` material id (0 when none).
//!
//! Both readers check that indices are in range and positions finite before returning, so a
//! loaded mesh is always safe to hand to [`super::bvh::Bvh::new`].

use super::TriangleMesh;
use nalgebra::{Matrix4, Point3};
use std::path::{Path, PathBuf};

/// Failure to read a mesh file. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The extension is not one of `.obj`, `.gltf`, `.glb`.
    #[error("{path}: unsupported mesh format (expected .obj, .gltf or .glb)")]
    UnsupportedFormat { path: PathBuf },
    /// The OBJ reader failed (missing file, syntax error, index out of bounds).
    #[error("{path}: cannot read OBJ: {source}")]
    Obj {
        path: PathBuf,
        source: tobj::LoadError,
    },
    /// The glTF reader failed (missing file, invalid JSON or GLB, missing or short buffer).
    #[error("{path}: cannot read glTF: {source}")]
    Gltf { path: PathBuf, source: gltf::Error },
    /// The glTF document has no scene to take meshes from.
    #[error("{path}: glTF document has no scene")]
    NoScene { path: PathBuf },
    /// The node hierarchy loops back on itself.
    #[error("{path}: glTF node {node} is its own ancestor")]
    NodeCycle { path: PathBuf, node: usize },
    /// A primitive is not a triangle list (points, lines, strips or fans).
    #[error("{path}: mesh {mesh}, primitive {primitive}: mode {mode:?} is not supported (only TRIANGLES)")]
    NotTriangles {
        path: PathBuf,
        mesh: String,
        primitive: usize,
        mode: gltf::mesh::Mode,
    },
    /// A primitive lacks readable `POSITION` data.
    #[error("{path}: mesh {mesh}, primitive {primitive}: no readable POSITION accessor")]
    NoPositions {
        path: PathBuf,
        mesh: String,
        primitive: usize,
    },
    /// A primitive has an `indices` accessor whose data cannot be read.
    #[error("{path}: mesh {mesh}, primitive {primitive}: unreadable indices accessor")]
    BadIndices {
        path: PathBuf,
        mesh: String,
        primitive: usize,
    },
    /// The index list of a mesh or primitive is not a whole number of triangles.
    #[error("{path}: {part}: {count} indices is not a multiple of 3")]
    PartialTriangle {
        path: PathBuf,
        part: String,
        count: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("{path}: {part}: vertex index {index} out of range (it has {vertices} vertices)")]
    IndexOutOfRange {
        path: PathBuf,
        part: String,
        index: u32,
        vertices: usize,
    },
    /// A position (after transforms) is infinite or NaN.
    #[error("{path}: {part}: vertex {vertex} has a non-finite position")]
    NonFinite {
        path: PathBuf,
        part: String,
        vertex: usize,
    },
}

/// Read a triangle mesh from `path`, choosing the reader by extension (case-insensitive):
/// `.obj`, `.gltf` or `.glb`.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, LoadError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("obj") => load_obj(path),
        Some("gltf") | Some("glb") => load_gltf(path),
        _ => Err(LoadError::UnsupportedFormat {
            path: path.to_path_buf(),
        }),
    }
}

fn load_obj(path: &Path) -> Result<TriangleMesh, LoadError> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials only matter through their ids; a missing .mtl file is not an error here.
    let (models, _materials) = tobj::load_obj(path, &options).map_err(|source| LoadError::Obj {
        path: path.to_path_buf(),
        source,
    })?;
    let mut mesh = TriangleMesh::default();
    for model in &models {
        let m = &model.mesh;
        let part = format!("object {:?}", model.name);
        let positions: Vec<Point3<f32>> = m
            .positions
            .chunks_exact(3)
            .map(|c| Point3::new(c[0], c[1], c[2]))
            .collect();
        let material = m.material_id.unwrap_or(0) as u32;
        let piece = checked_piece(path, &part, positions, &m.indices)?;
        mesh.append(&piece, material);
    }
    Ok(mesh)
}

fn load_gltf(path: &Path) -> Result<TriangleMesh, LoadError> {
    let gltf_err = |source| LoadError::Gltf {
        path: path.to_path_buf(),
        source,
    };
    // Buffers only: decoding textures would be wasted work and fails on missing image files.
    let gltf::Gltf { document, blob } = gltf::Gltf::open(path).map_err(gltf_err)?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    let buffers = gltf::import_buffers(&document, Some(base), blob).map_err(gltf_err)?;
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| LoadError::NoScene {
            path: path.to_path_buf(),
        })?;

    let mut mesh = TriangleMesh::default();
    // (node, world_from_parent, depth): depth beyond the node count means a cycle.
    let mut stack: Vec<(gltf::Node, Matrix4<f32>, usize)> =
        scene.nodes().map(|n| (n, Matrix4::identity(), 0)).collect();
    stack.reverse();
    let node_count = document.nodes().len();
    while let Some((node, world_from_parent, depth)) = stack.pop() {
        if depth > node_count {
            return Err(LoadError::NodeCycle {
                path: path.to_path_buf(),
                node: node.index(),
            });
        }
        let world_from_node = world_from_parent * Matrix4::from(node.transform().matrix());
        if let Some(gmesh) = node.mesh() {
            let mirrored = world_from_node.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
            let name = match gmesh.name() {
                Some(n) => format!("{} ({n:?})", gmesh.index()),
                None => gmesh.index().to_string(),
            };
            for prim in gmesh.primitives() {
                let part = format!("mesh {name}, primitive {}", prim.index());
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    return Err(LoadError::NotTriangles {
                        path: path.to_path_buf(),
                        mesh: name,
                        primitive: prim.index(),
                        mode: prim.mode(),
                    });
                }
                let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let positions: Vec<Point3<f32>> = reader
                    .read_positions()
                    .ok_or_else(|| LoadError::NoPositions {
                        path: path.to_path_buf(),
                        mesh: name.clone(),
                        primitive: prim.index(),
                    })?
                    .map(|p| world_from_node.transform_point(&Point3::from(p)))
                    .collect();
                let indices: Vec<u32> = match (prim.indices(), reader.read_indices()) {
                    (_, Some(ix)) => ix.into_u32().collect(),
                    (None, None) => (0..positions.len() as u32).collect(),
                    (Some(_), None) => {
                        return Err(LoadError::BadIndices {
                            path: path.to_path_buf(),
                            mesh: name,
                            primitive: prim.index(),
                        })
                    }
                };
                let mut piece = checked_piece(path, &part, positions, &indices)?;
                if mirrored {
                    for t in &mut piece.triangles {
                        t.swap(1, 2);
                    }
                }
                let material = prim.material().index().unwrap_or(0) as u32;
                mesh.append(&piece, material);
            }
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world_from_node, depth + 1));
        }
    }
    Ok(mesh)
}

/// A mesh piece from positions and a flat index list, after checking that the indices form
/// whole triangles within range and that every position is finite.
fn checked_piece(
    path: &Path,
    part: &str,
    positions: Vec<Point3<f32>>,
    indices: &[u32],
) -> Result<TriangleMesh, LoadError> {
    if !indices.len().is_multiple_of(3) {
        return Err(LoadError::PartialTriangle {
            path: path.to_path_buf(),
            part: part.to_string(),
            count: indices.len(),
        });
    }
    if let Some(&index) = indices.iter().find(|&&i| i as usize >= positions.len()) {
        return Err(LoadError::IndexOutOfRange {
            path: path.to_path_buf(),
            part: part.to_string(),
            index,
            vertices: positions.len(),
        });
    }
    if let Some(vertex) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(LoadError::NonFinite {
            path: path.to_path_buf(),
            part: part.to_string(),
            vertex,
        });
    }
    let triangles = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect::<Vec<_>>();
    Ok(TriangleMesh {
        material: vec![0; triangles.len()],
        positions,
        triangles,
    })
}
