//! Mesh files made ready for a scene: vertices welded so that closedness is judged on the
//! surface ([`welded`]), and a mesh fitted to a size on the floor ([`fit_mesh`]).

use super::TriangleMesh;
use nalgebra::{Matrix4, Vector3};

/// The mesh with vertices at bit-identical positions merged (files often repeat a vertex per
/// face or per normal), so that closedness is judged on the surface, not on the indexing.
pub fn welded(mesh: &TriangleMesh) -> TriangleMesh {
    let mut index: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let mut positions = Vec::new();
    let remap: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            *index
                .entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .or_insert_with(|| {
                    positions.push(*p);
                    (positions.len() - 1) as u32
                })
        })
        .collect();
    TriangleMesh {
        positions,
        triangles: mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| remap[i as usize]))
            .collect(),
        material: mesh.material.clone(),
    }
}

/// Centre the mesh's bounds in x and z, put its bottom at y = 0 and scale it uniformly so its
/// largest extent is `size_m`.
pub fn fit_mesh(mesh: &mut TriangleMesh, size_m: f64) {
    let b = mesh.bounds();
    let extent = b.max - b.min;
    let largest = extent.x.max(extent.y).max(extent.z) as f64;
    let s = if largest > 0.0 { size_m / largest } else { 1.0 };
    let shift = Vector3::new(
        -0.5 * (b.min.x + b.max.x) as f64,
        -b.min.y as f64,
        -0.5 * (b.min.z + b.max.z) as f64,
    );
    let m = Matrix4::new_scaling(s) * Matrix4::new_translation(&shift);
    mesh.transform(&m.cast::<f32>());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::primitives;

    #[test]
    fn file_meshes_are_welded_before_the_closedness_test_and_fitted() {
        // A box whose triangles each carry their own three vertices, as OBJ files often do.
        let shared = primitives::cuboid(Vector3::new(0.2, 0.4, 0.1));
        let mut split = TriangleMesh::default();
        for i in 0..shared.triangle_count() {
            let k = split.positions.len() as u32;
            split.positions.extend_from_slice(&shared.corners(i));
            split.triangles.push([k, k + 1, k + 2]);
            split.material.push(0);
        }
        assert!(!primitives::is_closed(&split));
        assert!(primitives::is_closed(&welded(&split)));
        // Fit: bottom at y = 0, centred in x and z, largest extent (y, 0.4) scaled to 0.1.
        let mut m = split.clone();
        m.transform(&Matrix4::new_translation(&Vector3::new(1.0, 2.0, 3.0)));
        fit_mesh(&mut m, 0.1);
        let b = m.bounds();
        assert!(b.min.y.abs() < 1e-6 && (b.max.y - 0.1).abs() < 1e-6);
        assert!((b.min.x + b.max.x).abs() < 1e-6 && (b.min.z + b.max.z).abs() < 1e-6);
        assert!((b.max.x - b.min.x - 0.05).abs() < 1e-6);
    }
}
