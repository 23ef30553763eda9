#!/usr/bin/env python3
"""office_a seen by other cameras (scenes/office_a_nodes/): capture sets of the reference office
reference/scenes/office_a rendered by Radiance for cameras its capture does not have, so
docs/commissioning.md can give office_a's errors with and without a fisheye and with one and
two nodes (issue 18). The scene, its Radiance files and its truth are office_a's own (read from
the shared directory, never copied or changed).

Cameras (all 2.98 m above the floor, looking straight down, 320 x 240):
  * fisheye_c: the pose of office_a's own capture (3.0, 3.6) m with the sim-fisheye board's
    Kannala-Brandt lens (fx = fy = 105 px, k = 0.03, -0.008, 0.0005, 0), image x along the
    room's y (7.2 m);
  * pinhole_s, pinhole_n: two nodes at (2.5, 1.8) and (2.5, 5.4) m with office_a's pinhole
    (fx = 160 px, 90 deg across, image x along the room's y);
  * fisheye_s, fisheye_n: the same two nodes with the fisheye.

Rendering, noise and assembly are those of open_plan_nodes.py (its docstring): rtrace on each
pixel ray with the irradiance-cache settings there, luminance = 179 (0.265 R + 0.670 G +
0.065 B), depth along the optical axis, office_a's ToF error model on 3 depth frames, 16-bit
luminance at 0.02 cd/m^2 per unit.

    python3 bench/radiance/office_a_nodes.py --write
    python3 bench/radiance/office_a_nodes.py --render --work /tmp/office_a_nodes   # ~5 min, 2 cores
    python3 bench/radiance/office_a_nodes.py --assemble --work /tmp/office_a_nodes
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from open_plan_nodes import FISHEYE_K, GAIN, assemble_set, render_frame  # noqa: E402

SRC = Path(__file__).resolve().parents[2] / "reference/scenes/office_a"
RAD = SRC / "radiance"
OUT = Path(__file__).resolve().parents[2] / "scenes" / "office_a_nodes"
LUMINAIRES = list(range(1, 9))
CAMERA_Z = 2.98
CAMERAS = {  # name: (x, y, lens)
    "fisheye_c": (3.0, 3.6, "fisheye"),
    "pinhole_s": (2.5, 1.8, "pinhole"),
    "pinhole_n": (2.5, 5.4, "pinhole"),
    "fisheye_s": (2.5, 1.8, "fisheye"),
    "fisheye_n": (2.5, 5.4, "fisheye"),
}


def camera_json(name: str) -> dict:
    x, y, lens = CAMERAS[name]
    c = {"position": [x, y, CAMERA_Z],
         "R_world_from_camera": [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]],
         "width": 320, "height": 240, "cx": 159.5, "cy": 119.5,
         "luminance_cd_m2_per_unit": GAIN,
         "note": f"office_a, {name}; bench/radiance/office_a_nodes.py"}
    if lens == "pinhole":
        c.update({"model": "pinhole", "fx": 160.0, "fy": 160.0})
    else:
        c.update({"model": "kannala_brandt", "k": FISHEYE_K, "fx": 105.0, "fy": 105.0})
    c["encodings"] = {
        "depth_png": "uint16 millimetres along the camera optical axis (z_cam), 0 = no return",
        "luminance_png": "uint16 linear, luminance_cd_per_m2 = value * luminance_cd_m2_per_unit, "
                         "clipped at 65535",
    }
    return c


def write() -> None:
    for name in CAMERAS:
        d = OUT / name
        d.mkdir(parents=True, exist_ok=True)
        (d / "camera.json").write_text(json.dumps(camera_json(name), indent=1) + "\n")
    print(f"wrote {OUT}")


def files(on: set[int]) -> list[str]:
    return ["materials.rad", "geometry.rad"] + [
        f"lum_on_{k}.rad" if k in on else f"lum_off_{k}.rad" for k in LUMINAIRES]


def render(cam: str, k: int | None, work: Path) -> None:
    c = json.loads((OUT / cam / "camera.json").read_text())
    name = f"{cam}_depth" if k is None else f"{cam}_L{k}"
    render_frame(c, name, files(set() if k is None else {k}), work, k is None, RAD)


def render_all(a) -> None:
    a.work.mkdir(parents=True, exist_ok=True)
    jobs = [(cam, None) for cam in CAMERAS] + [(cam, k) for cam in CAMERAS for k in LUMINAIRES]
    with ThreadPoolExecutor(a.jobs) as ex:
        list(ex.map(lambda j: render(j[0], j[1], a.work), jobs))


def assemble(a) -> None:
    for n, cam in enumerate(CAMERAS):
        assemble_set(OUT / cam, a.work, cam, LUMINAIRES, 300 + 10 * n)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--render", action="store_true")
    ap.add_argument("--assemble", action="store_true")
    ap.add_argument("--work", type=Path, default=Path("/tmp/office_a_nodes"))
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if not (a.write or a.render or a.assemble):
        ap.error("nothing to do")
    if a.write:
        write()
    if a.render:
        render_all(a)
    if a.assemble:
        assemble(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
