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
    /// The file could not be opened (missing, unreadable); checked before the extension.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
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
    /// A binary glTF whose header declares another length than the file has (glTF 2.0
    /// §4.4.2: `length` is the total length of the file), checked before anything is
    /// allocated by that length.
    #[error("{path}: GLB header declares {declared} bytes, but the file has {actual}")]
    GlbLength {
        path: PathBuf,
        declared: u32,
        actual: u64,
    },
    /// A glTF buffer URI that names something other than a regular file (a folder, a
    /// device, whose reading would not end) or whose percent-encoding is not UTF-8.
    #[error("{path}: glTF buffer {buffer}: uri {uri:?} {reason}")]
    BadBufferUri {
        path: PathBuf,
        buffer: usize,
        uri: String,
        reason: String,
    },
    /// An index that the glTF or OBJ reader would use before checking it (an accessor of a
    /// primitive, a face's vertex, texture or normal index far beyond the file).
    #[error("{path}: {part}: {what}")]
    BadReference {
        path: PathBuf,
        part: String,
        what: String,
    },
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
    // A missing file is an I/O error (with its OS error), not a reader's failure.
    std::fs::File::open(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
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
    check_obj_indices(path)?;
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
    let bytes = std::fs::read(path).map_err(|e| gltf_err(gltf::Error::Io(e)))?;
    check_glb_length(path, &bytes)?;
    // Buffers only: decoding textures would be wasted work and fails on missing image files.
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(gltf_err)?;
    check_primitive_accessors(path, document.as_json())?;
    let document = gltf::Document::from_json(document.into_json()).map_err(gltf_err)?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    check_buffer_files(path, &document, base)?;
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
                for accessor in prim.attributes().map(|(_, a)| a).chain(prim.indices()) {
                    check_accessor_span(path, &part, &accessor)?;
                }
                check_accessor_types(path, &part, &prim)?;
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

/// Refuse a face whose vertex, texture or normal index `tobj` would turn into a huge
/// `usize` and multiply unchecked (overflow): an index of 0 (OBJ counts from 1), a positive
/// index beyond the number of lines of the file (no statement can refer further,
/// `f 1/9223372036854775807/1`), or a negative (relative) index reaching before the first
/// position, texture coordinate or normal declared so far (`f 7/-3` after one `vt`). The
/// file is read lossily: `tobj` reads it line by line and meets a face line before it meets
/// a later line that is not UTF-8.
fn check_obj_indices(path: &Path) -> Result<(), LoadError> {
    let Ok(bytes) = std::fs::read(path) else {
        return Ok(()); // `tobj` reports the read error with its own words
    };
    let text = String::from_utf8_lossy(&bytes);
    let limit = text.lines().count() as u64;
    // Positions, texture coordinates and normals declared so far, in a face's `v/vt/vn` order.
    let mut declared = [0u64; 3];
    const KINDS: [&str; 3] = ["positions", "texture coordinates", "normals"];
    for (line_no, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("f" | "l" | "p") => {}
            Some(kind) => {
                if let Some(k) = ["v", "vt", "vn"].iter().position(|&d| d == kind) {
                    declared[k] += 1;
                }
                continue;
            }
            None => continue,
        }
        for word in words {
            for (kind, index) in word.split('/').enumerate().take(3) {
                if index.is_empty() {
                    continue;
                }
                let why = match index.parse::<i64>() {
                    Ok(0) => "OBJ counts from 1".to_string(),
                    Ok(i) if i > 0 && i as u64 > limit => {
                        format!("it is beyond the file's {limit} lines")
                    }
                    Ok(i) if i < 0 && i.unsigned_abs() > declared[kind] => format!(
                        "it reaches before the first of the {} {} declared so far",
                        declared[kind], KINDS[kind]
                    ),
                    Ok(_) => continue,
                    Err(_) if index.parse::<f64>().is_ok() => {
                        "it is not a 64-bit whole number".to_string()
                    }
                    Err(_) => continue, // not a number: `tobj` refuses the face
                };
                return Err(LoadError::BadReference {
                    path: path.to_path_buf(),
                    part: format!("line {}", line_no + 1),
                    what: format!("index {index}: {why}"),
                });
            }
        }
    }
    Ok(())
}

/// Refuse a primitive attribute that names an accessor the document does not have: the
/// glTF crate's validation indexes the accessor list with the `POSITION` index unchecked.
fn check_primitive_accessors(path: &Path, root: &gltf::json::Root) -> Result<(), LoadError> {
    let count = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let indices = prim.attributes.values().chain(prim.indices.iter());
            if let Some(bad) = indices.map(|i| i.value()).find(|&i| i >= count) {
                return Err(LoadError::BadReference {
                    path: path.to_path_buf(),
                    part: format!("mesh {m}, primitive {p}"),
                    what: format!("accessor {bad} does not exist (the file has {count})"),
                });
            }
        }
    }
    Ok(())
}

/// Refuse an accessor of no elements, whose buffer view leaves its buffer, or whose span
/// `offset + stride * (count - 1) + size` overflows or leaves its buffer view: the glTF
/// crate computes these unchecked.
fn check_accessor_span(
    path: &Path,
    part: &str,
    accessor: &gltf::Accessor,
) -> Result<(), LoadError> {
    let bad = |what: String| LoadError::BadReference {
        path: path.to_path_buf(),
        part: part.to_string(),
        what: format!("accessor {}: {what}", accessor.index()),
    };
    if accessor.count() == 0 {
        return Err(bad("count is 0".into()));
    }
    let size = accessor.size() as u64;
    if let Some(view) = accessor.view() {
        check_span(&view, accessor.offset(), accessor.count(), size).map_err(&bad)?;
    }
    if let Some(sparse) = accessor.sparse() {
        let count = sparse.count();
        if count == 0 {
            return Err(bad("sparse count is 0".into()));
        }
        let indices = sparse.indices();
        let index_size = indices.index_type().size() as u64;
        check_span(&indices.view(), indices.offset(), count, index_size)
            .map_err(|e| bad(format!("sparse indices: {e}")))?;
        let values = sparse.values();
        check_span(&values.view(), values.offset(), count, size)
            .map_err(|e| bad(format!("sparse values: {e}")))?;
    }
    Ok(())
}

/// Check that `count` elements of `size` bytes from byte `offset` of `view` fit the view,
/// and the view its buffer: `offset + stride * (count - 1) + size`, which the glTF crate
/// computes unchecked (as it adds the view's offset and length), must not overflow or leave
/// the view, and a stride below the element size (which the crate asserts in debug builds)
/// is refused. `count` is at least 1.
fn check_span(
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    size: u64,
) -> Result<(), String> {
    let view_end = (view.offset() as u64).checked_add(view.length() as u64);
    if view_end.is_none_or(|end| end > view.buffer().length() as u64) {
        return Err(format!(
            "buffer view {} ({} bytes from byte {}) leaves its {}-byte buffer",
            view.index(),
            view.length(),
            view.offset(),
            view.buffer().length()
        ));
    }
    let stride = view.stride().map_or(size, |s| s as u64);
    if stride < size {
        return Err(format!(
            "buffer view {} has a stride of {stride} bytes, less than its {size}-byte elements",
            view.index()
        ));
    }
    let end = (count as u64 - 1)
        .checked_mul(stride)
        .and_then(|v| v.checked_add(offset as u64))
        .and_then(|v| v.checked_add(size));
    match end {
        Some(end) if end <= view.length() as u64 => Ok(()),
        _ => Err(format!(
            "{count} elements of {size} bytes every {stride} from byte {offset} do not fit its {}-byte view",
            view.length()
        )),
    }
}

/// Refuse a `POSITION` accessor that is not `VEC3` of f32 and an `indices` accessor that is
/// not `SCALAR` of u8, u16 or u32, as glTF 2.0 requires: the glTF crate reads them as
/// `[f32; 3]` and integers whatever the accessor says (it asserts the element size only in
/// debug builds, and reaches `unreachable!()` for a float index type).
fn check_accessor_types(path: &Path, part: &str, prim: &gltf::Primitive) -> Result<(), LoadError> {
    use gltf::accessor::{DataType, Dimensions};
    let bad = |what: String| LoadError::BadReference {
        path: path.to_path_buf(),
        part: part.to_string(),
        what,
    };
    if let Some(pos) = prim.get(&gltf::Semantic::Positions) {
        if (pos.dimensions(), pos.data_type()) != (Dimensions::Vec3, DataType::F32) {
            return Err(bad(format!(
                "POSITION accessor {} holds {:?} of {:?} (VEC3 of f32)",
                pos.index(),
                pos.dimensions(),
                pos.data_type()
            )));
        }
    }
    if let Some(ix) = prim.indices() {
        let int = matches!(ix.data_type(), DataType::U8 | DataType::U16 | DataType::U32);
        if ix.dimensions() != Dimensions::Scalar || !int {
            return Err(bad(format!(
                "indices accessor {} holds {:?} of {:?} (SCALAR of u8, u16 or u32)",
                ix.index(),
                ix.dimensions(),
                ix.data_type()
            )));
        }
    }
    Ok(())
}

/// Refuse a binary glTF (`glTF` magic) whose header length is not the file's length.
///
/// `gltf::Gltf::open` allocates the header's length before reading (4 GB for a 2 kB file
/// that claims 0xFFFFFFF0 bytes) and underflows on a length below the 12-byte header; the
/// slice reader that [`load_gltf`] uses instead trusts the length too, so it is checked
/// here first.
fn check_glb_length(path: &Path, bytes: &[u8]) -> Result<(), LoadError> {
    if bytes.len() < 12 || &bytes[0..4] != b"glTF" {
        return Ok(()); // JSON glTF, or too short for gltf's own "not glTF" error
    }
    let declared = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if declared as u64 != bytes.len() as u64 {
        return Err(LoadError::GlbLength {
            path: path.to_path_buf(),
            declared,
            actual: bytes.len() as u64,
        });
    }
    Ok(())
}

/// Refuse buffer URIs that the glTF importer would follow into something other than a
/// regular file, or whose percent-decoding is not UTF-8 (the importer unwraps it and
/// panics). Mirrors `gltf::import`'s schemes: `data:` is inline, `file:` and `file://` name
/// a path as is, other schemes are refused by the importer, a relative reference is
/// percent-decoded and joined to the document's folder.
fn check_buffer_files(
    path: &Path,
    document: &gltf::Document,
    base: &Path,
) -> Result<(), LoadError> {
    for buffer in document.buffers() {
        let gltf::buffer::Source::Uri(uri) = buffer.source() else {
            continue;
        };
        let bad = |reason: &str| LoadError::BadBufferUri {
            path: path.to_path_buf(),
            buffer: buffer.index(),
            uri: uri.to_string(),
            reason: reason.to_string(),
        };
        let target = if uri.contains(':') {
            match uri
                .strip_prefix("file://")
                .or_else(|| uri.strip_prefix("file:"))
            {
                Some(rest) => PathBuf::from(rest),
                None => continue,
            }
        } else {
            let decoded = percent_decode(uri).ok_or_else(|| bad("is not UTF-8 once decoded"))?;
            base.join(decoded)
        };
        // A missing file is reported by the importer itself.
        if target.exists() && !target.is_file() {
            return Err(bad("is not a regular file"));
        }
    }
    Ok(())
}

/// `%XX` escapes decoded (other bytes kept), or `None` when the result is not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (b[i], b.get(i + 1).copied(), b.get(i + 2).copied()) {
            (b'%', Some(h), Some(l)) if hex(h).is_some() && hex(l).is_some() => {
                out.push((hex(h)? * 16 + hex(l)?) as u8);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
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
