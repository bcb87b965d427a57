//! Fiducial candidates of primitive meshes: points a calibration can find in an image, in the
//! primitive's own frame. A quad offers its 4 corners and a 3 x 3 grid inside it, a box its 8
//! corners. Scenes place them with their mesh and keep those the camera sees
//! (`Scene::fiducials`).

use nalgebra::{Point3, Vector3};

/// Kind of a fiducial candidate within its mesh entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Candidate {
    /// Corner `k` of a quad (0..4, counter-clockwise from (-x, -y)) or a box (0..8, bit 1:
    /// +x, bit 2: +y, bit 4: +z).
    Corner(usize),
    /// Row and column of a quad's inner 3 x 3 grid, at quarters of its size.
    Grid(usize, usize),
}

impl Candidate {
    /// `corner<k>` or `grid<r><c>`.
    pub fn name(&self) -> String {
        match self {
            Candidate::Corner(i) => format!("corner{i}"),
            Candidate::Grid(r, c) => format!("grid{r}{c}"),
        }
    }
}

/// The corners and the 3 x 3 grid of a quad of `size_x` by `size_y` centred on the origin in
/// the z = 0 plane (as `primitives::quad` builds it).
pub fn quad_candidates(size_x: f64, size_y: f64) -> Vec<(Candidate, Point3<f64>)> {
    let (hx, hy) = (0.5 * size_x, 0.5 * size_y);
    let mut pts = Vec::new();
    for (c, (sx, sy)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .enumerate()
    {
        pts.push((Candidate::Corner(c), Point3::new(sx * hx, sy * hy, 0.0)));
    }
    for r in 0..3 {
        for c in 0..3 {
            let fx = (c as f64 + 1.0) / 4.0 * 2.0 - 1.0;
            let fy = (r as f64 + 1.0) / 4.0 * 2.0 - 1.0;
            pts.push((Candidate::Grid(r, c), Point3::new(fx * hx, fy * hy, 0.0)));
        }
    }
    pts
}

/// The 8 corners of a box of `size` centred on the origin (as `primitives::cuboid` builds it).
pub fn box_candidates(size: &Vector3<f64>) -> Vec<(Candidate, Point3<f64>)> {
    (0..8)
        .map(|c| {
            let s = |bit: usize| if c & bit != 0 { 0.5 } else { -0.5 };
            (
                Candidate::Corner(c),
                Point3::new(s(1) * size.x, s(2) * size.y, s(4) * size.z),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::primitives;

    #[test]
    fn quad_candidates_are_its_corners_and_a_grid_at_quarters() {
        let pts = quad_candidates(0.4, 0.2);
        assert_eq!(pts.len(), 13);
        let corners: Vec<_> = pts
            .iter()
            .filter(|(c, _)| matches!(c, Candidate::Corner(_)))
            .collect();
        assert_eq!(corners.len(), 4);
        // Every corner is a vertex of the quad primitive.
        let mesh = primitives::quad(0.4, 0.2);
        for (_, p) in &corners {
            assert!(mesh
                .positions
                .iter()
                .any(|v| (v.cast::<f64>() - p).norm() < 1e-6));
        }
        // The grid's centre is the quad's centre; its corners sit at a quarter of the size.
        let find = |k: Candidate| pts.iter().find(|(c, _)| *c == k).unwrap().1;
        assert!(find(Candidate::Grid(1, 1)).coords.norm() < 1e-12);
        let g = find(Candidate::Grid(2, 0));
        assert!((g - Point3::new(-0.1, 0.05, 0.0)).norm() < 1e-12, "{g}");
        assert_eq!(Candidate::Grid(2, 0).name(), "grid20");
        assert_eq!(Candidate::Corner(3).name(), "corner3");
    }

    #[test]
    fn box_candidates_are_the_vertices_of_the_cuboid() {
        let size = Vector3::new(0.1, 0.2, 0.3);
        let pts = box_candidates(&size);
        assert_eq!(pts.len(), 8);
        let mesh = primitives::cuboid(size.cast::<f32>());
        for (_, p) in &pts {
            assert!(p.x.abs() == 0.05 && p.y.abs() == 0.1 && p.z.abs() == 0.15);
            assert!(mesh
                .positions
                .iter()
                .any(|v| (v.cast::<f64>() - p).norm() < 1e-6));
        }
        // Bit 1 of the index is +x, bit 2 +y, bit 4 +z.
        assert_eq!(pts[5].1, Point3::new(0.05, -0.1, 0.15));
    }
}
