#!/usr/bin/env python3
"""Radiance's illuminance at exactly a report's own task points, for a room the node was not
tuned on (issue 32: "point by point against an independent reference at the report's own
points").

It builds the room's image and report with `luxnode image build` and `luxnode report`, reads
the task points of every desk from results.json (`desks[].task.points`, grid order), and
computes at each point, 1 mm above the desk top and facing up:

* `lux`: `rtrace -I` with every luminaire on at 100 % (the report's "new installation, every
  luminaire on"), no sky: -aa 0 -ab 8 -ad AD -lw 1e-4 -ds 0.05 -dj 1 -dt 0 -dc 1 (rooms.py's
  truth settings, more -ad), the mean of --passes passes (and their standard error);
* `covered`: whether an object of the scene (a monitor, divider or cabinet: the axis-aligned
  box of its group in scene.obj) stands on the point, i.e. the point lies strictly inside the
  box's footprint and the box's bottom is within 5 cm above it (the report's rule, read from the
  geometry, not from the report).

The room's Radiance scene is rooms.py's (`scenes/ROOM/radiance`: glazing as Radiance glass,
every luminaire's on file). Writes CSV: desk_id, x_m, y_m, z_m, lux, lux_stderr, covered.

    python3 bench/radiance/report_points.py --room room_02 --luxnode target/debug/luxnode \\
        --out tests/data/rooms/room_02/report_points.csv

Only the standard library and pyradiance (for the binaries).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from rooms import EFFICACY, RGB_Y, files_for  # noqa: E402
from open_plan_nodes import octree, rtrace  # noqa: E402

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
COVER_CLEARANCE_M = 0.05
OBJECTS = ("monitor_", "divider_", "cabinet_")


def object_boxes(obj: Path) -> list[tuple[str, list[float], list[float]]]:
    """(group, min xyz, max xyz) of every monitor, divider and cabinet group of scene.obj."""
    verts, boxes, group = [], {}, None
    for ln in obj.read_text().splitlines():
        p = ln.split()
        if not p:
            continue
        if p[0] == "v":
            verts.append([float(x) for x in p[1:4]])
        elif p[0] == "g":
            group = p[1] if len(p) > 1 else None
        elif p[0] == "f" and group and group.startswith(OBJECTS):
            for v in p[1:]:
                boxes.setdefault(group, []).append(verts[int(v.split("/")[0]) - 1])
    return [(g, [min(v[k] for v in vs) for k in range(3)], [max(v[k] for v in vs) for k in range(3)])
            for g, vs in boxes.items()]


def covered(p: dict, boxes) -> bool:
    x, y, z = p["x_m"], p["y_m"], p["z_m"]
    return any(lo[0] < x < hi[0] and lo[1] < y < hi[1] and z <= lo[2] <= z + COVER_CLEARANCE_M
               for _, lo, hi in boxes)


def report_points(luxnode: Path, scene: Path, work: Path) -> list[tuple[int, dict]]:
    img = work / "room.img"
    subprocess.run([str(luxnode), "image", "build", "--scene", str(scene), "--out", str(img)],
                   check=True, capture_output=True)
    subprocess.run([str(luxnode), "report", "--image", str(img), "--out", str(work / "report")],
                   check=True, capture_output=True)
    res = json.loads((work / "report" / "results.json").read_text())
    return [(d["id"], p) for d in res["desks"] for p in d["task"]["points"]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--room", default="room_02")
    ap.add_argument("--luxnode", type=Path, default=REPO / "target" / "debug" / "luxnode")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--ad", type=int, default=2048)
    ap.add_argument("--passes", type=int, default=2)
    a = ap.parse_args()
    scene = REPO / "scenes" / "rooms" / a.room
    rad = scene / "radiance"
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        pts = report_points(a.luxnode, scene, work)
        ids = {l["id"] for l in json.loads((scene / "luminaires.json").read_text())}
        oct_ = octree(files_for(scene, ids, False), work, "all_on", rad)
        rays = "".join(f"{p['x_m']:.6f} {p['y_m']:.6f} {p['z_m'] + 0.001:.6f} 0 0 1\n"
                       for _, p in pts)
        opts = ["-I", "-h", "-ov", "-aa", "0", "-ab", "8", "-ad", str(a.ad), "-lw", "1e-4",
                "-ds", "0.05", "-dj", "1", "-dt", "0", "-dc", "1"]
        t0 = time.time()
        vals = rtrace(opts, oct_, rays * a.passes, rad)
        dt = time.time() - t0
    boxes = object_boxes(scene / "scene.obj")
    n = len(pts)
    lux = [EFFICACY * sum(w * x for w, x in zip(RGB_Y, v[:3])) for v in vals]
    a.out.parent.mkdir(parents=True, exist_ok=True)
    with open(a.out, "w") as f:
        f.write("desk_id,x_m,y_m,z_m,lux,lux_stderr,covered\n")
        for i, (desk, p) in enumerate(pts):
            per = [lux[s * n + i] for s in range(a.passes)]
            se = statistics.stdev(per) / len(per) ** 0.5 if len(per) > 1 else 0.0
            f.write(f"{desk},{p['x_m']:.4f},{p['y_m']:.4f},{p['z_m']:.4f},"
                    f"{statistics.fmean(per):.2f},{se:.2f},{int(covered(p, boxes))}\n")
    print(f"{a.out}: {n} points, {sum(covered(p, boxes) for _, p in pts)} covered; rtrace "
          f"{' '.join(opts)}, {a.passes} passes, {dt:.0f} s")


if __name__ == "__main__":
    main()
