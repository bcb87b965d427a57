#!/usr/bin/env python3
"""Write tools/scenes/peer_cornell/: mitransient's own Cornell box as a femto scene file.

The geometry is `mitransient.cornell_box()` (mitransient 1.3.1): Mitsuba's rectangles
([-1, 1]^2 at z = 0) and cubes ([-1, 1]^3) through each shape's `to_world`, written as flat
triangles, one OBJ per material. The area light is replaced by an isotropic point source at
(0, 0.5, 0), as in the independent check of issue 20; the light's rectangle stays as white
geometry. Albedos are the luminance of mitransient's RGB reflectances (what a mono variant
of Mitsuba uses), so both renderers read one number per material from scene.toml.

Camera: mitransient's (origin (0, 0, 3.9), looking at the origin, 39.3077 deg), 64 x 64
pixels, 300 bins of 100 ps (0.03 m of optical path, about the check's bin) from 11,675 ps
(3.5 m, mitransient's start_opl). `femto simulate --bounces 7` is Mitsuba's max_depth 8.

Run once with Mitsuba + mitransient installed; the output is committed, so the comparison
and the golden references need only the files. Rerunning rewrites the same bytes.
"""

import os

import numpy as np

C_M_PER_PS = 2.99792458e-4

RECT = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float64)
RECT_TRIS = [(0, 1, 2), (0, 2, 3)]
CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
# Outward-facing triangles of the cube (index = 4 x + 2 y + z for x, y, z in {0, 1}).
CUBE_TRIS = [
    (0, 1, 3), (0, 3, 2),  # x = -1
    (4, 6, 7), (4, 7, 5),  # x = +1
    (0, 4, 5), (0, 5, 1),  # y = -1
    (2, 3, 7), (2, 7, 6),  # y = +1
    (0, 2, 6), (0, 6, 4),  # z = -1
    (1, 5, 7), (1, 7, 3),  # z = +1
]


def luminance(rgb):
    r, g, b = rgb
    return 0.212671 * r + 0.715160 * g + 0.072169 * b


def main():
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    import mitransient

    box = mitransient.cornell_box()
    here = os.path.dirname(os.path.abspath(__file__))
    out = os.path.join(here, "peer_cornell")
    os.makedirs(out, exist_ok=True)
    albedo = {m: luminance([float(v) for v in box[m]["reflectance"]["value"]]) for m in ("white", "red", "green")}
    tris = {m: [] for m in albedo}
    for name, shape in box.items():
        if not isinstance(shape, dict) or shape.get("type") not in ("rectangle", "cube"):
            continue
        m = np.array(shape["to_world"].matrix, dtype=np.float64)
        base, faces = (RECT, RECT_TRIS) if shape["type"] == "rectangle" else (CUBE, CUBE_TRIS)
        p = base @ m[:3, :3].T + m[:3, 3]
        tris[shape["bsdf"]["id"]].extend((name, [p[i] for i in f]) for f in faces)
    for m, ts in tris.items():
        with open(os.path.join(out, f"{m}.obj"), "w") as f:
            f.write(f"# mitransient.cornell_box(), material {m}: {', '.join(sorted({n for n, _ in ts}))}\n")
            for _, corners in ts:
                for c in corners:
                    f.write("v {:.7f} {:.7f} {:.7f}\n".format(*[0.0 if abs(x) < 5e-7 else x for x in c]))
            for k in range(len(ts)):
                f.write(f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}\n")
    dt_ps, t0_ps = 100.0, 11675.0
    with open(os.path.join(out, "scene.toml"), "w") as f:
        f.write(f"""# mitransient's own Cornell box (mitransient.cornell_box(), 1.3.1) with an isotropic point
# source at (0, 0.5, 0): the primary scene of tools/compare_mitsuba.py and of the golden
# references (tests/golden). Written by tools/scenes/make_peer_cornell.py; do not edit by hand.
# Albedos: the luminance of mitransient's RGB reflectances. Bins: 100 ps = {dt_ps * C_M_PER_PS:.6f} m.
name = "peer_cornell"
eta = 1.0

[laser]
position_m = [0.0, 0.5, 0.0]
normal = [0.0, -1.0, 0.0]
emission = "isotropic"
wavelength_nm = 795.0
pulse_width_fs = 0.0
energy = 1.0

[camera]
position_m = [0.0, 0.0, 3.9]
look_at_m = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
vfov_deg = 39.3077
nx = 64
ny = 64
nt = 300
dt_ps = {dt_ps}
t0_ps = {t0_ps}
""")
        for m in ("white", "red", "green"):
            f.write(f'\n[[mesh]]\nname = "{m}"\nfile = "{m}.obj"\nalbedo = {albedo[m]:.6f}\n')


if __name__ == "__main__":
    main()
