//! The HDF5 cube container: round trips, the documented on-disk layout (checked through the
//! HDF5 crate alone), atomic writes, slab streaming, extra groups, and `femto info`.

use femto::container::{
    self, AttrValue, ContainerError, CubeReader, CubeWriter, DataBuf, GroupData, Provenance,
};
use femto::cube::{Cube, TimeAxis, TimeFrame};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use std::path::Path;
#[path = "common/cli.rs"]
mod cli;
use cli::FemtoCmd;

const AXIS: TimeAxis = TimeAxis {
    t0_ps: -12.5,
    dt_ps: 0.75,
    nt: 7,
};

/// The value the test cubes hold at `(x, y, t)`: distinct everywhere, negative in places.
fn value(x: usize, y: usize, t: usize) -> f32 {
    (y * 1000 + x * 10 + t) as f32 * 0.5 - 3.0
}

fn test_cube(nx: usize, ny: usize, with_mask: bool) -> Cube {
    let mut c = Cube::zeros(nx, ny, AXIS, TimeFrame::World);
    for y in 0..ny {
        for x in 0..nx {
            for (t, v) in c.profile_mut(x, y).iter_mut().enumerate() {
                *v = value(x, y, t);
            }
        }
    }
    if with_mask {
        c.mask = Some((0..nx * ny).map(|i| u8::from(i % 3 != 0)).collect());
    }
    c
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn provenance() -> Provenance {
    Provenance::new("femto ingest caps/*.png -o cube.h5")
        .with_note("ingest.dark_frame", "dark.png")
        .with_note("ingest.sources", "caps/000.png .. caps/009.png")
}

#[test]
fn round_trip_keeps_values_mask_and_provenance() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let cube = test_cube(5, 4, true);
    container::write_cube_with_units(&path, &cube, "photons", &provenance()).unwrap();
    assert_eq!(container::read_cube(&path).unwrap(), cube);

    let meta = container::read_meta(&path).unwrap();
    assert_eq!((meta.nx, meta.ny, meta.axis), (5, 4, AXIS));
    assert_eq!(meta.frame, TimeFrame::World);
    assert_eq!(meta.units, "photons");
    assert_eq!(
        meta.femto_version.as_deref(),
        Some(env!("CARGO_PKG_VERSION"))
    );
    assert_eq!(
        meta.command_line.as_deref(),
        Some("femto ingest caps/*.png -o cube.h5")
    );
    assert_eq!(meta.notes, provenance().notes);
    assert!(meta.has_mask);
    assert!(meta.groups.is_empty());
    assert_eq!(meta.size_bytes(), 5 * 4 * 7 * 4 + 5 * 4);
    assert_eq!(files_in(dir.path()), ["cube.h5"]);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o644, "an ordinary file, not tempfile's 0600");
    }

    // Without a mask, and with the default units.
    let plain = test_cube(3, 2, false);
    container::write_cube(&path, &plain, &Provenance::new("x")).unwrap();
    let back = container::read_cube(&path).unwrap();
    assert_eq!(back, plain);
    let meta = container::read_meta(&path).unwrap();
    assert!(!meta.has_mask);
    assert_eq!(meta.units, container::DEFAULT_UNITS);
    assert!(meta.notes.is_empty());
}

#[test]
fn raw_datasets_match_the_documented_layout() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let (nx, ny) = (6, 3);
    let cube = test_cube(nx, ny, true);
    container::write_cube(&path, &cube, &provenance()).unwrap();

    // Read back through the HDF5 crate alone, following docs/cube-format.md.
    let f = rust_hdf5::H5File::open(&path).unwrap();
    let ds = f.dataset("cube").unwrap();
    assert_eq!(ds.shape(), vec![ny, nx, AXIS.nt]);
    let raw: Vec<f32> = ds.read_raw().unwrap();
    for y in 0..ny {
        for x in 0..nx {
            for t in 0..AXIS.nt {
                assert_eq!(raw[(y * nx + x) * AXIS.nt + t], value(x, y, t));
            }
        }
    }
    assert!(ds.is_chunked());
    let chunk = ds.chunk_dims().unwrap();
    assert_eq!((chunk[0], chunk[2]), (1, AXIS.nt));
    let ids: Vec<u16> = ds.filters().unwrap().iter().map(|f| f.id).collect();
    assert_eq!(ids, [2, 1], "shuffle (2) then deflate (1)");

    let num = |name: &str| ds.attr(name).unwrap().read_numeric::<f64>().unwrap();
    let text = |name: &str| ds.attr(name).unwrap().read_string().unwrap();
    assert_eq!(num("t0_ps"), AXIS.t0_ps);
    assert_eq!(num("dt_ps"), AXIS.dt_ps);
    assert_eq!(text("time_frame"), "world");
    assert_eq!(text("units"), "arbitrary");
    assert_eq!(text("femto_version"), env!("CARGO_PKG_VERSION"));
    assert_eq!(text("command_line"), "femto ingest caps/*.png -o cube.h5");
    assert_eq!(text("ingest.dark_frame"), "dark.png");

    let mask = f.dataset("mask").unwrap();
    assert_eq!(mask.shape(), vec![ny, nx]);
    let m: Vec<u8> = mask.read_raw().unwrap();
    assert_eq!(
        m,
        (0..nx * ny)
            .map(|i| u8::from(i % 3 != 0))
            .collect::<Vec<_>>()
    );
}

#[test]
fn reads_a_cube_written_by_another_tool() {
    // Written as an h5py user would, from the documentation: contiguous storage, integer
    // t0_ps, no provenance, no mask.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("other.h5");
    let (nx, ny, nt) = (2, 3, 4);
    let data: Vec<f32> = (0..nx * ny * nt).map(|i| i as f32).collect();
    {
        let f = rust_hdf5::H5File::create(&path).unwrap();
        let ds = f
            .new_dataset::<f32>()
            .shape([ny, nx, nt])
            .create("cube")
            .unwrap();
        ds.write_raw(&data).unwrap();
        ds.new_attr::<i64>()
            .shape(())
            .create("t0_ps")
            .unwrap()
            .write_numeric(&100i64)
            .unwrap();
        ds.new_attr::<f64>()
            .shape(())
            .create("dt_ps")
            .unwrap()
            .write_numeric(&2.0f64)
            .unwrap();
        for (k, v) in [
            ("time_frame", "camera"),
            ("units", "counts"),
            ("operator", "me"),
        ] {
            ds.new_attr::<rust_hdf5::VarLenUnicode>()
                .shape(())
                .create(k)
                .unwrap()
                .write_string(v)
                .unwrap();
        }
        f.close().unwrap();
    }
    let cube = container::read_cube(&path).unwrap();
    assert_eq!((cube.nx, cube.ny, cube.nt()), (nx, ny, nt));
    assert_eq!(cube.axis.t0_ps, 100.0);
    assert_eq!(cube.frame, TimeFrame::Camera);
    assert_eq!(cube.profile(1, 2), &[20.0, 21.0, 22.0, 23.0]);
    assert_eq!(cube.mask, None);
    let meta = container::read_meta(&path).unwrap();
    assert_eq!(meta.femto_version, None);
    assert_eq!(meta.notes, [("operator".to_string(), "me".to_string())]);
}

#[test]
fn failed_writes_leave_no_file_and_keep_the_old_one() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let old = test_cube(4, 3, false);
    container::write_cube(&path, &old, &Provenance::new("old")).unwrap();
    let old_bytes = std::fs::read(&path).unwrap();
    let check_untouched = || {
        assert_eq!(std::fs::read(&path).unwrap(), old_bytes);
        assert_eq!(files_in(dir.path()), ["cube.h5"]);
    };

    // A streaming writer dropped half-way.
    {
        let mut w = CubeWriter::create(
            &path,
            4,
            3,
            AXIS,
            TimeFrame::Camera,
            "x",
            &Provenance::new("new"),
        )
        .unwrap();
        w.write_rows(0, &[1.0; 4 * AXIS.nt]).unwrap();
        assert_eq!(
            files_in(dir.path()).len(),
            2,
            "the temporary file exists meanwhile"
        );
    }
    check_untouched();

    // A writer finished with rows missing.
    let mut w = CubeWriter::create(
        &path,
        4,
        3,
        AXIS,
        TimeFrame::Camera,
        "x",
        &Provenance::new(""),
    )
    .unwrap();
    w.write_rows(1, &vec![1.0; 2 * 4 * AXIS.nt]).unwrap();
    let err = w.finish().unwrap_err();
    assert!(err.to_string().contains("row 0"), "{err}");
    assert!(err.to_string().contains("cube.h5"), "{err}");
    check_untouched();

    // Bad input rejected: a note that would overwrite a schema attribute, a data buffer of
    // the wrong length, a slab past the last row.
    let bad = Provenance::new("new").with_note("t0_ps", "0");
    assert!(container::write_cube(&path, &test_cube(4, 3, false), &bad).is_err());
    let mut short = test_cube(4, 3, false);
    short.data.pop();
    assert!(container::write_cube(&path, &short, &Provenance::new("")).is_err());
    let mut w = CubeWriter::create(
        &path,
        4,
        3,
        AXIS,
        TimeFrame::Camera,
        "x",
        &Provenance::new(""),
    )
    .unwrap();
    assert!(w.write_rows(2, &vec![0.0; 2 * 4 * AXIS.nt]).is_err());
    assert!(w.write_rows(0, &[0.0; 4 * AXIS.nt + 1]).is_err());
    drop(w);
    check_untouched();
    assert_eq!(container::read_cube(&path).unwrap(), old);

    // A folder that does not exist.
    let missing = dir.path().join("no/such/dir/cube.h5");
    let err = container::write_cube(&missing, &old, &Provenance::new("")).unwrap_err();
    assert!(matches!(err, ContainerError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("no/such/dir/cube.h5"), "{err}");

    // A folder that disappears before the writer finishes.
    let gone = dir.path().join("gone");
    std::fs::create_dir(&gone).unwrap();
    let target = gone.join("cube.h5");
    let mut w = CubeWriter::create(
        &target,
        4,
        1,
        AXIS,
        TimeFrame::Camera,
        "x",
        &Provenance::new(""),
    )
    .unwrap();
    w.write_rows(0, &[0.0; 4 * AXIS.nt]).unwrap();
    std::fs::remove_dir_all(&gone).unwrap();
    assert!(w.finish().is_err());
    assert!(!target.exists());
    check_untouched();
}

#[test]
fn slabs_stream_in_any_order() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let (nx, ny) = (9, 23);
    let expected = test_cube(nx, ny, true);
    let row_len = nx * AXIS.nt;
    // Slabs of 1, 2 or 3 rows, written in a shuffled order.
    let mut slabs = Vec::new();
    let mut y = 0;
    while y < ny {
        let n = (1 + y % 3).min(ny - y);
        slabs.push((y, n));
        y += n;
    }
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    slabs.shuffle(&mut rng);
    let mut w = CubeWriter::create(
        &path,
        nx,
        ny,
        AXIS,
        TimeFrame::World,
        "arbitrary",
        &provenance(),
    )
    .unwrap();
    for &(y0, n) in &slabs {
        w.write_rows(y0, &expected.data[y0 * row_len..(y0 + n) * row_len])
            .unwrap();
    }
    w.write_mask(expected.mask.as_ref().unwrap()).unwrap();
    w.finish().unwrap();

    let r = CubeReader::open(&path).unwrap();
    assert_eq!(r.meta().notes, provenance().notes);
    slabs.shuffle(&mut rng);
    for &(y0, n) in &slabs {
        let rows = r.read_rows(y0, n).unwrap();
        assert_eq!(rows, &expected.data[y0 * row_len..(y0 + n) * row_len]);
    }
    assert!(r.read_rows(ny - 1, 2).is_err());
    assert_eq!(r.read_cube().unwrap(), expected);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o644, "an ordinary file, not tempfile's 0600");
    }
    // The streamed range equals the range of the closed form.
    let (lo, hi) = r.value_range(&|_| {}).unwrap().unwrap();
    assert_eq!(
        (lo, hi),
        (value(0, 0, 0), value(nx - 1, ny - 1, AXIS.nt - 1))
    );
}

fn registration(nx: usize, ny: usize, scale: f32) -> GroupData {
    let px = nx * ny;
    GroupData {
        attrs: vec![
            ("fx".into(), AttrValue::F64(812.25)),
            ("width".into(), AttrValue::I64(nx as i64)),
            (
                "calibration".into(),
                AttrValue::Str("[intrinsics]\nfx = 812.25\n".into()),
            ),
            (
                "position_m".into(),
                AttrValue::F64Array(vec![0.5, -1.0, 2.0]),
            ),
        ],
        datasets: vec![
            (
                "point_m".into(),
                vec![ny, nx, 3],
                DataBuf::F32((0..px * 3).map(|i| i as f32 * scale).collect()),
            ),
            (
                "triangle".into(),
                vec![ny, nx],
                DataBuf::U32((0..px as u32).map(|i| i * 7).collect()),
            ),
            (
                "mask".into(),
                vec![ny, nx],
                DataBuf::U8((0..px).map(|i| (i % 2) as u8).collect()),
            ),
            (
                "offset".into(),
                vec![px],
                DataBuf::I32((0..px as i32).map(|i| -i).collect()),
            ),
        ],
    }
}

fn sorted(mut g: GroupData) -> GroupData {
    g.datasets.sort_by(|a, b| a.0.cmp(&b.0));
    g
}

#[test]
fn groups_are_added_and_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let (nx, ny) = (5, 4);
    let cube = test_cube(nx, ny, true);
    container::write_cube(&path, &cube, &provenance()).unwrap();

    let reg = registration(nx, ny, 0.5);
    container::write_groups(&path, &[("registration", reg.clone())]).unwrap();
    let pyramid = GroupData {
        attrs: vec![("levels".into(), AttrValue::I64(2))],
        datasets: vec![(
            "level0".into(),
            vec![3, 2],
            DataBuf::F64(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
        )],
    };
    container::write_groups(&path, &[("pyramid", pyramid.clone())]).unwrap();

    assert_eq!(
        container::list_groups(&path).unwrap(),
        ["pyramid", "registration"]
    );
    assert_eq!(
        container::read_group(&path, "registration").unwrap(),
        sorted(reg)
    );
    assert_eq!(container::read_group(&path, "pyramid").unwrap(), pyramid);
    // The cube, its mask and its provenance were carried over.
    assert_eq!(container::read_cube(&path).unwrap(), cube);
    assert_eq!(
        container::read_meta(&path).unwrap().notes,
        provenance().notes
    );

    // Replace one group; the other stays.
    let reg2 = registration(nx, ny, -2.0);
    container::write_groups(&path, &[("registration", reg2.clone())]).unwrap();
    assert_eq!(
        container::read_group(&path, "registration").unwrap(),
        sorted(reg2)
    );
    assert_eq!(container::read_group(&path, "pyramid").unwrap(), pyramid);
    assert_eq!(files_in(dir.path()), ["cube.h5"]);

    // Row access to one dataset of a group.
    let r = CubeReader::open(&path).unwrap();
    assert_eq!(
        r.group_dataset_shape("registration", "point_m").unwrap(),
        (vec![ny, nx, 3], "f32")
    );
    let rows = r.read_group_rows("registration", "point_m", 1, 2).unwrap();
    let first = nx * 3;
    let want: Vec<f32> = (first..first + 2 * nx * 3)
        .map(|i| i as f32 * -2.0)
        .collect();
    assert_eq!(rows, DataBuf::F32(want));
    assert!(r.read_group_rows("registration", "point_m", 3, 2).is_err());
    assert!(matches!(
        r.read_group("nope"),
        Err(ContainerError::NoGroup { .. })
    ));

    // Invalid groups are refused and leave the file as it was.
    let before = std::fs::read(&path).unwrap();
    let bad_shape = GroupData {
        attrs: vec![],
        datasets: vec![("d".into(), vec![2, 2], DataBuf::U8(vec![1, 2, 3]))],
    };
    assert!(container::write_groups(&path, &[("g", bad_shape)]).is_err());
    assert!(container::write_groups(&path, &[("cube", GroupData::default())]).is_err());
    assert_eq!(std::fs::read(&path).unwrap(), before);
}

#[test]
fn errors_name_the_file_and_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("image.png");
    std::fs::write(&png, b"\x89PNG\r\n\x1a\n0000000000000000").unwrap();
    let err = container::read_cube(&png).unwrap_err();
    assert!(matches!(err, ContainerError::NotHdf5 { .. }), "{err:?}");
    assert!(err.to_string().contains("image.png"));

    let missing = dir.path().join("missing.h5");
    let err = container::read_meta(&missing).unwrap_err();
    assert!(matches!(err, ContainerError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("missing.h5"));

    // HDF5 files that break the schema one way each.
    let write = |name: &str, f: &dyn Fn(&rust_hdf5::H5File)| {
        let p = dir.path().join(name);
        let file = rust_hdf5::H5File::create(&p).unwrap();
        f(&file);
        file.close().unwrap();
        p
    };
    let str_attr = |ds: &rust_hdf5::H5Dataset, k: &str, v: &str| {
        ds.new_attr::<rust_hdf5::VarLenUnicode>()
            .shape(())
            .create(k)
            .unwrap()
            .write_string(v)
            .unwrap();
    };
    let f64_attr = |ds: &rust_hdf5::H5Dataset, k: &str, v: f64| {
        ds.new_attr::<f64>()
            .shape(())
            .create(k)
            .unwrap()
            .write_numeric(&v)
            .unwrap();
    };
    let no_cube = write("nocube.h5", &|f| {
        let ds = f.new_dataset::<f32>().shape([2]).create("other").unwrap();
        ds.write_raw(&[0.0f32, 1.0]).unwrap();
    });
    let err = container::read_cube(&no_cube).unwrap_err();
    assert!(matches!(err, ContainerError::NoCube { .. }), "{err:?}");

    let rank2 = write("rank2.h5", &|f| {
        let ds = f.new_dataset::<f32>().shape([2, 2]).create("cube").unwrap();
        ds.write_raw(&[0.0f32; 4]).unwrap();
    });
    let err = container::read_cube(&rank2).unwrap_err();
    assert!(
        matches!(err, ContainerError::WrongRank { found: 2, .. }),
        "{err:?}"
    );

    let f64_cube = write("f64.h5", &|f| {
        let ds = f
            .new_dataset::<f64>()
            .shape([1, 1, 2])
            .create("cube")
            .unwrap();
        ds.write_raw(&[0.0f64; 2]).unwrap();
    });
    let err = container::read_cube(&f64_cube).unwrap_err();
    assert!(err.to_string().contains("f64"), "{err}");

    let cube_with = |name: &str, frame: Option<&str>| {
        write(name, &|f| {
            let ds = f
                .new_dataset::<f32>()
                .shape([1, 1, 2])
                .create("cube")
                .unwrap();
            ds.write_raw(&[0.0f32; 2]).unwrap();
            f64_attr(&ds, "t0_ps", 0.0);
            f64_attr(&ds, "dt_ps", 1.0);
            str_attr(&ds, "units", "x");
            if let Some(fr) = frame {
                str_attr(&ds, "time_frame", fr);
            }
        })
    };
    let err = container::read_cube(&cube_with("noframe.h5", None)).unwrap_err();
    assert!(
        matches!(err, ContainerError::MissingAttribute { .. }),
        "{err:?}"
    );
    assert!(err.to_string().contains("time_frame"), "{err}");
    let err = container::read_cube(&cube_with("badframe.h5", Some("lab"))).unwrap_err();
    assert!(
        matches!(err, ContainerError::BadAttribute { .. }),
        "{err:?}"
    );
    assert!(err.to_string().contains("lab") && err.to_string().contains("badframe.h5"));
}

#[test]
fn image_stacks_of_any_numeric_type_become_f32() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("stack.h5");
    let u16s: Vec<u16> = (0..24).map(|i| i * 1000).collect();
    let f64s: Vec<f64> = (0..24).map(|i| i as f64 * -0.25).collect();
    {
        let f = rust_hdf5::H5File::create(&path).unwrap();
        let g = f.create_group("scan").unwrap();
        g.new_dataset::<u16>()
            .shape([2, 3, 4])
            .create("frames")
            .unwrap()
            .write_raw(&u16s)
            .unwrap();
        f.new_dataset::<f64>()
            .shape([4, 3, 2])
            .create("f")
            .unwrap()
            .write_raw(&f64s)
            .unwrap();
        f.new_dataset::<i64>()
            .shape([1, 1, 1])
            .create("wide")
            .unwrap()
            .write_raw(&[5i64])
            .unwrap();
        f.close().unwrap();
    }
    let (shape, v) = container::read_image_stack(&path, "scan/frames").unwrap();
    assert_eq!(shape, [2, 3, 4]);
    assert_eq!(v, u16s.iter().map(|&x| x as f32).collect::<Vec<_>>());
    let (shape, v) = container::read_image_stack(&path, "/f").unwrap();
    assert_eq!(shape, [4, 3, 2]);
    assert_eq!(v, f64s.iter().map(|&x| x as f32).collect::<Vec<_>>());
    let err = container::read_image_stack(&path, "wide").unwrap_err();
    assert!(err.to_string().contains("stack.h5") && err.to_string().contains("wide"));
    let err = container::read_image_stack(&path, "absent").unwrap_err();
    assert!(matches!(err, ContainerError::NoDataset { .. }), "{err:?}");
    assert!(err.to_string().contains("absent"));
}

#[test]
fn info_describes_a_cube_as_json() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let (nx, ny) = (5, 4);
    container::write_cube(&path, &test_cube(nx, ny, true), &provenance()).unwrap();
    container::write_groups(&path, &[("registration", registration(nx, ny, 1.0))]).unwrap();

    let out = FemtoCmd::new()
        .args(["info", path.to_str().unwrap(), "--json"])
        .output();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(
        text.trim().lines().count(),
        1,
        "one JSON object on one line"
    );
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(j["kind"], "cube");
    assert_eq!(j["shape"]["ny"], ny);
    assert_eq!(j["shape"]["nx"], nx);
    assert_eq!(j["shape"]["nt"], AXIS.nt);
    assert_eq!(j["time_axis"]["t0_ps"], AXIS.t0_ps);
    assert_eq!(j["time_axis"]["dt_ps"], AXIS.dt_ps);
    assert_eq!(
        j["time_axis"]["end_ps"],
        AXIS.t0_ps + AXIS.nt as f64 * AXIS.dt_ps
    );
    assert_eq!(j["time_axis"]["unit"], "ps");
    assert_eq!(j["time_frame"], "world");
    assert_eq!(j["value_range"]["min"], value(0, 0, 0) as f64);
    assert_eq!(
        j["value_range"]["max"],
        value(nx - 1, ny - 1, AXIS.nt - 1) as f64
    );
    // Pixels i with i % 3 != 0 are valid.
    let valid = (0..nx * ny).filter(|i| i % 3 != 0).count();
    assert_eq!(j["mask"]["valid_pixels"], valid);
    assert_eq!(j["mask"]["pixels"], nx * ny);
    assert_eq!(j["size_bytes"], nx * ny * AXIS.nt * 4 + nx * ny);
    assert_eq!(j["groups"], serde_json::json!(["registration"]));
    assert_eq!(j["femto_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(j["notes"]["ingest.dark_frame"], "dark.png");

    let out = FemtoCmd::new()
        .args(["info", path.to_str().unwrap()])
        .output();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("world") && text.contains("registration"),
        "{text}"
    );
}

/// Issue 29: `femto info` prints a summary (long lists counted with their range, numbers
/// rounded); `--full` prints every stored value, `--json` too.
#[test]
fn info_summarises_long_notes_and_full_prints_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.h5");
    let shifts: Vec<f64> = (0..48).map(|i| (i as f64 - 20.0) * 0.1234567891).collect();
    let files: Vec<String> = (0..48).map(|i| format!("scanline_{i:04}.png")).collect();
    let shifts_json = serde_json::to_string(&shifts).unwrap();
    let files_json = serde_json::to_string(&files).unwrap();
    let p = provenance()
        .with_note("ingest.jitter_shifts_ps", &shifts_json)
        .with_note("ingest.source_files", &files_json)
        .with_note("ingest.jitter_rms_ps", "1.6411945904467917");
    container::write_cube(&path, &test_cube(5, 4, true), &p).unwrap();
    let text = |extra: &[&str]| {
        let mut args = vec!["info", path.to_str().unwrap()];
        args.extend_from_slice(extra);
        let out = FemtoCmd::new().args(&args).output();
        assert!(out.status.success());
        String::from_utf8(out.stdout).unwrap()
    };
    let summary = text(&[]);
    assert!(
        summary.contains(
            "ingest.jitter_shifts_ps = 48 numbers, -2.46914 .. 3.33333 (--full lists them)"
        ),
        "{summary}"
    );
    assert!(
        summary.contains(
            r#"ingest.source_files = 48 entries, "scanline_0000.png" .. "scanline_0047.png""#
        ),
        "{summary}"
    );
    assert!(
        summary.contains("ingest.jitter_rms_ps = 1.64119\n"),
        "{summary}"
    );
    assert!(!summary.contains("scanline_0001.png"), "{summary}");
    let full = text(&["--full"]);
    assert!(
        full.contains(&shifts_json) && full.contains(&files_json),
        "{full}"
    );
    assert!(
        full.contains("ingest.jitter_rms_ps = 1.6411945904467917"),
        "{full}"
    );
    let json: serde_json::Value = serde_json::from_str(&text(&["--json"])).unwrap();
    assert_eq!(
        json["notes"]["ingest.jitter_shifts_ps"],
        shifts_json.as_str()
    );
}

#[test]
fn info_rejects_other_files_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let txt = dir.path().join("notes.txt");
    std::fs::write(&txt, "hello").unwrap();
    let missing = dir.path().join("missing.h5");
    for (p, what) in [
        (
            &txt,
            "not a file femto reads; femto reads femto cubes (.h5)",
        ),
        (&missing, "No such file"),
    ] {
        let out = FemtoCmd::new().args(["info", p.to_str().unwrap()]).output();
        assert_eq!(out.status.code(), Some(2));
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(
            err.contains(p.to_str().unwrap()) && err.contains(what),
            "{err}"
        );
        assert!(out.stdout.is_empty());
    }
}

/// The h5py fixtures (tests/data/h5py, written by tools/make_h5py_fixtures.py): a
/// femto cube that h5py annotated, and a cube h5py wrote itself and annotated.
const H5PY_FIXTURES: [&str; 2] = ["annotated.h5", "h5py_cube.h5"];

/// A copy of fixture `name` in `dir`.
fn h5py_fixture(dir: &Path, name: &str) -> std::path::PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/h5py")
        .join(name);
    let dst = dir.join(name);
    std::fs::copy(&src, &dst).unwrap_or_else(|e| panic!("{}: {e}", src.display()));
    dst
}

/// Where `new` differs from `old` within `old`'s length: `(first, last)` offsets.
fn changed_range(old: &[u8], new: &[u8]) -> Option<(usize, usize)> {
    let differs = |i: &usize| old[*i] != new[*i];
    let n = old.len().min(new.len());
    let first = (0..n).find(differs)?;
    Some((first, (0..n).rev().find(differs).unwrap_or(first)))
}

fn pyramid_like(rows: usize, scale: f64) -> GroupData {
    GroupData {
        attrs: vec![
            ("levels".into(), AttrValue::I64(2)),
            ("source".into(), AttrValue::Str("cube.h5".into())),
        ],
        datasets: vec![(
            "level_1".into(),
            vec![rows, 3],
            DataBuf::F64((0..rows * 3).map(|i| i as f64 * scale).collect()),
        )],
    }
}

/// Adding a group to a file that h5py annotated appends to it copy-on-write: no byte of the
/// old file changes but the superblock's (the last write, which switches readers to the new
/// root group), so the cube, h5py's groups, datasets and attributes of every default type
/// are kept as they were, byte for byte, and the update writes a small fraction of the file.
/// Replacing the group does the same.
#[test]
fn groups_are_appended_to_h5py_annotated_files_without_rewriting_them() {
    let dir = tempfile::tempdir().unwrap();
    for name in H5PY_FIXTURES {
        let path = h5py_fixture(dir.path(), name);
        let cube = container::read_cube(&path).unwrap();
        let groups = container::GroupReader::open(&path)
            .unwrap()
            .groups()
            .to_vec();
        assert_eq!(groups, ["notes"], "{name}");
        for (round, scale) in [(0, 1.5), (1, -0.25)] {
            let old = std::fs::read(&path).unwrap();
            let mut up = container::GroupUpdate::open(&path).unwrap();
            up.write_group("pyramid", &pyramid_like(4, scale)).unwrap();
            up.finish().unwrap();
            let new = std::fs::read(&path).unwrap();
            // Only the superblock changed (at most 96 bytes at offset 0) ...
            let (first, last) = changed_range(&old, &new).expect("the superblock changed");
            assert!(
                first < 96 && last < 96,
                "{name} round {round}: bytes {first}..={last}"
            );
            // ... and what was added is small: no copy of the cube (the most, about 11 KB,
            // for h5py's version 0 file, whose groups are symbol tables: B-tree nodes and
            // local heaps written afresh).
            let added = new.len() - old.len();
            assert!(added < 16384, "{name} round {round}: {added} bytes added");
            // Everything reads back: the cube, femto's group, h5py's group still listed.
            assert_eq!(container::read_cube(&path).unwrap(), cube, "{name}");
            assert_eq!(
                container::read_group(&path, "pyramid").unwrap(),
                pyramid_like(4, scale),
                "{name}"
            );
            assert_eq!(
                container::GroupReader::open(&path).unwrap().groups(),
                ["notes", "pyramid"],
                "{name}"
            );
        }
    }
}

/// An update that is dropped unfinished, or that fails, leaves the file byte-identical (the
/// bytes it appended are truncated away), and never touched the old bytes meanwhile.
#[test]
fn unfinished_in_place_updates_leave_the_file_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    for name in H5PY_FIXTURES {
        let path = h5py_fixture(dir.path(), name);
        let old = std::fs::read(&path).unwrap();
        // An update that has begun a 3 x 2 group `pyramid/d`.
        let begun = || {
            let mut up = container::GroupUpdate::open(&path).unwrap();
            up.begin_group(
                "pyramid",
                &[],
                &[container::DatasetSpec::new(
                    "d",
                    &[3, 2],
                    container::GroupElem::F64,
                )],
            )
            .unwrap();
            up
        };
        // Dropped half-way through a streamed group.
        let mut up = begun();
        up.write_group_rows("pyramid", "d", 0, &DataBuf::F64(vec![1.0, 2.0]))
            .unwrap();
        let during = std::fs::read(&path).unwrap();
        assert_eq!(&during[..old.len()], &old[..], "{name}: old bytes written");
        drop(up);
        assert_eq!(std::fs::read(&path).unwrap(), old, "{name}: after a drop");
        // Failed: a row never written.
        let up = begun();
        let e = up.finish().unwrap_err().to_string();
        assert!(e.contains("row 0"), "{e}");
        assert_eq!(
            std::fs::read(&path).unwrap(),
            old,
            "{name}: after a failure"
        );
        assert_eq!(files_in(dir.path()).len(), 1, "{name}: no temporary file");
        std::fs::remove_file(&path).unwrap();
    }
}

/// `femto pyramid` and `femto info` read a cube that h5py annotated, and the pyramid is added
/// without a byte of the old file changing but the superblock's.
#[test]
fn femto_pyramid_keeps_what_h5py_wrote() {
    let dir = tempfile::tempdir().unwrap();
    for name in H5PY_FIXTURES {
        let path = h5py_fixture(dir.path(), name);
        let old = std::fs::read(&path).unwrap();
        FemtoCmd::new().arg("info").arg(&path).ok();
        FemtoCmd::new().arg("pyramid").arg(&path).ok();
        let new = std::fs::read(&path).unwrap();
        let (first, last) = changed_range(&old, &new).unwrap();
        assert!(
            first < 96 && last < 96,
            "{name}: bytes {first}..={last} changed"
        );
        let out = FemtoCmd::new().arg("info").arg(&path).arg("--json").ok();
        let j: serde_json::Value = serde_json::from_str(&out.stdout).unwrap();
        assert_eq!(
            j["groups"],
            serde_json::json!(["notes", "pyramid"]),
            "{name}"
        );
        std::fs::remove_file(&path).unwrap();
    }
}

/// Every attribute of the object at `path` (`""` for the root group) of `file`: name, HDF5
/// type, dimensions, and value (its bytes, or its strings for variable-length strings).
fn attrs_of(file: &rust_hdf5::H5File, path: &str, dataset: bool) -> Vec<String> {
    let attr_text = |a: rust_hdf5::H5Attribute| {
        let dt = a.datatype().unwrap();
        let value = match dt {
            rust_hdf5::DatatypeMessage::VarLenString { .. } => {
                format!("{:?}", a.read_strings().unwrap())
            }
            _ => format!("{:?}", a.read_raw().unwrap()),
        };
        format!("{dt:?} {:?} {value}", a.dims().unwrap())
    };
    let mut out = Vec::new();
    if dataset {
        let ds = file.dataset(path).unwrap();
        for n in ds.attr_names().unwrap() {
            out.push(format!("{n}: {}", attr_text(ds.attr(&n).unwrap())));
        }
    } else {
        let g = if path.is_empty() {
            file.root_group()
        } else {
            file.root_group().group(path).unwrap()
        };
        for n in g.attr_names().unwrap() {
            out.push(format!("{n}: {}", attr_text(g.attr(&n).unwrap())));
        }
    }
    out.sort();
    out
}

/// What h5py wrote into the fixtures (root attributes, `/notes`, its attributes, and
/// `/notes/trace` with its values and attribute), read through the HDF5 crate.
fn h5py_objects(path: &Path) -> Vec<String> {
    let f = rust_hdf5::H5File::open(path).unwrap();
    let trace = f.dataset("notes/trace").unwrap();
    let mut out = vec![
        format!("/ {:?}", attrs_of(&f, "", false)),
        format!("/notes {:?}", attrs_of(&f, "notes", false)),
        format!("/notes/trace {:?}", attrs_of(&f, "notes/trace", true)),
        format!(
            "/notes/trace {:?} {:?} {:?}",
            trace.datatype().unwrap(),
            trace.shape(),
            trace.read_raw_bytes().unwrap()
        ),
    ];
    out.push(format!(
        "{:?}",
        f.root_group().group("notes").unwrap().dataset_names()
    ));
    out
}

/// A command that writes a new cube from an annotated one (`femto unwarp`, through
/// `CubeWriter::keep_foreign_from`) and the rewrite that updates a file the HDF5 layer cannot
/// append to both carry what h5py wrote: every attribute with its HDF5 type (h5py's str
/// and bytes differ in character set, its bool is an enum, lists of str are arrays of
/// variable-length strings), and datasets with their values and attributes.
#[test]
fn new_cubes_carry_what_h5py_wrote() {
    let dir = tempfile::tempdir().unwrap();
    for name in H5PY_FIXTURES {
        let src = h5py_fixture(dir.path(), name);
        let want = h5py_objects(&src);
        assert!(
            want[1].contains("raw_header") && want[1].contains("reviewed"),
            "{want:?}"
        );
        let cube = container::read_cube(&src).unwrap();
        let write = |out: &Path, keep: bool| {
            let mut w = CubeWriter::create(
                out,
                cube.nx,
                cube.ny,
                cube.axis,
                cube.frame,
                "arbitrary",
                &provenance(),
            )
            .unwrap();
            w.write_rows(0, &cube.data).unwrap();
            if keep {
                w.keep_foreign_from(&src);
            }
            w.finish().unwrap();
        };
        // A new cube.
        let out = dir.path().join(format!("new-{name}"));
        write(&out, true);
        assert_eq!(h5py_objects(&out), want, "{name}: new cube");
        assert_eq!(container::read_cube(&out).unwrap().data, cube.data);
        // Without it, nothing is carried.
        let bare = dir.path().join(format!("bare-{name}"));
        write(&bare, false);
        assert!(container::GroupReader::open(&bare)
            .unwrap()
            .groups()
            .is_empty());
        std::fs::remove_file(&out).unwrap();
        std::fs::remove_file(&bare).unwrap();
        std::fs::remove_file(&src).unwrap();
    }
}
