//! The describe stage as a library call (issue 15): `describe_file` returns typed figures of
//! a cube and its groups, a pyramid side file, a mesh and a streak image, expected values
//! computed here from what the test wrote; its errors name the file.

use femto::calibrate::register::Registration;
use femto::camera::{Calibration, Intrinsics, Pose};
use femto::container::{self, Provenance};
use femto::cube::{Cube, TimeAxis, TimeFrame};
use femto::formats::StreakImage;
use femto::pipeline::describe::{
    describe_file, DescribeOptions, Description, PrefixLayout, PyramidSummary, StoredNumber,
};
use femto::pipeline::pyramid::{pyramid_file, PyramidOptions};
use femto::pipeline::{Progress, Quiet, StageError};
use femto::store::registration::{registration_group, FitSummary};
use nalgebra::{Point3, Vector3};
use std::path::Path;
use std::sync::Mutex;

const AXIS: TimeAxis = TimeAxis {
    t0_ps: -12.5,
    dt_ps: 0.75,
    nt: 7,
};
const NX: usize = 5;
const NY: usize = 4;

/// A cube whose values are distinct, negative in places, NaN at one sample; pixels `i` with
/// `i % 3 != 0` valid.
fn test_cube() -> Cube {
    let mut c = finite_cube();
    c.profile_mut(NX - 1, NY - 1)[AXIS.nt - 1] = f32::NAN;
    c
}

/// [`test_cube`] without the NaN (the stages, `pyramid` among them, refuse a NaN).
fn finite_cube() -> Cube {
    let mut c = Cube::zeros(NX, NY, AXIS, TimeFrame::World);
    for y in 0..NY {
        for x in 0..NX {
            for (t, v) in c.profile_mut(x, y).iter_mut().enumerate() {
                *v = (y * 1000 + x * 10 + t) as f32 * 0.5 - 3.0;
            }
        }
    }
    c.mask = Some((0..NX * NY).map(|i| u8::from(i % 3 != 0)).collect());
    c
}

fn calibration() -> Calibration {
    Calibration {
        intrinsics: Intrinsics::from_vfov(NX, NY, 40.0),
        pose: Pose::look_at(
            Point3::new(0.5, 0.9, 1.6),
            Point3::new(0.0, 0.0, 0.0),
            Vector3::y(),
        )
        .unwrap(),
        t0_ps: 1234.5,
        time_scale: 1.0,
        laser_m: Point3::new(-0.4, 0.0, 0.3),
        eta: 1.0,
    }
}

/// Pixels `i` with `i % 2 == 1` see geometry at `1.5 + 0.1 i` metres.
fn registration() -> Registration {
    let px = NX * NY;
    let hit = |i: usize| i % 2 == 1;
    Registration {
        nx: NX,
        ny: NY,
        camera_m: Point3::new(0.5, 0.9, 1.6),
        point_m: vec![[0.0; 3]; px],
        dist_m: (0..px)
            .map(|i| {
                if hit(i) {
                    1.5 + 0.1 * i as f32
                } else {
                    f32::NAN
                }
            })
            .collect(),
        normal: vec![[0.0, 0.0, 1.0]; px],
        triangle: (0..px as u32).collect(),
        mask: (0..px).map(|i| u8::from(hit(i))).collect(),
    }
}

/// Records the passes and the last step reported.
#[derive(Default)]
struct Record(Mutex<Vec<(String, u64, u64)>>);

impl Progress for Record {
    fn start(&self, what: &str, len: u64) {
        self.0.lock().unwrap().push((what.to_string(), len, 0));
    }
    fn set(&self, done: u64) {
        if let Some(last) = self.0.lock().unwrap().last_mut() {
            last.2 = done;
        }
    }
}

fn describe(path: &Path) -> Description {
    describe_file(path, &DescribeOptions::default(), &Quiet).unwrap()
}

#[test]
fn a_cube_with_registration_and_pyramid_is_described_by_typed_figures() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let cube = test_cube();
    container::write_cube(
        &path,
        &cube,
        &Provenance::new("femto test").with_note("ingest.dark_frame", "dark.png"),
    )
    .unwrap();
    let fit = FitSummary {
        points: 30,
        outliers: 2,
        reprojection_rms_px: 0.7,
        time_samples: 10,
        time_inliers: 9,
        time_residual_rms_ps: 0.4,
    };
    let group = registration_group(&registration(), &calibration(), "scene.glb", Some(&fit));
    container::write_groups(&path, &[("registration", group)]).unwrap();
    let options = PyramidOptions {
        levels: Some(2),
        ..PyramidOptions::default()
    };
    // `pyramid` refuses the NaN: the pyramid of the finite twin, stored with this cube.
    let twin = dir.path().join("twin.h5");
    container::write_cube(&twin, &finite_cube(), &Provenance::new("femto test")).unwrap();
    pyramid_file(&twin, &options, &Quiet).unwrap();
    let group = container::read_group(&twin, "pyramid").unwrap();
    container::write_groups(&path, &[("pyramid", group)]).unwrap();

    let progress = Record::default();
    let d = describe_file(&path, &DescribeOptions::default(), &progress).unwrap();
    assert_eq!(
        *progress.0.lock().unwrap(),
        [("scanning".to_string(), NY as u64, NY as u64)]
    );
    let Description::Cube(d) = d else {
        panic!("not a cube: {d:?}")
    };
    assert_eq!(d.file, path);
    assert_eq!((d.meta.nx, d.meta.ny, d.meta.axis), (NX, NY, AXIS));
    assert_eq!(d.meta.frame, TimeFrame::World);
    assert_eq!(d.meta.groups, ["pyramid", "registration"]);
    assert!(d
        .meta
        .notes
        .contains(&("ingest.dark_frame".to_string(), "dark.png".to_string())));
    // The finite values' range, the NaN left out.
    let finite: Vec<f32> = cube
        .data
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let range = d.value_range.unwrap();
    assert_eq!(
        range.min,
        finite.iter().copied().fold(f32::INFINITY, f32::min)
    );
    assert_eq!(
        range.max,
        finite.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    );
    assert_eq!(range.max, (3 * 1000 + 4 * 10 + 5) as f32 * 0.5 - 3.0);
    // The NaN is counted and located, not refused.
    let (count, at) = d.non_finite.unwrap();
    assert_eq!(
        (count, at.x, at.y, at.bin),
        (1, NX - 1, NY - 1, AXIS.nt - 1)
    );
    assert!(at.value.is_nan());
    let valid = (0..NX * NY).filter(|i| i % 3 != 0).count();
    assert_eq!(d.mask, Some((valid, NX * NY)));

    let r = d.registration.as_ref().unwrap();
    assert_eq!(r.calibration, Ok(calibration()));
    assert_eq!(r.mesh.as_deref(), Some("scene.glb"));
    assert_eq!(r.pixels, NX * NY);
    assert_eq!(r.hit_pixels, Some(NX * NY / 2));
    assert_eq!(r.hit_fraction(), Some(0.5));
    let dist = r.dist_m.unwrap();
    assert_eq!((dist.min, dist.max), (1.5 + 0.1, 1.5 + 0.1 * 19.0));
    let f = r.fit.as_ref().unwrap();
    assert_eq!(f.points, Some(StoredNumber::Int(30)));
    assert_eq!(f.outliers, Some(StoredNumber::Int(2)));
    assert_eq!(f.reprojection_rms_px, Some(StoredNumber::Float(0.7)));
    assert_eq!(f.time_inliers, Some(StoredNumber::Int(9)));
    assert!(r.datasets.iter().any(|n| n == "dist_m"));

    let PyramidSummary::Readable {
        info,
        prefix,
        matches_cube,
    } = d.pyramid.as_ref().unwrap()
    else {
        panic!("unreadable pyramid: {:?}", d.pyramid)
    };
    assert_eq!((info.levels, info.axis), (2, AXIS));
    assert_eq!(info.level_nts(), [4, 2]);
    assert_eq!(*matches_cube, Some(true));
    assert_eq!(
        *prefix,
        PrefixLayout::TwoLevel {
            coarse_shape: [NY, NX, 1],
            fine_shape: [NY, NX, AXIS.nt + 1],
        }
    );
    // The JSON carries the same figures.
    let j = Description::Cube(d.clone()).to_json();
    assert_eq!(j["kind"], "cube");
    assert_eq!(j["registration"]["hit_fraction"], 0.5);
    assert_eq!(j["pyramid"]["level_nt"], serde_json::json!([4, 2]));
    assert_eq!(j["pyramid"]["error"], serde_json::Value::Null);
}

#[test]
fn a_side_file_and_a_stale_pyramid_are_told_apart() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let side = dir.path().join("pyr.h5");
    container::write_cube(&path, &finite_cube(), &Provenance::new("femto test")).unwrap();
    let options = PyramidOptions {
        side_file: Some(side.clone()),
        ..PyramidOptions::default()
    };
    pyramid_file(&path, &options, &Quiet).unwrap();
    let Description::PyramidSideFile(s) = describe(&side) else {
        panic!("not a side file")
    };
    assert_eq!(s.groups, ["pyramid"]);
    let PyramidSummary::Readable {
        info, matches_cube, ..
    } = &s.pyramid
    else {
        panic!("unreadable: {:?}", s.pyramid)
    };
    assert_eq!(info.levels, 3, "all levels: 7 bins down to 1");
    assert_eq!(*matches_cube, None, "no cube to compare with");

    // The pyramid of another cube, stored with this one: stale.
    let mut other = finite_cube();
    other.axis.dt_ps = 1.0;
    let other_path = dir.path().join("other.h5");
    container::write_cube(&other_path, &other, &Provenance::new("femto test")).unwrap();
    pyramid_file(&other_path, &PyramidOptions::default(), &Quiet).unwrap();
    let group = container::read_group(&other_path, "pyramid").unwrap();
    container::write_groups(&path, &[("pyramid", group)]).unwrap();
    let Description::Cube(c) = describe(&path) else {
        panic!("not a cube")
    };
    assert!(matches!(
        c.pyramid,
        Some(PyramidSummary::Readable {
            matches_cube: Some(false),
            ..
        })
    ));
}

#[test]
fn a_streak_image_is_described_as_read_and_transposed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("line.exr");
    let data = vec![1.5, -2.0, 0.25, f32::NAN, 4.0, 0.0];
    femto::formats::raster::write_exr_f32(&path, &StreakImage::new(3, 2, data)).unwrap();
    let Description::StreakImage(s) = describe(&path) else {
        panic!("not a streak image")
    };
    assert_eq!((s.nx, s.nt, s.format.as_str()), (3, 2, "exr"));
    let r = s.value_range.unwrap();
    assert_eq!((r.min, r.max), (-2.0, 4.0));
    assert_eq!(s.saturated_pixels, None, "float samples do not saturate");
    assert!(s.time_axis.is_none() && s.img.is_none());
    assert!(format!("{s}").contains("3 x 2 (nx, nt): x across, time down"));

    let options = DescribeOptions {
        transpose: true,
        ..Default::default()
    };
    let Description::StreakImage(t) = describe_file(&path, &options, &Quiet).unwrap() else {
        panic!("not a streak image")
    };
    assert_eq!((t.nx, t.nt), (2, 3));
    assert_eq!(t.value_range, s.value_range);
    assert!(format!("{t}").contains("2 x 3 (nx, nt): time across, x down"));
    let j = Description::StreakImage(t).to_json();
    assert_eq!((j["nx"].as_u64(), j["nt"].as_u64()), (Some(2), Some(3)));
}

#[test]
fn a_mesh_is_described_per_material() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.obj");
    // Three right triangles with unit legs, 0.5 m^2 each.
    std::fs::write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl a\nf 1 2 3\nusemtl b\nf 1 2 4\nf 1 3 4\n",
    )
    .unwrap();
    let Description::Mesh(m) = describe(&path) else {
        panic!("not a mesh")
    };
    assert_eq!((m.triangles, m.vertices), (3, 4));
    let b = m.bounds_m.unwrap();
    assert_eq!(
        (b.min, b.max),
        (Point3::origin(), Point3::new(1.0, 1.0, 1.0))
    );
    assert_eq!(m.surface_area_m2, 1.5);
    let per_material: usize = m.materials.iter().map(|x| x.triangles).sum();
    assert_eq!(per_material, 3);
}

#[test]
fn errors_name_the_file_once() {
    let dir = tempfile::tempdir().unwrap();
    let txt = dir.path().join("notes.txt");
    std::fs::write(&txt, "hello").unwrap();
    let png = dir.path().join("bad.png");
    std::fs::write(&png, "not a png").unwrap();
    let missing = dir.path().join("missing.h5");
    let err = |p: &Path| describe_file(p, &DescribeOptions::default(), &Quiet).unwrap_err();

    let e = err(&txt);
    assert!(matches!(e, StageError::Input { .. }), "{e:?}");
    // The refusal lists what femto reads (issue 44).
    let text = e.to_string();
    assert!(
        text.contains("not a file femto reads") && text.contains("femto cubes (.h5)"),
        "{e}"
    );
    assert!(text.contains(".ptu") && text.contains(".npz"), "{e}");
    let e = err(&missing);
    assert!(matches!(e, StageError::Io { .. }), "{e:?}");
    let e = err(&png);
    assert!(matches!(e, StageError::Input { .. }), "{e:?}");
    for (p, e) in [(&txt, err(&txt)), (&missing, err(&missing)), (&png, e)] {
        let text = e.to_string();
        let name = p.display().to_string();
        assert!(text.starts_with(&format!("{name}: ")), "{text}");
        assert_eq!(text.matches(&name).count(), 1, "{text}");
    }
}
