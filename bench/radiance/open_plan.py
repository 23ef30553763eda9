#!/usr/bin/env python3
"""The open-plan reference scene (scenes/open_plan/): geometry, luminaires, sensors, desks,
states, and its truth by Radiance.

The floor: 30 x 20 x 3 m, floor rho 0.20, ceiling 0.80, walls 0.50; 60 recessed 0.6 x 0.6 m
luminaires (the synthetic batwing louvre of office_a, 7913 lm each) on a 10 x 6 grid (3.0 m
x 3.33 m), their openings 3 mm below the ceiling like office_a's; 40 desks (1.6 x 0.8 m tops at
0.75 m, rho 0.50, 30 mm thick slabs) in 10 islands of 4; four 1.5 m high screens (rho 0.40,
40 mm thick) between islands; 8 desk-top luxmeters (ideal cosine, facing up).

Method of the truth (that of docs/formats.md, at reduced cost for 60 sources):
Radiance `rtrace -I` without irradiance cache (-aa 0), -ab 8 -ad 2048 -lw 1e-4, every source
shadow-tested (-dt 0 -dc 1), sources subdivided (-ds 0.05 -dj 1), `--seeds` passes averaged
(standard error reported). The luminaire is office_a's ies2rad output (flatcorr, luminaire.dat).
lux = 179 * irradiance (grey scene). Direct part: the same with -ab 0.

    python3 open_plan.py --write            # the scene files (no Radiance)
    python3 open_plan.py --truth --seeds 2  # truth.csv for states.csv (Radiance, a few minutes)
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

OUT = Path(__file__).resolve().parents[2] / "scenes" / "open_plan"
LX, LY, LZ = 30.0, 20.0, 3.0
LUM_Z = 2.997
RHO = {"floor": 0.20, "ceiling": 0.80, "wall": 0.50, "desk": 0.50, "screen": 0.40}
FLUX_LM = 7913.0
EFFICACY = 179.0

# ------------------------------------------------------------------ geometry


def luminaires() -> list[dict]:
    out = []
    for j in range(6):
        for i in range(10):
            x, y = 1.5 + 3.0 * i, 10.0 / 3.0 * (j + 0.5)
            out.append({
                "id": len(out) + 1, "name": f"luminaire_{len(out) + 1}",
                "position": [round(x, 6), round(y, 6), LUM_Z], "aim": [0.0, 0.0, -1.0],
                "rotation_deg": 0.0, "c0_direction": [1.0, 0.0, 0.0],
                "c90_direction": [0.0, 1.0, 0.0], "photometry_ldt": "luminaire.ldt",
                "photometry_ies": "luminaire.ies", "flux_lm": FLUX_LM,
                "luminous_opening_m": [0.6, 0.6]})
    return out


def desks() -> list[dict]:
    """10 islands of 4 desks (2 x 2, 1.6 m along x, 0.8 m along y), 2 rows of 5 islands."""
    out = []
    for row in range(2):
        for col in range(5):
            cx, cy = 3.5 + 5.75 * col, 5.5 + 9.0 * row
            for a in range(2):
                for b in range(2):
                    x0, y0 = cx - 1.6 + 1.6 * a, cy - 0.8 + 0.8 * b
                    out.append({"id": len(out) + 1, "group": f"desk_{len(out) + 1}",
                                "x0": round(x0, 3), "x1": round(x0 + 1.6, 3),
                                "y0": round(y0, 3), "y1": round(y0 + 0.8, 3), "z": 0.75})
    return out


SCREENS = [  # x0, x1, y0, y1, height: thin boxes between islands
    (6.30, 6.34, 3.5, 7.5, 1.5), (12.05, 12.09, 3.5, 7.5, 1.5),
    (17.80, 17.84, 12.5, 16.5, 1.5), (23.55, 23.59, 12.5, 16.5, 1.5),
]

SENSORS = [  # (desk id, dx, dy) from the desk's x0, y0; notes
    (1, 0.4, 0.4, "island 1 (south-west)"),
    (4, 0.8, 0.4, "island 1, the desk nearest screen 1"),
    (10, 0.8, 0.4, "island 3, centre of the south row"),
    (13, 1.2, 0.4, "island 4"),
    (20, 0.4, 0.4, "island 5 (south-east)"),
    (22, 0.8, 0.4, "island 6 (north-west)"),
    (31, 0.8, 0.4, "island 8, between screens 3 and 4"),
    (40, 1.2, 0.6, "island 10 (north-east)"),
]


def quads() -> list[tuple[str, str, list[tuple[float, float, float]]]]:
    """(group, material, corners counter-clockwise seen from the front)."""
    q = []
    q.append(("floor", "floor", [(0, 0, 0), (LX, 0, 0), (LX, LY, 0), (0, LY, 0)]))
    q.append(("ceiling", "ceiling", [(0, LY, LZ), (LX, LY, LZ), (LX, 0, LZ), (0, 0, LZ)]))
    q.append(("wall_s", "wall", [(0, 0, 0), (0, 0, LZ), (LX, 0, LZ), (LX, 0, 0)]))
    q.append(("wall_n", "wall", [(LX, LY, 0), (LX, LY, LZ), (0, LY, LZ), (0, LY, 0)]))
    q.append(("wall_w", "wall", [(0, LY, 0), (0, LY, LZ), (0, 0, LZ), (0, 0, 0)]))
    q.append(("wall_e", "wall", [(LX, 0, 0), (LX, 0, LZ), (LX, LY, LZ), (LX, LY, 0)]))
    for d in desks():
        q += box(d["group"], "desk", d["x0"], d["x1"], d["y0"], d["y1"], 0.72, 0.75)
    for k, (x0, x1, y0, y1, h) in enumerate(SCREENS):
        q += box(f"screen_{k + 1}", "screen", x0, x1, y0, y1, 0.0, h)
    for l in luminaires():
        x, y, _ = l["position"]
        q.append((l["name"], "luminaire_opening",
                  [(x - 0.3, y - 0.3, LUM_Z), (x - 0.3, y + 0.3, LUM_Z),
                   (x + 0.3, y + 0.3, LUM_Z), (x + 0.3, y - 0.3, LUM_Z)]))
    return q


def box(group, mat, x0, x1, y0, y1, z0, z1):
    """A closed box with outward faces; no bottom face when it stands on the floor."""
    f = [
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
        [(x1, y1, z0), (x0, y1, z0), (x0, y1, z1), (x1, y1, z1)],
        [(x0, y1, z0), (x0, y0, z0), (x0, y0, z1), (x0, y1, z1)],
        [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],
    ]
    if z0 > 1e-9:
        f.append([(x0, y1, z0), (x1, y1, z0), (x1, y0, z0), (x0, y0, z0)])
    return [(group, mat, c) for c in f]


def sensors() -> list[dict]:
    ds = {d["id"]: d for d in desks()}
    out = []
    for k, (did, dx, dy, note) in enumerate(SENSORS):
        d = ds[did]
        out.append({"id": k + 1, "position": [round(d["x0"] + dx, 3), round(d["y0"] + dy, 3), 0.751],
                    "normal": [0.0, 0.0, 1.0], "note": f"desk {did}: {note}"})
    return out


def states() -> list[tuple[int, list[int]]]:
    ids = [l["id"] for l in luminaires()]
    west = [i for i in ids if (i - 1) % 10 < 5]
    checker = [i for i in ids if ((i - 1) % 10 + (i - 1) // 10) % 2 == 0]
    return [(1, ids), (2, west), (3, checker), (4, [23])]


def write_scene_files(out: Path, name: str, rho: dict, quads_, luminaires_, sensors_, desks_,
                      states_, grid_step_m: float) -> None:
    """The luxnode scene files of a scene given as quads: scene.obj/.mtl, luminaires.json,
    sensors.json, desks.json (with a grid of points on each desk top, `grid_step_m` apart),
    states.csv. Shared by the scenes this directory generates."""
    out.mkdir(parents=True, exist_ok=True)
    mats = dict(rho, luminaire_opening=0.0)
    with open(out / "scene.mtl", "w") as f:
        for m, r in mats.items():
            f.write(f"newmtl {m}\nKa 0 0 0\nKd {r:.4f} {r:.4f} {r:.4f}\nKs 0 0 0\n\n")
    lines = [f"# reference scene '{name}' (bench/radiance/{name}.py): metres, z up, CCW front faces",
             "mtllib scene.mtl"]
    faces, nv, group = [], 0, None
    for g, m, c in quads_:
        if g != group:
            faces.append(f"g {g}\nusemtl {m}")
            group = g
        for p in c:
            lines.append("v {:.6f} {:.6f} {:.6f}".format(*p))
        faces.append(f"f {nv + 1} {nv + 2} {nv + 3}\nf {nv + 1} {nv + 3} {nv + 4}")
        nv += 4
    (out / "scene.obj").write_text("\n".join(lines + faces) + "\n")
    (out / "luminaires.json").write_text(json.dumps(luminaires_, indent=1) + "\n")
    (out / "sensors.json").write_text(json.dumps(sensors_, indent=1) + "\n")
    grid = []
    half = grid_step_m / 2
    for d in desks_:
        x = d["x0"] + half
        while x < d["x1"]:
            y = d["y0"] + half
            while y < d["y1"]:
                grid.append({"desk_id": d["id"], "x": round(x, 3), "y": round(y, 3), "z": 0.751})
                y += grid_step_m
            x += grid_step_m
    (out / "desks.json").write_text(json.dumps({"desks": desks_, "grid_step_m": grid_step_m,
                                                "grid_points": grid}) + "\n")
    with open(out / "states.csv", "w") as f:
        f.write("scenario_id,luminaires_on\n")
        for sid, on in states_:
            f.write(f"{sid},{';'.join(map(str, on))}\n")


def write_scene() -> None:
    write_scene_files(OUT, "open_plan", RHO, quads(), luminaires(), sensors(), desks(), states(),
                      0.25)
    # Radiance files: materials and geometry (luminaires added per state)
    rad = OUT / "radiance"
    rad.mkdir(exist_ok=True)
    with open(rad / "materials.rad", "w") as f:
        for m, r in RHO.items():
            f.write(f"void plastic {m}\n0\n0\n5 {r} {r} {r} 0 0\n\n")
        f.write("void plastic luminaire_off\n0\n0\n5 0 0 0 0 0\n\n")
    with open(rad / "geometry.rad", "w") as f:
        for k, (g, m, c) in enumerate(quads()):
            if m == "luminaire_opening":
                continue
            coords = "\n".join("\t{:.6f} {:.6f} {:.6f}".format(*p) for p in c)
            f.write(f"{m} polygon {g}.{k}\n0\n0\n12\n{coords}\n")
    print(f"wrote {OUT}")


# ------------------------------------------------------------------ truth


def luminaire_rad(on: set[int]) -> str:
    s = []
    for l in luminaires():
        x, y, _ = l["position"]
        if l["id"] in on:
            # office_a's luminaire.rad: the opening 0.25 mm below the given point
            s.append(f"!xform -n {l['name']} -t {x} {y} {LUM_Z + 0.00025:.6f} luminaire.rad\n")
        else:
            c = [(x - 0.3, y - 0.3, LUM_Z), (x - 0.3, y + 0.3, LUM_Z),
                 (x + 0.3, y + 0.3, LUM_Z), (x + 0.3, y - 0.3, LUM_Z)]
            coords = "\n".join("\t{:.6f} {:.6f} {:.6f}".format(*p) for p in c)
            s.append(f"luminaire_off polygon {l['name']}.off\n0\n0\n12\n{coords}\n")
    return "".join(s)


def run_state(sid: int, on: list[int], a, work: Path) -> dict:
    import pyradiance  # noqa: F401  (bin/ on PATH, lib/ on RAYPATH)
    binp = Path(pyradiance.BINPATH)
    rad = OUT / "radiance"
    lum = work / f"lum_{sid}.rad"
    lum.write_text(luminaire_rad(set(on)))
    octree = work / f"s{sid}.oct"
    with open(octree, "wb") as f:
        subprocess.run([str(binp / "oconv"), "materials.rad", "geometry.rad", str(lum)], cwd=rad,
                       stdout=f, check=True)
    rays = "".join("{} {} {} {} {} {}\n".format(*s["position"], *s["normal"]) for s in sensors())
    # a different number of dummy rays per state shifts the random stream
    dummy = "".join("60 60 1.5 0 0 1\n" for _ in range(sid))
    out = {}
    for part, ab in (("total", a.ab), ("direct", 0)):
        opts = ["-I", "-h", "-ov", "-aa", "0", "-ab", str(ab), "-ad", str(a.ad), "-lw", str(a.lw),
                "-ds", "0.05", "-dj", "1", "-dt", "0", "-dc", "1"]
        seeds = a.seeds if ab > 0 else 1
        t0 = time.perf_counter()
        p = subprocess.run([str(binp / "rtrace"), *opts, str(octree)], cwd=rad,
                           input=dummy + rays * seeds, capture_output=True, text=True, check=True)
        vals = [EFFICACY * float(ln.split()[0]) for ln in p.stdout.splitlines() if ln.strip()][sid:]
        n = len(sensors())
        out[part] = [[vals[s * n + k] for s in range(seeds)] for k in range(n)]
        out[part + "_s"] = time.perf_counter() - t0
        out["opts_" + part] = " ".join(opts)
    return out


def truth(a) -> None:
    sts = states()
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(a.jobs) as ex:
        res = list(ex.map(lambda s: run_state(s[0], s[1], a, Path(tmp)), sts))
    with open(OUT / "truth.csv", "w") as f:
        f.write("scenario_id,luminaires_on,sensor_id,lux,lux_direct,lux_indirect,lux_stderr\n")
        for (sid, on), r in zip(sts, res):
            for k, s in enumerate(sensors()):
                t = r["total"][k]
                lux = statistics.fmean(t)
                se = statistics.stdev(t) / len(t) ** 0.5 if len(t) > 1 else 0.0
                d = r["direct"][k][0]
                f.write(f"{sid},{';'.join(map(str, on))},{s['id']},{lux:.3f},{d:.3f},"
                        f"{lux - d:.3f},{se:.3f}\n")
            print(f"state {sid}: {r['total_s']:.0f} s (+{r['direct_s']:.0f} s direct)")
    print(f"wrote {OUT / 'truth.csv'} (rtrace {res[0]['opts_total']}; {a.seeds} passes)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", action="store_true", help="write the scene files")
    ap.add_argument("--truth", action="store_true", help="compute truth.csv with Radiance")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("-ab", type=int, default=8)
    ap.add_argument("-ad", type=int, default=2048)
    ap.add_argument("-lw", type=float, default=1e-4)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if not (a.write or a.truth):
        ap.error("nothing to do: --write and/or --truth")
    if a.write:
        write_scene()
    if a.truth:
        truth(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
