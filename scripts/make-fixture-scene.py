#!/usr/bin/env python3
"""Writes tests/fixtures/small_office: a small scene in the format of docs/formats.md,
so that tests which need *a* scene (not the Radiance truth) run without ../shared.

Method: everything is constructed here, in closed form, with no other input.
- Room 4 x 3 x 2.8 m (floor rho 0.2, walls 0.5, ceiling 0.7), one desk 1.6 x 0.8 m, 0.75 m high
  (rho 0.4), faces counter-clockwise from their front: the shell faces into the room, the desk
  outwards.
- Two recessed luminaires, 0.6 x 0.6 m openings 5 mm below the ceiling, aimed down, 2000 lm each,
  with a Lambertian (cosine) distribution written as EULUMDAT and IES LM-63-2002: I(gamma) =
  I0 cos(gamma) for gamma <= 90 degrees, 0 above, I0 = flux / pi. The flux of that table is
  exactly flux (integral of I0 cos over the lower hemisphere = pi I0), so a reader's integrated
  flux is a closed-form check.
- Three sensors (desk centre, desk corner, floor near a wall), desks.json with a 0.25 m grid,
  camera.json (a 90 degree pinhole at the ceiling centre looking down), states.csv with three
  scenarios. No truth.csv: the Radiance yardstick stays reference/scenes.

Run: python3 scripts/make-fixture-scene.py  (deterministic; rewrites the directory's files)
"""
import json
import math
import os

OUT = os.path.join(os.path.dirname(__file__), "..", "tests", "fixtures", "small_office")
ROOM = (4.0, 3.0, 2.8)
DESK = (1.2, 2.8, 1.1, 1.9, 0.75)  # x0 x1 y0 y1 z
LUMS = [(1, 1.2, 1.5), (2, 2.8, 1.5)]  # id, x, y
FLUX_LM = 2000.0
OPENING_M = 0.6


def quad(a, b, c, d):
    return [a, b, c, d]


def box_faces_outward(x0, x1, y0, y1, z0, z1, bottom=False):
    f = {
        "top": quad((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)),
        "s": quad((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)),
        "e": quad((x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)),
        "n": quad((x1, y1, z0), (x0, y1, z0), (x0, y1, z1), (x1, y1, z1)),
        "w": quad((x0, y1, z0), (x0, y0, z0), (x0, y0, z1), (x0, y1, z1)),
    }
    if bottom:
        f["bottom"] = quad((x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0))
    return f


def write_obj():
    lx, ly, lz = ROOM
    groups = []  # (group, material, [quads])
    groups.append(("floor", "floor", [quad((0, 0, 0), (lx, 0, 0), (lx, ly, 0), (0, ly, 0))]))
    groups.append(("ceiling", "ceiling", [quad((0, 0, lz), (0, ly, lz), (lx, ly, lz), (lx, 0, lz))]))
    groups.append(("wall_s", "wall", [quad((0, 0, 0), (0, 0, lz), (lx, 0, lz), (lx, 0, 0))]))
    groups.append(("wall_n", "wall", [quad((0, ly, 0), (lx, ly, 0), (lx, ly, lz), (0, ly, lz))]))
    groups.append(("wall_w", "wall", [quad((0, 0, 0), (0, ly, 0), (0, ly, lz), (0, 0, lz))]))
    groups.append(("wall_e", "wall", [quad((lx, 0, 0), (lx, 0, lz), (lx, ly, lz), (lx, ly, 0))]))
    x0, x1, y0, y1, z = DESK
    d = box_faces_outward(x0, x1, y0, y1, 0.0, z)
    groups.append(("desk_1", "desk", list(d.values())))
    h = OPENING_M / 2
    zo = lz - 0.005
    for i, x, y in LUMS:
        # the opening faces down: counter-clockwise seen from below
        groups.append((f"luminaire_{i}", "luminaire",
                       [quad((x - h, y - h, zo), (x - h, y + h, zo), (x + h, y + h, zo), (x + h, y - h, zo))]))
    verts, lines = [], []
    for g, m, quads in groups:
        lines.append(f"g {g}")
        lines.append(f"usemtl {m}")
        for q in quads:
            base = len(verts) + 1
            verts.extend(q)
            lines.append(f"f {base} {base + 1} {base + 2}")
            lines.append(f"f {base} {base + 2} {base + 3}")
    with open(os.path.join(OUT, "scene.obj"), "w") as f:
        f.write("# luxnode test fixture: small office (scripts/make-fixture-scene.py), metres, z up\n")
        f.write("mtllib scene.mtl\n")
        for v in verts:
            f.write("v {:.4f} {:.4f} {:.4f}\n".format(*v))
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(OUT, "scene.mtl"), "w") as f:
        f.write("# Kd r r r = diffuse (Lambertian) reflectance; no specular part\n")
        for name, rho in [("floor", 0.2), ("ceiling", 0.7), ("wall", 0.5), ("desk", 0.4), ("luminaire", 0.0)]:
            f.write(f"newmtl {name}\nKa 0 0 0\nKd {rho:.4f} {rho:.4f} {rho:.4f}\nKs 0 0 0\nNs 1\nd 1\nillum 1\n\n")


def cosine_cd_per_klm(gamma_deg):
    # relative photometry: cd per 1000 lm of lamp flux; lamp flux 1000 lm, LOR 100 %
    i0 = 1000.0 / math.pi
    return i0 * max(0.0, math.cos(math.radians(gamma_deg))) if gamma_deg <= 90 else 0.0


def write_photometry():
    gammas = [5.0 * k for k in range(37)]
    ldt = [
        "luxnode test fixture",  # company
        "1",  # Ityp: point source with symmetry about the vertical axis
        "1",  # Isym: rotational symmetry
        "1",  # Mc: number of C planes
        "0",  # Dc
        str(len(gammas)),  # Ng
        "5",  # Dg
        "FIXTURE-COSINE",  # report number
        "Lambertian cosine distribution (closed form)",  # luminaire name
        "COSINE-600",  # luminaire number
        "cosine.ldt",  # file name
        "2026-11-23",  # date, user
        "600", "600", "0",  # length, width, height of luminaire, mm
        "600", "600",  # luminous area length, width, mm
        "0", "0", "0", "0",  # luminous area heights C0 C90 C180 C270
        "100.0",  # downward flux fraction, %
        "100.0",  # light output ratio, %
        "1.0",  # conversion factor
        "0.0",  # tilt
        "1",  # number of lamp sets
        "1",  # number of lamps
        "LED module",  # lamp type
        "1000",  # total lamp flux, lm
        "4000",  # colour temperature
        "1B",  # colour rendering
        "20.0",  # wattage, W
    ]
    ldt += ["0.0"] * 10  # direct ratios (unused)
    ldt += ["0.0"]  # C angle
    ldt += [f"{g:.1f}" for g in gammas]
    ldt += [f"{cosine_cd_per_klm(g):.3f}" for g in gammas]
    with open(os.path.join(OUT, "cosine.ldt"), "w", newline="\r\n") as f:
        f.write("\n".join(ldt) + "\n")
    ies = [
        "IESNA:LM-63-2002",
        "[TEST] luxnode test fixture",
        "[MANUFAC] luxnode",
        "[LUMINAIRE] Lambertian cosine distribution (closed form)",
        "TILT=NONE",
        # lamps, lumens/lamp, multiplier, n vertical, n horizontal, photometric type C,
        # units metres, width, length, height
        f"1 1000 1.0 {len(gammas)} 1 1 2 -0.6 -0.6 0.0",
        "1.0 1.0 20.0",
        " ".join(f"{g:.1f}" for g in gammas),
        "0.0",
        " ".join(f"{cosine_cd_per_klm(g):.3f}" for g in gammas),
    ]
    with open(os.path.join(OUT, "cosine.ies"), "w") as f:
        f.write("\n".join(ies) + "\n")


def write_json():
    lums = []
    for i, x, y in LUMS:
        lums.append({
            "id": i,
            "name": f"luminaire_{i}",
            "position": [x, y, ROOM[2] - 0.005],
            "aim": [0.0, 0.0, -1.0],
            "rotation_deg": 0.0,
            "c0_direction": [1.0, 0.0, 0.0],
            "c90_direction": [0.0, 1.0, 0.0],
            "photometry_ldt": "cosine.ldt",
            "photometry_ies": "cosine.ies",
            "flux_lm": FLUX_LM,
            "luminous_opening_m": [OPENING_M, OPENING_M],
        })
    x0, x1, y0, y1, z = DESK
    sensors = [
        {"id": 1, "position": [(x0 + x1) / 2, (y0 + y1) / 2, z + 0.001], "normal": [0.0, 0.0, 1.0],
         "note": "desk centre"},
        {"id": 2, "position": [x0 + 0.1, y0 + 0.1, z + 0.001], "normal": [0.0, 0.0, 1.0],
         "note": "desk corner"},
        {"id": 3, "position": [0.5, 0.5, 0.001], "normal": [0.0, 0.0, 1.0],
         "note": "floor near the south-west corner"},
    ]
    step = 0.25
    grid = []
    nx, ny = round((x1 - x0) / step), round((y1 - y0) / step)
    for i in range(nx):
        for j in range(ny):
            grid.append({"desk_id": 1, "x": round(x0 + (i + 0.5) * step, 4),
                         "y": round(y0 + (j + 0.5) * step, 4), "z": z + 0.001})
    desks = {"desks": [{"id": 1, "group": "desk_1", "x0": x0, "x1": x1, "y0": y0, "y1": y1, "z": z}],
             "grid_step_m": step, "grid_points": grid}
    w, h, hfov = 160, 120, 90.0
    fx = (w / 2) / math.tan(math.radians(hfov / 2))
    camera = {
        "position": [ROOM[0] / 2, ROOM[1] / 2, ROOM[2] - 0.02],
        "look": [0.0, 0.0, -1.0],
        "up": [-1.0, 0.0, 0.0],
        "right": [0.0, 1.0, 0.0],
        "width": w, "height": h,
        "fx": fx, "fy": fx, "cx": (w - 1) / 2, "cy": (h - 1) / 2,
        "hfov_deg": hfov,
        "vfov_deg": math.degrees(2 * math.atan((h / 2) / fx)),
        "R_world_from_camera": [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
    }
    for name, v in [("luminaires.json", lums), ("sensors.json", sensors), ("desks.json", desks),
                    ("camera.json", camera)]:
        with open(os.path.join(OUT, name), "w") as f:
            json.dump(v, f, indent=1)
            f.write("\n")
    with open(os.path.join(OUT, "states.csv"), "w") as f:
        f.write("scenario_id,luminaires_on\n1,1\n2,2\nall,1;2\n")


def main():
    os.makedirs(OUT, exist_ok=True)
    write_obj()
    write_photometry()
    write_json()
    with open(os.path.join(OUT, "README.md"), "w") as f:
        f.write("# small_office: a test fixture\n\nWritten by `scripts/make-fixture-scene.py` (its docstring states the method).\n"
                "Format: `docs/formats.md`. No Radiance truth: tests that compare with\n"
                "Radiance use `reference/scenes/office_a`.\n")
    print("wrote", os.path.normpath(OUT))


if __name__ == "__main__":
    main()
