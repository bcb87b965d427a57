"""y-tal (pip y-tal, import tal) both ways, numbers compared.

1. A capture written by y-tal's own writer (tal.io.write_capture) is ingested by femto
   (`femto ingest capture.hdf5 -o cube.h5`, and with `--dataset H`); h5py reads the cube:
   cube[y, x, t] must equal H[t, x, y], t0_ps = t_start / c (less the first bounce with
   t_accounts_first_and_last_bounces = True), dt_ps = delta_t / c, the clock world (False)
   or camera (True), the tal group's sensor grid the capture's.
2. That cube exported back (`femto export --to tal`) and read by tal.io.read_capture: H,
   delta_t, t_start, the flag, sensor and laser positions equal to the first capture's.
3. A calibrated world-time cube (femto demo --quick: simulate, ingest, calibrate, unwarp)
   exported and read by tal.io.read_capture: H is the cube transposed, delta_t = dt c /
   time_scale, t_start = (t0 - calibration t0) c / time_scale, sensor_grid_xyz equal to the
   registration's point_m within 1e-9 m, laser_grid_xyz its laser_m.
4. A confocal capture written by y-tal (laser_grid_xyz = sensor_grid_xyz, so that
   NLOSCaptureData.is_confocal() is True) is ingested, unwarped (both wall legs removed: each
   pixel's pulse, placed at its own laser leg + last bounce + a 0.6 m echo, lands at the echo)
   and exported back: tal.io.read_capture gives the same H, t_start, delta_t, and a capture
   that y-tal still calls confocal.
"""

import os
import subprocess

import h5py
import numpy as np

C_M_PER_PS = 2.99792458e-4


def run(femto, *args):
    p = subprocess.run([femto, *args], capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"femto {' '.join(args)}: exit {p.returncode}: {p.stderr.strip()}")
    return p.stdout


def attr_str(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def tal_capture(path, accounts):
    import tal
    from tal.enums import GridFormat, HFormat
    from tal.io.capture_data import NLOSCaptureData

    rng = np.random.default_rng(17)
    nt, sx, sy = 24, 5, 4
    d = NLOSCaptureData()
    d.H = rng.random((nt, sx, sy), dtype=np.float32)
    d.H_format = HFormat.T_Sx_Sy
    gx, gy = np.meshgrid(np.linspace(-0.5, 0.5, sx), np.linspace(-0.4, 0.4, sy), indexing="ij")
    d.sensor_grid_xyz = np.stack([gx, gy, np.zeros_like(gx)], axis=-1).astype(np.float32)
    d.sensor_grid_normals = np.broadcast_to(np.float32([0, 0, 1]), (sx, sy, 3)).copy()
    d.sensor_grid_format = GridFormat.X_Y_3
    d.sensor_xyz = np.float32([0.1, -0.2, -1.5])
    d.laser_xyz = np.float32([0.3, 0.4, -1.2])
    d.laser_grid_xyz = np.float32([[[0.25, 0.1, 0.0]]])
    d.laser_grid_normals = np.float32([[[0, 0, 1]]])
    d.laser_grid_format = GridFormat.X_Y_3
    d.delta_t = np.float32(0.003)
    d.t_start = np.float32(0.75)
    d.t_accounts_first_and_last_bounces = accounts
    tal.io.write_capture(path, d)
    return d


def close(a, b, rel=1e-9, abs_=0.0):
    return abs(float(a) - float(b)) <= max(abs_, rel * max(abs(float(a)), abs(float(b))))


def check_ingest_and_back(femto, work, accounts, failures):
    import tal

    src = os.path.join(work, f"ytal_{accounts}.hdf5")
    d = tal_capture(src, accounts)
    h = np.asarray(d.H)
    spot = np.asarray(d.laser_grid_xyz, np.float64).reshape(3)
    first = float(np.linalg.norm(np.asarray(d.laser_xyz, np.float64) - spot)) if accounts else 0.0
    want_t0 = (float(d.t_start) - first) / C_M_PER_PS
    want_dt = float(d.delta_t) / C_M_PER_PS
    for extra in ([], ["--dataset", "H"]):
        cube_path = os.path.join(work, f"cube_{accounts}{'_H' if extra else ''}.h5")
        run(femto, "ingest", src, *extra, "-o", cube_path)
        with h5py.File(cube_path, "r") as f:
            cube = f["cube"][...]
            a = f["cube"].attrs
            grid = f["tal/sensor_grid_m"][...]
            frame = attr_str(a["time_frame"])
            t0, dt = float(a["t0_ps"]), float(a["dt_ps"])
        how = "ingest" + (" --dataset H" if extra else "")
        diff = float(np.abs(cube - h.transpose(2, 1, 0)).max()) if cube.shape == h.shape[::-1] else None
        grid_err = float(np.abs(grid - np.asarray(d.sensor_grid_xyz, np.float64).transpose(1, 0, 2)).max())
        print(f"tal: y-tal capture (accounts={accounts}) -> femto {how}: cube {cube.shape} vs H "
              f"{h.shape} max |diff| {diff}, t0 {t0:.6f} ps (want {want_t0:.6f}), dt {dt:.6f} ps "
              f"(want {want_dt:.6f}), clock {frame}, sensor grid max err {grid_err:.2e} m")
        if diff is None or diff != 0.0:
            failures.append(f"{how} (accounts={accounts}): cube {cube.shape} is not H {h.shape} as (Sy, Sx, T): {diff}")
        if not (close(t0, want_t0, 1e-9) and close(dt, want_dt, 1e-9)):
            failures.append(f"{how} (accounts={accounts}): axis t0 {t0} dt {dt}, want {want_t0} {want_dt}")
        if frame != ("camera" if accounts else "world"):
            failures.append(f"{how} (accounts={accounts}): clock {frame}")
        if grid_err > 1e-9:
            failures.append(f"{how} (accounts={accounts}): tal group sensor grid off by {grid_err} m")

    back = os.path.join(work, f"back_{accounts}.hdf5")
    run(femto, "export", "--to", "tal", os.path.join(work, f"cube_{accounts}.h5"), "-o", back)
    r = tal.io.read_capture(back)
    herr = float(np.abs(np.asarray(r.H) - h).max()) if np.shape(r.H) == h.shape else None
    gerr = float(np.abs(np.asarray(r.sensor_grid_xyz, np.float64) - np.asarray(d.sensor_grid_xyz, np.float64)).max())
    lerr = float(np.abs(np.asarray(r.laser_xyz, np.float64) - np.asarray(d.laser_xyz, np.float64)).max())
    serr = float(np.abs(np.asarray(r.laser_grid_xyz, np.float64).reshape(3) - spot).max())
    print(f"tal: femto export of it -> tal.io.read_capture: H {np.shape(r.H)} max |diff| {herr}, delta_t "
          f"{float(r.delta_t):.9g} (was {float(d.delta_t):.9g}), t_start {float(r.t_start):.9g} (was "
          f"{float(d.t_start):.9g}), accounts {bool(r.t_accounts_first_and_last_bounces)}, sensor grid "
          f"err {gerr:.2e} m, laser origin err {lerr:.2e} m, spot err {serr:.2e} m, H_format {r.H_format}")
    if herr is None or herr != 0.0:
        failures.append(f"export (accounts={accounts}): H differs ({herr})")
    if not (close(r.delta_t, d.delta_t, 1e-9) and close(r.t_start, d.t_start, 1e-9)):
        failures.append(f"export (accounts={accounts}): delta_t {r.delta_t} t_start {r.t_start}")
    if bool(r.t_accounts_first_and_last_bounces) != accounts:
        failures.append(f"export (accounts={accounts}): flag {r.t_accounts_first_and_last_bounces}")
    if max(gerr, lerr, serr) > 1e-9:
        failures.append(f"export (accounts={accounts}): positions off by {max(gerr, lerr, serr)} m")


def check_registered_export(femto, work, failures):
    import tal

    demo = os.path.join(work, "demo")
    run(femto, "demo", "--quick", "--out", demo)
    world = os.path.join(demo, "data", "world.h5")
    out = os.path.join(work, "world_tal.hdf5")
    run(femto, "export", "--to", "tal", world, "-o", out)
    r = tal.io.read_capture(out)
    with h5py.File(world, "r") as f:
        cube = f["cube"][...]
        a = f["cube"].attrs
        reg = f["registration"]
        points = reg["point_m"][...].astype(np.float64)
        ra = reg.attrs
        t0_cal, scale = float(ra["t0_ps"]), float(ra["time_scale"])
        laser = np.asarray(ra["laser_m"], np.float64)
        t0, dt = float(a["t0_ps"]), float(a["dt_ps"])
    want_h = cube.transpose(2, 1, 0)
    herr = float(np.abs(np.asarray(r.H) - want_h).max()) if np.shape(r.H) == want_h.shape else None
    grid = np.asarray(r.sensor_grid_xyz, np.float64)
    want_grid = points.transpose(1, 0, 2)
    both = np.isfinite(want_grid)
    nan_same = bool(np.array_equal(both, np.isfinite(grid)))
    gerr = float(np.abs(grid[both] - want_grid[both]).max()) if grid.shape == want_grid.shape else None
    want_dt = dt * C_M_PER_PS / scale
    want_start = (t0 - t0_cal) * C_M_PER_PS / scale
    spot_err = float(np.abs(np.asarray(r.laser_grid_xyz, np.float64).reshape(3) - laser).max())
    print(f"tal: femto demo --quick world.h5 {cube.shape} -> export -> tal.io.read_capture: H {np.shape(r.H)} "
          f"max |diff| {herr}, delta_t {float(r.delta_t):.9g} m (want {want_dt:.9g}), t_start "
          f"{float(r.t_start):.9g} m (want {want_start:.9g}), accounts {bool(r.t_accounts_first_and_last_bounces)}, "
          f"sensor grid vs registration point_m max err {gerr} m over {int(both.all(axis=-1).sum())} seen points "
          f"(NaN pattern equal: {nan_same}), spot err {spot_err:.2e} m")
    if herr is None or herr != 0.0:
        failures.append(f"registered export: H is not the cube transposed ({herr})")
    if gerr is None or gerr > 1e-9 or not nan_same:
        failures.append(f"registered export: sensor grid off the registration by {gerr} m (NaN equal {nan_same})")
    if not (close(r.delta_t, want_dt, 1e-12) and close(r.t_start, want_start, 1e-9, 1e-12)):
        failures.append(f"registered export: delta_t {r.delta_t} t_start {r.t_start}, want {want_dt} {want_start}")
    if bool(r.t_accounts_first_and_last_bounces):
        failures.append("registered export: a world-time cube must give t_accounts_first_and_last_bounces False")
    if spot_err > 1e-9:
        failures.append(f"registered export: laser spot off by {spot_err} m")


def check_confocal(femto, work, failures):
    import tal
    from tal.enums import GridFormat, HFormat
    from tal.io.capture_data import NLOSCaptureData

    nt, sx, sy = 500, 4, 3
    delta_t = 0.01
    gx, gy = np.meshgrid(np.linspace(-0.3, 0.3, sx), np.linspace(-0.2, 0.2, sy), indexing="ij")
    grid = np.stack([gx, gy, np.ones_like(gx)], axis=-1)
    sensor = np.array([0.1, -0.2, -0.5])
    laser = np.array([-0.3, 0.1, -0.4])
    legs = np.linalg.norm(grid - laser, axis=-1) + np.linalg.norm(grid - sensor, axis=-1)
    echo = 0.6
    h = np.zeros((nt, sx, sy), np.float32)
    for x in range(sx):
        for y in range(sy):
            h[int((legs[x, y] + echo) // delta_t), x, y] = 1 + x + 10 * y
    d = NLOSCaptureData()
    d.H = h
    d.H_format = HFormat.T_Sx_Sy
    d.sensor_grid_xyz = grid.astype(np.float32)
    d.sensor_grid_normals = np.broadcast_to(np.float32([0, 0, -1]), (sx, sy, 3)).copy()
    d.sensor_grid_format = GridFormat.X_Y_3
    d.laser_grid_xyz = grid.astype(np.float32)
    d.laser_grid_normals = d.sensor_grid_normals.copy()
    d.laser_grid_format = GridFormat.X_Y_3
    d.sensor_xyz = sensor.astype(np.float32)
    d.laser_xyz = laser.astype(np.float32)
    d.delta_t = np.float32(delta_t)
    d.t_start = np.float32(0.0)
    d.t_accounts_first_and_last_bounces = True
    src = os.path.join(work, "confocal.hdf5")
    tal.io.write_capture(src, d)
    if not tal.io.read_capture(src).is_confocal():
        failures.append("confocal: y-tal does not call its own capture confocal (test setup)")
    cube = os.path.join(work, "confocal.h5")
    world = os.path.join(work, "confocal_world.h5")
    back = os.path.join(work, "confocal_back.hdf5")
    run(femto, "ingest", src, "-o", cube)
    run(femto, "unwarp", cube, "-o", world)
    run(femto, "export", "--to", "tal", cube, "-o", back)
    r = tal.io.read_capture(back)
    herr = float(np.abs(np.asarray(r.H) - h).max()) if np.shape(r.H) == h.shape else None
    with h5py.File(world, "r") as f:
        w = f["cube"][...].astype(np.float64)
        a = f["cube"].attrs
        t = float(a["t0_ps"]) + (np.arange(w.shape[2]) + 0.5) * float(a["dt_ps"])
    mean_ps = (w * t).sum(axis=2) / w.sum(axis=2)
    want_ps = echo / C_M_PER_PS
    bin_ps = delta_t / C_M_PER_PS
    worst = float(np.abs(mean_ps - want_ps).max())
    print(f"tal: confocal y-tal capture {h.shape} -> femto ingest, unwarp: pulses at the echo "
          f"{want_ps:.1f} ps within {worst:.2f} ps (a bin is {bin_ps:.1f} ps); export -> "
          f"tal.io.read_capture: H max |diff| {herr}, is_confocal {r.is_confocal()}, t_start "
          f"{float(r.t_start):.9g}, delta_t {float(r.delta_t):.9g}")
    if herr is None or herr != 0.0:
        failures.append(f"confocal export: H differs ({herr})")
    if not r.is_confocal():
        failures.append("confocal export: y-tal does not read it as confocal")
    if not (close(r.delta_t, delta_t, 1e-7) and abs(float(r.t_start)) < 1e-9):
        failures.append(f"confocal export: delta_t {r.delta_t} t_start {r.t_start}")
    if worst > bin_ps:
        failures.append(f"confocal unwarp: a pulse {worst} ps from the echo (both legs not removed)")


def check(femto, workdir):
    failures = []
    check_confocal(femto, workdir, failures)
    for accounts in (False, True):
        check_ingest_and_back(femto, workdir, accounts, failures)
    check_registered_export(femto, workdir, failures)
    return failures
