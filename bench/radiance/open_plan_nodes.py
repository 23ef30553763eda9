#!/usr/bin/env python3
"""A zone of the open-plan floor seen by two ceiling nodes (scenes/open_plan_nodes/): the scene,
the four commissioning capture sets (two nodes, each with a pinhole and with a fisheye camera)
rendered by Radiance, and the truth at the desk sensors.

The scene (--write). A 12 x 7 x 3 m open-plan zone with the open_plan floor's materials (floor
rho 0.20, ceiling 0.80, walls 0.50, desks 0.50, screen 0.40) and luminaire (the synthetic batwing
louvre of office_a, 7913 lm, openings 3 mm below the ceiling): 8 luminaires on a 4 x 2 grid
(3.0 x 3.5 m); two islands of 4 desks (1.6 x 0.8 m tops at 0.75 m, 30 mm slabs) centred at
x = 3 m and x = 9 m; a 1.5 m screen between them (x = 6 m, y 2.5..4.5 m); a 1.1 m cabinet along
the south wall (x 7.5..10.5 m, rho 0.35). 8 desk-top sensors (ideal cosine, facing up), one per
desk, and a 9th on the cabinet top; 12 scenarios (all on, west half, east half, a checkerboard,
each luminaire alone).

The nodes. Node A at (3, 3.5, 2.98) m, node B at (9, 3.5, 2.98) m, both looking straight down.
  * pinhole: office_a's camera (320 x 240, 90 deg across, image x along the room's y): each node
    sees its own island, 4 of the 8 desk sensors;
  * fisheye: a Kannala-Brandt lens (fx = fy = 105 px, k = 0.03, -0.008, 0.0005, 0, the
    sim-fisheye board's), image x along the room's x: each node sees the whole zone but what
    the screen and the desks hide.

Rendering (--render). Radiance `rtrace` on each camera's pixel rays (the lens model of
src/scene/lens.rs; pixels beyond 89 deg off the axis are left black with no depth): luminance =
179 * (0.265 R + 0.670 G + 0.065 B) cd/m^2 of the first hit's radiance, with
daylight.py's --fast irradiance-cache settings (-ab 7 -ad 512 -as 128 -aa 0.15 -ar 128 -lw 1e-4,
-ds 0.05 -dj 0.7 -dt 0); depth = first-hit distance (-oL) projected on the optical axis.
One rendering per camera and luminaire (luminaire k alone at 100 %).

Assembly (--assemble). Capture sets in the format of docs/formats.md:
pinhole_a/, pinhole_b/, fisheye_a/, fisheye_b/, each camera.json (gain 0.02 cd/m^2 per unit),
depth_000..002.png with office_a's ToF error model (1 % range noise, flying pixels at depth
edges, 0.5 % dropouts; seeded) and luminance_L<k>.png (16-bit, rounded, clipped at 65535).

Truth (--truth). `rtrace -I` at the sensors, the method of docs/formats.md at
reduced cost: no irradiance cache (-aa 0), -ab 10 -ad 4096 -lw 5e-5, every source
shadow-tested (-dt 0 -dc 1), sources subdivided (-ds 0.05 -dj 1), `--seeds` passes averaged;
one luminaire at a time (Radiance is linear in its sources), each scenario the sum; the direct
part with -ab 0. truth.csv in the shared scenes' columns.

    python3 bench/radiance/open_plan_nodes.py --write
    python3 bench/radiance/open_plan_nodes.py --render --work /tmp/open_plan_nodes   # ~15 min, 2 cores
    python3 bench/radiance/open_plan_nodes.py --assemble --work /tmp/open_plan_nodes
    python3 bench/radiance/open_plan_nodes.py --truth --seeds 4 --work /tmp/open_plan_nodes

Only the standard library, numpy and pyradiance (for the binaries).
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

try:
    import pyradiance  # noqa: F401  (bin/ on PATH and lib/ on RAYPATH)
except ImportError:  # pragma: no cover
    sys.exit("pyradiance is not installed: pip install pyradiance")

sys.path.insert(0, str(Path(__file__).resolve().parent))
from daylight import noisy_depth, quantise, write_png16  # noqa: E402
from open_plan import box, write_scene_files  # noqa: E402

BIN = Path(pyradiance.BINPATH)
HERE = Path(__file__).resolve().parent
OUT = HERE.parents[1] / "scenes" / "open_plan_nodes"
OPEN_PLAN = HERE.parents[1] / "scenes" / "open_plan"
LX, LY, LZ = 12.0, 7.0, 3.0
LUM_Z = 2.997
RHO = {"floor": 0.20, "ceiling": 0.80, "wall": 0.50, "desk": 0.50, "screen": 0.40,
       "cabinet": 0.35}
FLUX_LM = 7913.0
EFFICACY = 179.0
RGB_Y = (0.265, 0.670, 0.065)
GAIN = 0.02
CAMERA_Z = 2.98
NODES = {"a": 3.0, "b": 9.0}
FISHEYE_K = [0.03, -0.008, 0.0005, 0.0]
MAX_THETA = math.radians(89.0)
FRAME_OPTS = ["-h", "-ov", "-ab", "7", "-ad", "512", "-as", "128", "-aa", "0.15", "-ar", "128",
              "-lw", "1e-4", "-ds", "0.05", "-dj", "0.7", "-dt", "0", "-dc", "1"]
SCREEN = (5.98, 6.02, 2.5, 4.5, 1.5)
CABINET = (7.5, 10.5, 0.0, 0.45, 1.1)

# ------------------------------------------------------------------ scene


def luminaires() -> list[dict]:
    out = []
    for j in range(2):
        for i in range(4):
            x, y = 1.5 + 3.0 * i, 1.75 + 3.5 * j
            k = len(out) + 1
            out.append({"id": k, "name": f"luminaire_{k}", "position": [x, y, LUM_Z],
                        "aim": [0.0, 0.0, -1.0], "rotation_deg": 0.0,
                        "c0_direction": [1.0, 0.0, 0.0], "c90_direction": [0.0, 1.0, 0.0],
                        "photometry_ldt": "luminaire.ldt", "photometry_ies": "luminaire.ies",
                        "flux_lm": FLUX_LM, "luminous_opening_m": [0.6, 0.6]})
    return out


def desks() -> list[dict]:
    out = []
    for cx in (3.0, 9.0):
        cy = 3.5
        for a in range(2):
            for b in range(2):
                x0, y0 = cx - 1.6 + 1.6 * a, cy - 0.8 + 0.8 * b
                out.append({"id": len(out) + 1, "group": f"desk_{len(out) + 1}",
                            "x0": round(x0, 3), "x1": round(x0 + 1.6, 3),
                            "y0": round(y0, 3), "y1": round(y0 + 0.8, 3), "z": 0.75})
    return out


# (desk id, dx, dy from the desk's x0, y0)
SENSOR_SPOTS = [(1, 0.5, 0.3), (2, 0.8, 0.5), (3, 1.1, 0.4), (4, 1.3, 0.5),
                (5, 0.3, 0.4), (6, 0.8, 0.3), (7, 1.2, 0.5), (8, 0.6, 0.6)]


def sensors() -> list[dict]:
    ds = {d["id"]: d for d in desks()}
    out = []
    for did, dx, dy in SENSOR_SPOTS:
        d = ds[did]
        out.append({"id": len(out) + 1,
                    "position": [round(d["x0"] + dx, 3), round(d["y0"] + dy, 3), 0.751],
                    "normal": [0.0, 0.0, 1.0], "note": f"desk {did}"})
    x0, x1, y0, y1, h = CABINET
    out.append({"id": 9, "position": [9.0, 0.25, round(h + 0.001, 3)], "normal": [0.0, 0.0, 1.0],
                "note": "cabinet top"})
    return out


def quads():
    q = [("floor", "floor", [(0, 0, 0), (LX, 0, 0), (LX, LY, 0), (0, LY, 0)]),
         ("ceiling", "ceiling", [(0, LY, LZ), (LX, LY, LZ), (LX, 0, LZ), (0, 0, LZ)]),
         ("wall_s", "wall", [(0, 0, 0), (0, 0, LZ), (LX, 0, LZ), (LX, 0, 0)]),
         ("wall_n", "wall", [(LX, LY, 0), (LX, LY, LZ), (0, LY, LZ), (0, LY, 0)]),
         ("wall_w", "wall", [(0, LY, 0), (0, LY, LZ), (0, 0, LZ), (0, 0, 0)]),
         ("wall_e", "wall", [(LX, 0, 0), (LX, 0, LZ), (LX, LY, LZ), (LX, LY, 0)])]
    for d in desks():
        q += box(d["group"], "desk", d["x0"], d["x1"], d["y0"], d["y1"], 0.72, 0.75)
    x0, x1, y0, y1, h = SCREEN
    q += box("screen", "screen", x0, x1, y0, y1, 0.0, h)
    x0, x1, y0, y1, h = CABINET
    # against the wall: no back face (it would coincide with the wall)
    q += [f for f in box("cabinet", "cabinet", x0, x1, y0 + 0.001, y1, 0.0, h)]
    for l in luminaires():
        x, y, _ = l["position"]
        q.append((l["name"], "luminaire_opening",
                  [(x - 0.3, y - 0.3, LUM_Z), (x - 0.3, y + 0.3, LUM_Z),
                   (x + 0.3, y + 0.3, LUM_Z), (x + 0.3, y - 0.3, LUM_Z)]))
    return q


def states() -> list[tuple[int, list[int]]]:
    ids = [l["id"] for l in luminaires()]
    west = [i for i in ids if (i - 1) % 4 < 2]
    east = [i for i in ids if (i - 1) % 4 >= 2]
    checker = [i for i in ids if ((i - 1) % 4 + (i - 1) // 4) % 2 == 0]
    out = [(1, ids), (2, west), (3, east), (4, checker)]
    out += [(4 + k, [k]) for k in ids]
    return out


def camera_json(node: str, lens: str) -> dict:
    x = NODES[node]
    if lens == "pinhole":
        r = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]
        extra = {"model": "pinhole", "fx": 160.0, "fy": 160.0}
    else:
        r = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
        extra = {"model": "kannala_brandt", "k": FISHEYE_K, "fx": 105.0, "fy": 105.0}
    c = {"position": [x, 3.5, CAMERA_Z], "R_world_from_camera": r, "width": 320, "height": 240,
         "cx": 159.5, "cy": 119.5, "luminance_cd_m2_per_unit": GAIN,
         "note": f"node {node.upper()}, {lens}; bench/radiance/open_plan_nodes.py"}
    c.update(extra)
    c["encodings"] = {
        "depth_png": "uint16 millimetres along the camera optical axis (z_cam), 0 = no return",
        "luminance_png": "uint16 linear, luminance_cd_per_m2 = value * luminance_cd_m2_per_unit, "
                         "clipped at 65535",
    }
    return c


def poly(mat: str, name: str, pts) -> str:
    coords = "\n".join("\t{:.6f} {:.6f} {:.6f}".format(*p) for p in pts)
    return f"{mat} polygon {name}\n0\n0\n{3 * len(pts)}\n{coords}\n"


def write_scene() -> None:
    write_scene_files(OUT, "open_plan_nodes", RHO, quads(), luminaires(), sensors(), desks(),
                      states(), 0.2)
    for f in ("luminaire.ldt", "luminaire.ies"):
        shutil.copy(OPEN_PLAN / f, OUT / f)
    rad = OUT / "radiance"
    rad.mkdir(exist_ok=True)
    for f in ("luminaire.rad", "luminaire.dat"):
        shutil.copy(OPEN_PLAN / "radiance" / f, rad / f)
    with open(rad / "materials.rad", "w") as f:
        for m, r in RHO.items():
            f.write(f"void plastic {m}\n0\n0\n5 {r} {r} {r} 0 0\n\n")
        f.write("void plastic luminaire_off\n0\n0\n5 0 0 0 0 0\n\n")
    with open(rad / "geometry.rad", "w") as f:
        for k, (g, m, c) in enumerate(quads()):
            if m != "luminaire_opening":
                f.write(poly(m, f"{g}.{k}", c))
    for l in luminaires():
        x, y, _ = l["position"]
        (rad / f"lum_on_{l['id']}.rad").write_text(
            f"!xform -n {l['name']} -t {x} {y} {LUM_Z + 0.00025:.6f} luminaire.rad\n")
        (rad / f"lum_off_{l['id']}.rad").write_text(poly(
            "luminaire_off", f"{l['name']}.off",
            [(x - 0.3, y - 0.3, LUM_Z), (x - 0.3, y + 0.3, LUM_Z), (x + 0.3, y + 0.3, LUM_Z),
             (x + 0.3, y - 0.3, LUM_Z)]))
    for node in NODES:
        for lens in ("pinhole", "fisheye"):
            d = OUT / f"{lens}_{node}"
            d.mkdir(exist_ok=True)
            (d / "camera.json").write_text(json.dumps(camera_json(node, lens), indent=1) + "\n")
    print(f"wrote {OUT}")


# ------------------------------------------------------------------ rendering


def kb_radius(theta: np.ndarray) -> np.ndarray:
    t2 = theta * theta
    k1, k2, k3, k4 = FISHEYE_K
    return theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))


def pixel_rays(c: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit world directions of every pixel and a mask of the pixels that have a ray."""
    w, h = c["width"], c["height"]
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    mx, my = (u - c["cx"]) / c["fx"], (v - c["cy"]) / c["fy"]
    if c["model"] == "pinhole":
        d_cam = np.stack([mx, my, np.ones_like(mx)], -1)
        ok = np.ones(mx.shape, bool)
    else:
        r = np.hypot(mx, my)
        # invert r(theta) by bisection (monotonic up to 89 deg for this lens)
        lo, hi = np.zeros_like(r), np.full_like(r, MAX_THETA)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            big = kb_radius(mid) > r
            hi = np.where(big, mid, hi)
            lo = np.where(big, lo, mid)
        theta = 0.5 * (lo + hi)
        ok = r <= kb_radius(np.array(MAX_THETA))
        phi = np.arctan2(my, mx)
        d_cam = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                          np.cos(theta)], -1)
    rot = np.array(c["R_world_from_camera"], dtype=float)
    d = d_cam @ rot.T
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d.reshape(-1, 3), ok.reshape(-1), rot[:, 2]


def scene_files(lum_on: set[int]) -> list[str]:
    return ["materials.rad", "geometry.rad"] + [
        f"lum_on_{l['id']}.rad" if l["id"] in lum_on else f"lum_off_{l['id']}.rad"
        for l in luminaires()]


def octree(files: list[str], work: Path, name: str, rad: Path | None = None) -> Path:
    oct_ = work / f"{name}.oct"
    with open(oct_, "wb") as f:
        subprocess.run([str(BIN / "oconv"), *files], cwd=rad or OUT / "radiance", stdout=f,
                       check=True)
    return oct_


def rtrace(opts: list[str], oct_: Path, rays: str, rad: Path | None = None) -> list[list[float]]:
    p = subprocess.run([str(BIN / "rtrace"), *opts, str(oct_)], cwd=rad or OUT / "radiance",
                       input=rays, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    return [[float(x) for x in ln.split()] for ln in p.stdout.splitlines() if ln.strip()]


def render_frame(c: dict, name: str, files: list[str], work: Path, depth: bool,
                 rad: Path | None = None) -> None:
    """One frame of camera `c` (a camera.json) into work/<name>.npy: the depth along the optical
    axis, m, or the luminance, cd/m^2; pixels with no ray (beyond a fisheye's field) 0."""
    out = work / f"{name}.npy"
    if out.exists():
        print(f"{name}: exists, skipped")
        return
    d, ok, axis = pixel_rays(c)
    o = np.array(c["position"], dtype=float)
    rays = "".join("%.6f %.6f %.6f %.7f %.7f %.7f\n" % (*o, *di) for di in d[ok])
    oct_ = octree(files, work, name, rad)
    t0 = time.time()
    full = np.zeros(len(d))
    if depth:
        t = np.array([v[0] for v in rtrace(["-h", "-oL", "-ab", "0", "-dt", "1"], oct_, rays, rad)])
        z = t * (d[ok] @ axis)
        z[~np.isfinite(z) | (t <= 0) | (t > 1e3)] = 0.0
        full[ok] = z
    else:
        # a few dummy rays first shift rtrace's time-seeded random stream between parallel runs
        dummy = "60 60 1.5 0 0 1\n" * (sum(map(ord, name)) % 97)
        vals = rtrace(FRAME_OPTS, oct_, dummy + rays, rad)[dummy.count("\n"):]
        full[ok] = EFFICACY * (np.array(vals) @ np.array(RGB_Y))
    np.save(out, full.reshape(c["height"], c["width"]))
    print(f"{name}: {time.time() - t0:.0f} s", flush=True)


def assemble_set(d: Path, work: Path, cam: str, luminaire_ids: list[int], seed: int) -> None:
    """Capture set `d` from the frames of camera `cam`: 3 noisy depth frames (seeds `seed`..),
    one quantised luminance frame per luminaire."""
    z = np.load(work / f"{cam}_depth.npy")
    for k in range(3):
        write_png16(d / f"depth_{k:03d}.png", noisy_depth(z, seed + k))
    for k in luminaire_ids:
        write_png16(d / f"luminance_L{k}.png", quantise(np.load(work / f"{cam}_L{k}.npy"), GAIN))
    print(f"wrote {d}")


def render(cam: str, k: int | None, work: Path) -> None:
    c = json.loads((OUT / cam / "camera.json").read_text())
    name = f"{cam}_depth" if k is None else f"{cam}_L{k}"
    render_frame(c, name, scene_files(set() if k is None else {k}), work, k is None)


def cameras() -> list[str]:
    return [f"{lens}_{n}" for lens in ("pinhole", "fisheye") for n in NODES]


def render_all(a) -> None:
    a.work.mkdir(parents=True, exist_ok=True)
    jobs = [(cam, None) for cam in cameras()]
    jobs += [(cam, l["id"]) for cam in cameras() for l in luminaires()]
    with ThreadPoolExecutor(a.jobs) as ex:
        list(ex.map(lambda j: render(j[0], j[1], a.work), jobs))


def assemble(a) -> None:
    ids = [l["id"] for l in luminaires()]
    for n, cam in enumerate(cameras()):
        assemble_set(OUT / cam, a.work, cam, ids, 200 + 10 * n)


# ------------------------------------------------------------------ truth


def truth_one(k: int, a) -> dict:
    sens = sensors()
    rays = "".join("{} {} {} {} {} {}\n".format(*s["position"], *s["normal"]) for s in sens)
    oct_ = octree(scene_files({k}), a.work, f"truth_L{k}")
    out = {}
    for part, ab, seeds in (("total", 10, a.seeds), ("direct", 0, 1)):
        opts = ["-I", "-h", "-ov", "-aa", "0", "-ab", str(ab), "-ad", "4096", "-lw", "5e-5",
                "-ds", "0.05", "-dj", "1", "-dt", "0", "-dc", "1"]
        dummy = "60 60 1.5 0 0 1\n" * (7 * k % 89)
        vals = rtrace(opts, oct_, dummy + rays * seeds)[dummy.count("\n"):]
        lux = [EFFICACY * sum(w * x for w, x in zip(RGB_Y, v[:3])) for v in vals]
        n = len(sens)
        out[part] = [[lux[s * n + i] for s in range(seeds)] for i in range(n)]
        out["opts"] = " ".join(opts)
    print(f"truth L{k} done", flush=True)
    return out


def truth(a) -> None:
    a.work.mkdir(parents=True, exist_ok=True)
    ids = [l["id"] for l in luminaires()]
    with ThreadPoolExecutor(a.jobs) as ex:
        comp = dict(zip(ids, ex.map(lambda k: truth_one(k, a), ids)))
    sens = sensors()
    with open(OUT / "truth.csv", "w") as f:
        f.write("scenario_id,luminaires_on,sensor_id,lux,lux_direct,lux_indirect,lux_stderr\n")
        for sid, on in states():
            for i, s in enumerate(sens):
                seeds = a.seeds
                per_seed = [sum(comp[k]["total"][i][j] for k in on) for j in range(seeds)]
                lux = sum(per_seed) / seeds
                se = (sum((x - lux) ** 2 for x in per_seed) / (seeds - 1) / seeds) ** 0.5 \
                    if seeds > 1 else 0.0
                d = sum(comp[k]["direct"][i][0] for k in on)
                f.write(f"{sid},{';'.join(map(str, on))},{s['id']},{lux:.3f},{d:.3f},"
                        f"{lux - d:.3f},{se:.3f}\n")
    print(f"wrote {OUT / 'truth.csv'} (rtrace {comp[1]['opts']}; {a.seeds} passes)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", action="store_true", help="write the scene files")
    ap.add_argument("--render", action="store_true", help="render the capture frames")
    ap.add_argument("--assemble", action="store_true", help="write the capture sets' PNGs")
    ap.add_argument("--truth", action="store_true", help="truth.csv with Radiance")
    ap.add_argument("--work", type=Path, default=Path("/tmp/open_plan_nodes"))
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if not (a.write or a.render or a.assemble or a.truth):
        ap.error("nothing to do")
    if a.write:
        write_scene()
    if a.render:
        render_all(a)
    if a.assemble:
        assemble(a)
    if a.truth:
        truth(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
