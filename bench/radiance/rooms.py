#!/usr/bin/env python3
"""The generalization bench of issue 28 (item 6): rooms the node was not tuned on.

It generates rooms from a seed, renders each node's capture set and live frames with Radiance,
computes the truth at the desk sensors, commissions each room with `luxnode commission` and
scores the node's desk lux against the truth: the distribution of errors over rooms and desks,
one node and two nodes, night (the model, every scenario; and the live estimate of an all-on
frame) and day (the live estimate of an all-on frame under an overcast sky through the
windows, and under a clear sky with sun), in view and out of view, with the fraction of values
whose truth lies within two stated uncertainties.

Rooms (--write). Room i of a seed is of kind i mod 8 (KINDS below: a small office, islands, a
long narrow room, an L-shaped room, a large open office, a tall square room, a room of rows
with cabinets, a deep open office); within its kind every parameter is drawn from the seed:
size (4 x 3 m to 14 x 9 m, ceiling 2.6-3.5 m), reflectances (floor 0.12-0.35, ceiling
0.70-0.90, walls 0.40-0.75, desks 0.30-0.60), the window wall (one side of the outline: 1-4
glazed openings, sill 0.8-1.0 m, transmittance 0.55-0.80), desk layout (along walls, islands
of four, rows; monitors, dividers, cabinets), a luminaire grid at 2.4-3.4 m spacing
(office_a's synthetic batwing louvre, 7913 lm, openings 3 mm below the ceiling, like every
scene of this directory), 6-10 desk-top sensors (ideal cosine, facing up; one by a wall, one
far from node a), and one or two nodes: node a a fisheye at the ceiling's centre or a pinhole
tilted 20-30 degrees toward one half of the room (walls and windows of the other half out of
view); rooms over 45 m^2 get node b. A scene directory per room in the format of the shared
scenes' README (scene.obj/.mtl with glazing as a diffuse 0.08 surface like
office_a_daylight, luminaires.json, sensors.json, desks.json, states.csv: all on, two halves,
a checkerboard, the window row off, two luminaires alone), room.json (`luxnode-room-plan/1`:
outline, heights, windows with their transmittance, site), nodes.json (the node poses and
lenses), README.md (its parameters), radiance/ (materials, geometry with the windows as
`glass`, one file per luminaire on and off, the overcast sky). `--check` runs `luxnode scene
check` on each.

Rendering (--render). open_plan_nodes.py's machinery: `rtrace` on every pixel ray of each
node's camera (pinhole, or the sim-fisheye board's Kannala-Brandt lens), with its fast
irradiance-cache settings (-ab 7 -ad 512 -as 128 -aa 0.15 -ar 128 -lw 1e-4 -ds 0.05 -dj 0.7
-dt 0; --frame-ab/--frame-ad lower them for smoke runs); frames: depth, each luminaire alone,
all luminaires (a live frame with its own noise), the overcast sky alone and the clear sky
alone (luminaires off). The clear sky is gensky's CIE clear sky with sun (+s) on 21 March at
the solar hour the first window faces the sun (`clear_hour`: 9:00-15:00; noon for a window
facing the northern half of the sky, where only the sky comes in), written to
radiance/sky_clear.rad.
Assembled as capture sets (camera.json, 3 depth frames with office_a's ToF error model,
luminance_L<k>.png at 0.02 cd/m^2 per unit) and live frames (night: all on; day: all on + the
overcast sky; clear: all on + the clear sky, where sun patches saturate the fixed gain as a
real camera's would; hazy: all on + a quarter of the clear sky (`HAZY`: a low winter sun or
haze, its sun patches below saturation, truth lux + HAZY lux_sky of truth_clear.csv); depth
with the ToF model, another seed). `--resolution WxH` scales the intrinsics (the
default 320x240 is office_a's; 80x60 for smoke runs). The fast cache's error is stated in
daylight.py: luminaire frames within 0.2 % of the truth at desk sensors (pi L / rho); sky
frames 3-17 % off at some desks, so the day column carries the renderer's error too.

Truth (--truth). `rtrace -I` at the sensors, one luminaire at a time, scenarios summed
(Radiance is linear in its sources): -aa 0 -ab 8 -ad 1024 -lw 1e-4 -ds 0.05 -dj 1 -dt 0 -dc 1,
`--seeds` passes (on office_a these settings are 0.4 % from the truth with one pass:
README.md's sweep); the direct part with -ab 0; the sky (daylight.py's gensky CIE overcast,
21 March 12:00 solar time, 47.4 N, ground 0.2) with -ad 32768 and twice the passes (the
window is a small bright source to -I's sampling). truth.csv in the shared scenes' columns
plus `lux_sky` (and `lux_sky_stderr`): the overcast sky's illuminance with every luminaire off
(the day truth of a scenario is lux + lux_sky); truth_clear.csv (`sensor_id,lux_sky,
lux_sky_stderr`) the clear sky's the same way. `--clear-sky` renders the clear frames and
computes truth_clear.csv alone, for rooms rendered before the clear day existed.

Evaluation (--evaluate). Per room: `luxnode commission` on node a's capture (one node), and
when the room has node b on node b's alone (one node (b)) and on both (two nodes), with `--room-plan room.json` as a further column
when `luxnode commission --help` offers the option (else "n/a"); night: `luxnode simulate
--image` on states.csv against truth.csv; live: `luxnode live` on each node's frame (two nodes:
per desk the node that measures it, the smaller uncertainty first; a node that sees the desk
saturated, and so publishes it as not available, or that flags the sun may be on it, over
another's inference; of two inferences, the smaller uncertainty). Desk error = sum |lux -
true| / sum true over the desk's values; in view = commission's flags (any node sees it).
Stated uncertainty: commission's per-desk relative standard uncertainty (night) and live's
uncertainty_lx (live). An image over the 4 MiB flash region (room_05's two nodes) is
commissioned again with --preset fast --precision u8, and the table says so. Prints the tables; --md FILE writes them as Markdown, --json FILE the
raw numbers.

    python3 bench/radiance/rooms.py --write --seed 28 --count 8 --out scenes/rooms --check \\
        --luxnode target/release/luxnode
    python3 bench/radiance/rooms.py --render --out scenes/rooms --work /tmp/rooms
    python3 bench/radiance/rooms.py --truth --out scenes/rooms --work /tmp/rooms --seeds 2
    python3 bench/radiance/rooms.py --evaluate --out scenes/rooms --work /tmp/rooms --md /tmp/rooms.md

Only the standard library, numpy and pyradiance (for the binaries).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import random
import shutil
import statistics
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
import open_plan_nodes as opn  # noqa: E402
from daylight import noisy_depth, quantise, sky_rad, write_png16  # noqa: E402
from open_plan import box, write_scene_files  # noqa: E402
from open_plan_nodes import assemble_set, octree, render_frame, rtrace  # noqa: E402

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
LUMINAIRE_SRC = REPO / "scenes" / "open_plan"  # office_a's batwing louvre, ldt/ies and ies2rad
FLUX_LM = 7913.0
EFFICACY = 179.0
RGB_Y = (0.265, 0.670, 0.065)
GAIN = opn.GAIN  # 0.02 cd/m^2 per unit
FISHEYE_K = opn.FISHEYE_K
SKY = ("overcast", 3, 21, 12.0)  # daylight.py's overcast_12
# The clear day: gensky's CIE clear sky with sun (+s), 21 March, at the hour the window wall
# faces the sun (`clear_hour`)
CLEAR = ("clear", 3, 21)
# the hazy day: the clear sky and its sun at this share of their strength (a low winter sun, or
# haze): Radiance is linear in its sources, so its frames and truth are the clear day's scaled,
# and its sun patches stay below the camera's saturation, where the node can fit the sun
HAZY = 0.25
SITE = {"latitude_deg": 47.4, "longitude_deg": 8.5, "north": [0.0, -1.0]}  # daylight.py's
GLAZING_RHO = 0.08
DESK_Z = 0.75

KINDS = [
    # name, W range, D range, H range, layout, node a lens, two nodes when large
    ("small office", (4.0, 5.2), (3.0, 3.8), (2.6, 2.8), "walls", "fisheye"),
    ("office with islands", (6.5, 8.0), (5.0, 6.0), (2.7, 3.0), "islands", "pinhole_tilted"),
    ("long narrow office", (10.0, 13.0), (4.0, 4.8), (2.7, 3.0), "rows", "fisheye"),
    ("L-shaped office", (9.0, 11.0), (7.0, 8.5), (2.8, 3.1), "islands", "fisheye"),
    ("large open office", (12.0, 14.0), (8.0, 9.0), (3.0, 3.3), "islands", "pinhole_tilted"),
    ("tall square room", (6.5, 7.5), (6.5, 7.5), (3.2, 3.5), "rows", "fisheye"),
    ("room of rows with cabinets", (8.0, 9.5), (5.5, 6.5), (2.8, 3.0), "rows", "pinhole_tilted"),
    ("deep open office", (9.0, 11.0), (7.0, 9.0), (2.9, 3.2), "mixed", "pinhole"),
]

# ------------------------------------------------------------------ geometry helpers


def r3(x: float) -> float:
    return round(x, 3)


def rect_in_notch(x0, x1, y0, y1, notch, margin=0.0) -> bool:
    if notch is None:
        return False
    nx0, ny0 = notch
    return x1 > nx0 - margin and y1 > ny0 - margin


def overlaps(a, b, margin) -> bool:
    return not (a[1] + margin <= b[0] or b[1] + margin <= a[0] or
                a[3] + margin <= b[2] or b[3] + margin <= a[2])


def outline_of(w, d, notch) -> list[list[float]]:
    if notch is None:
        return [[0.0, 0.0], [w, 0.0], [w, d], [0.0, d]]
    nx, ny = notch
    return [[0.0, 0.0], [w, 0.0], [w, ny], [nx, ny], [nx, d], [0.0, d]]


def dist_to_outline(x, y, outline) -> float:
    best = 1e9
    n = len(outline)
    for i in range(n):
        (ax, ay), (bx, by) = outline[i], outline[(i + 1) % n]
        dx, dy = bx - ax, by - ay
        t = max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)))
        best = min(best, math.hypot(x - ax - t * dx, y - ay - t * dy))
    return best


class Room:
    """One generated room: parameters and furniture (rectangles), then written as files."""

    def __init__(self, seed: int, index: int):
        self.index = index
        self.name = f"room_{index + 1:02d}"
        rng = random.Random(seed * 1000 + index)
        kind = KINDS[index % len(KINDS)]
        self.kind, wr, dr, hr, self.layout, self.lens_a = kind
        u = lambda a, b: round(rng.uniform(a, b), 1)  # noqa: E731
        self.w, self.d, self.h = u(*wr), u(*dr), round(rng.uniform(*hr), 2)
        self.notch = None
        if self.kind == "L-shaped office":
            self.notch = (round(self.w * rng.uniform(0.55, 0.65), 1),
                          round(self.d * rng.uniform(0.5, 0.6), 1))
        self.outline = outline_of(self.w, self.d, self.notch)
        self.rho = {"floor": round(rng.uniform(0.12, 0.35), 2),
                    "ceiling": round(rng.uniform(0.70, 0.90), 2),
                    "wall": round(rng.uniform(0.40, 0.75), 2),
                    "desk": round(rng.uniform(0.30, 0.60), 2),
                    "monitor": 0.10, "divider": round(rng.uniform(0.30, 0.55), 2),
                    "cabinet": round(rng.uniform(0.30, 0.55), 2),
                    "glazing": GLAZING_RHO}
        self.lum_z = round(self.h - 0.003, 3)
        self.cam_z = round(self.h - 0.02, 3)
        self._windows(rng)
        self._luminaires(rng)
        self.desks, self.monitors, self.dividers, self.cabinets = [], [], [], []
        self._furniture(rng)
        self._nodes(rng)
        self._sensors(rng)
        self._states()

    # ---- windows: 1-4 openings on one side of the outline
    def _windows(self, rng):
        n = len(self.outline)
        # an edge of full length (for the L: the south or west side)
        edges = [0, 1, 2, 3] if self.notch is None else [0, 5]
        self.window_edge = rng.choice(edges)
        p, q = self.outline[self.window_edge], self.outline[(self.window_edge + 1) % n]
        length = math.dist(p, q)
        self.transmittance = round(rng.uniform(0.55, 0.80), 2)
        sill = round(rng.uniform(0.8, 1.0), 2)
        head = round(min(self.h - 0.25, rng.uniform(2.1, 2.5)), 2)
        count = max(1, min(4, int(length / rng.uniform(2.5, 3.5))))
        width = round(min(length / count - 0.4, rng.uniform(1.2, 2.2)), 2)
        pitch = length / count
        self.windows = [(r3(pitch * (i + 0.5) - width / 2), r3(pitch * (i + 0.5) + width / 2),
                         sill, head) for i in range(count)]

    def wall_point(self, edge: int, t: float, z: float):
        n = len(self.outline)
        p, q = self.outline[edge], self.outline[(edge + 1) % n]
        length = math.dist(p, q)
        return (r3(p[0] + (q[0] - p[0]) * t / length), r3(p[1] + (q[1] - p[1]) * t / length), z)

    def window_quads(self):
        out = []
        for k, (t0, t1, s, h) in enumerate(self.windows):
            e = self.window_edge
            out.append((f"window_{k + 1}", [self.wall_point(e, t0, s), self.wall_point(e, t0, h),
                                            self.wall_point(e, t1, h), self.wall_point(e, t1, s)]))
        return out

    # ---- luminaires: a grid matched to the room
    def _luminaires(self, rng):
        sp = rng.uniform(2.4, 3.4)
        nx, ny = max(2, round(self.w / sp)), max(1, round(self.d / sp))
        self.lum_spacing = (round(self.w / nx, 2), round(self.d / ny, 2))
        self.luminaires = []
        for j in range(ny):
            for i in range(nx):
                x, y = r3(self.w * (i + 0.5) / nx), r3(self.d * (j + 0.5) / ny)
                if rect_in_notch(x - 0.3, x + 0.3, y - 0.3, y + 0.3, self.notch, 0.4):
                    continue
                k = len(self.luminaires) + 1
                self.luminaires.append({
                    "id": k, "name": f"luminaire_{k}", "position": [x, y, self.lum_z],
                    "aim": [0.0, 0.0, -1.0], "rotation_deg": 0.0,
                    "c0_direction": [1.0, 0.0, 0.0], "c90_direction": [0.0, 1.0, 0.0],
                    "photometry_ldt": "luminaire.ldt", "photometry_ies": "luminaire.ies",
                    "flux_lm": FLUX_LM, "luminous_opening_m": [0.6, 0.6]})

    # ---- furniture
    def fits(self, r, margin) -> bool:
        x0, x1, y0, y1 = r
        if x0 < 0.0 or y0 < 0.0 or x1 > self.w or y1 > self.d:
            return False
        if rect_in_notch(x0, x1, y0, y1, self.notch, 0.01):
            return False
        occupied = [(d["x0"], d["x1"], d["y0"], d["y1"]) for d in self.desks]
        occupied += [c[:4] for c in self.cabinets] + [c[:4] for c in self.dividers]
        return all(not overlaps(r, o, margin) for o in occupied)

    def add_desk(self, x0, y0, dw, dd, monitor: str | None, where: str) -> bool:
        r = (r3(x0), r3(x0 + dw), r3(y0), r3(y0 + dd))
        if not self.fits(r, 0.0 if where in ("island", "row") else 0.7):
            return False
        k = len(self.desks) + 1
        self.desks.append({"id": k, "group": f"desk_{k}", "x0": r[0], "x1": r[1], "y0": r[2],
                           "y1": r[3], "z": DESK_Z, "where": where})
        if monitor:
            cx = (r[0] + r[1]) / 2
            if monitor == "+y":
                m = (cx - 0.28, cx + 0.28, r[3] - 0.13, r[3] - 0.10)
            else:
                m = (cx - 0.28, cx + 0.28, r[2] + 0.10, r[2] + 0.13)
            self.monitors.append(tuple(r3(v) for v in m) + (k, monitor))
        return True

    def _wall_desks(self, rng, count, dw, dd, mon):
        """Desks against walls (2 cm off), along the rectangle's sides."""
        sides = [0, 1, 2, 3]
        rng.shuffle(sides)
        placed = 0
        for side in sides:
            along = self.w if side in (0, 2) else self.d
            t = rng.uniform(0.3, 1.0)
            while t + dw < along - 0.3 and placed < count:
                if side == 0:
                    ok = self.add_desk(t, 0.02, dw, dd, mon and "-y", "wall")
                elif side == 2:
                    ok = self.add_desk(t, self.d - 0.02 - dd, dw, dd, mon and "+y", "wall")
                elif side == 1:
                    ok = self.add_desk(self.w - 0.02 - dd, t, dd, dw, None, "wall")
                else:
                    ok = self.add_desk(0.02, t, dd, dw, None, "wall")
                placed += ok
                t += dw + (rng.uniform(0.1, 0.8) if ok else 0.3)
            if placed >= count:
                return

    def _islands(self, rng, dw, dd, mon, dividers):
        iw, idd = 2 * dw, 2 * dd
        aisle = rng.uniform(1.3, 1.8)
        nx = max(1, int((self.w - 1.2) / (iw + aisle)))
        ny = max(1, int((self.d - 1.2) / (idd + aisle)))
        gx = (self.w - nx * iw) / (nx + 1)
        gy = (self.d - ny * idd) / (ny + 1)
        for j in range(ny):
            for i in range(nx):
                x0, y0 = gx + i * (iw + gx), gy + j * (idd + gy)
                if rect_in_notch(x0, x0 + iw, y0, y0 + idd, self.notch, 0.8):
                    continue
                if not self.fits((x0, x0 + iw, y0, y0 + idd), 0.7):
                    continue
                for a in range(2):
                    for b in range(2):
                        self.add_desk(x0 + a * dw, y0 + b * dd, dw, dd,
                                      (mon and ("+y" if b == 0 else "-y")), "island")
                if dividers and i + 1 < nx:
                    xd = x0 + iw + gx / 2
                    r = (r3(xd - 0.02), r3(xd + 0.02), r3(y0), r3(y0 + idd),
                         round(rng.uniform(1.2, 1.5), 2))
                    if self.fits(r[:4], 0.3):
                        self.dividers.append(r)

    def _rows(self, rng, dw, dd, mon):
        pitch = dd + rng.uniform(1.1, 1.5)
        y = rng.uniform(1.0, 1.4)
        while y + dd < self.d - 0.9:
            x = rng.uniform(0.9, 1.3)
            while x + dw < self.w - 0.9:
                self.add_desk(x, y, dw, dd, mon and "+y", "row")
                x += dw + rng.choice([0.0, 0.0, 0.1])
            y += pitch

    def _cabinets(self, rng, count):
        for _ in range(count * 6):
            if len(self.cabinets) >= count:
                return
            side = rng.choice([s for s in (0, 1, 2, 3) if s != self.window_edge] or [0])
            cw, depth, hh = rng.uniform(0.8, 2.4), 0.45, round(rng.uniform(0.8, 2.0), 2)
            along = self.w if side in (0, 2) else self.d
            t = rng.uniform(0.2, max(0.3, along - cw - 0.2))
            if side == 0:
                r = (t, t + cw, 0.001, depth)
            elif side == 2:
                r = (t, t + cw, self.d - depth, self.d - 0.001)
            elif side == 1:
                r = (self.w - depth, self.w - 0.001, t, t + cw)
            else:
                r = (0.001, depth, t, t + cw)
            r = tuple(r3(v) for v in r)
            if self.fits(r, 0.6):
                self.cabinets.append(r + (hh,))

    def _furniture(self, rng):
        dw, dd = rng.choice([1.4, 1.6, 1.6, 1.8]), rng.choice([0.7, 0.8, 0.8])
        mon = rng.random() < 0.7
        if self.kind == "room of rows with cabinets":
            self._cabinets(rng, 3)
        elif self.kind in ("large open office", "deep open office"):
            self._cabinets(rng, 1)
        if self.layout == "walls":
            self._wall_desks(rng, 6, dw, dd, mon)
        elif self.layout == "islands":
            self._islands(rng, dw, dd, mon, dividers=self.kind != "office with islands")
            self._wall_desks(rng, 2, dw, dd, mon)
        elif self.layout == "rows":
            self._rows(rng, dw, dd, True)
            self._wall_desks(rng, 2, dw, dd, False)
        else:
            self._islands(rng, dw, dd, mon, dividers=True)
            self._wall_desks(rng, 3, dw, dd, mon)
        if not any(d["where"] == "wall" for d in self.desks):
            self._wall_desks(rng, 1, 1.2, 0.6, False)

    # ---- nodes
    def _free_spot(self, x, y):
        """(x, y) moved to the nearest point 0.45 m (Chebyshev) from every luminaire centre."""
        best = None
        for r in np.arange(0.0, 2.01, 0.25):
            for ang in range(0, 360, 45):
                px, py = x + r * math.cos(math.radians(ang)), y + r * math.sin(math.radians(ang))
                if rect_in_notch(px, px, py, py, self.notch, 0.5):
                    continue
                if all(max(abs(px - l["position"][0]), abs(py - l["position"][1])) >= 0.45
                       for l in self.luminaires):
                    best = (r3(px), r3(py))
                    break
            if best:
                return best
        return (r3(x), r3(y))

    def _nodes(self, rng):
        area = self.w * self.d - (0 if self.notch is None else
                                  (self.w - self.notch[0]) * (self.d - self.notch[1]))
        self.area = round(area, 1)
        two = area > 45.0
        if self.notch is not None:  # one node in each leg of the L
            pa = (self.notch[0] / 2, self.d * 0.65)
            pb = ((self.notch[0] + self.w) / 2, self.notch[1] / 2)
        elif two:
            pa, pb = (self.w * 0.27, self.d / 2), (self.w * 0.73, self.d / 2)
        else:
            pa, pb = (self.w / 2, self.d / 2), None
        self.nodes = []
        tilt = rng.uniform(20.0, 30.0) * rng.choice([-1, 1])
        lens_b = {"fisheye": "pinhole", "pinhole_tilted": "fisheye", "pinhole": "pinhole_tilted"}
        for nid, p, lens in (("a", pa, self.lens_a), ("b", pb, lens_b[self.lens_a])):
            if p is None:
                continue
            x, y = self._free_spot(*p)
            t = tilt if lens == "pinhole_tilted" else 0.0
            if nid == "b":
                t = -t
            self.nodes.append(camera_pose(nid, lens, (x, y, self.cam_z), t))

    # ---- sensors
    def _sensors(self, rng):
        a = self.nodes[0]["position"]
        n_target = rng.randint(6, 10)
        mons = {m[4]: m for m in self.monitors}

        def spot(d, half):
            """A point 0.2 m inside the top and clear of its monitor; half 0/1: that half of
            the desk's long side (a desk with two sensors), None: anywhere."""
            lo_x, hi_x, lo_y, hi_y = d["x0"] + 0.2, d["x1"] - 0.2, d["y0"] + 0.2, d["y1"] - 0.2
            m = mons.get(d["id"])
            if m and m[5] == "+y":
                hi_y = d["y1"] - 0.25
            elif m:
                lo_y = d["y0"] + 0.25
            if half is not None:
                if hi_x - lo_x >= hi_y - lo_y:
                    mid = (lo_x + hi_x) / 2
                    lo_x, hi_x = (lo_x, mid - 0.1) if half == 0 else (mid + 0.1, hi_x)
                else:
                    mid = (lo_y + hi_y) / 2
                    lo_y, hi_y = (lo_y, mid - 0.1) if half == 0 else (mid + 0.1, hi_y)
            return (r3(rng.uniform(lo_x, hi_x)), r3(rng.uniform(lo_y, hi_y)))

        chosen, notes = [], {}
        wall = sorted(self.desks, key=lambda d: dist_to_outline((d["x0"] + d["x1"]) / 2,
                                                                  (d["y0"] + d["y1"]) / 2,
                                                                  self.outline))
        far = sorted(self.desks, key=lambda d: -math.hypot((d["x0"] + d["x1"]) / 2 - a[0],
                                                            (d["y0"] + d["y1"]) / 2 - a[1]))
        chosen.append(wall[0])
        notes[wall[0]["id"]] = "by a wall"
        if far[0] is not wall[0]:
            chosen.append(far[0])
            notes[far[0]["id"]] = "far from node a"
        rest = [d for d in self.desks if d not in chosen]
        rng.shuffle(rest)
        chosen += rest[: max(0, n_target - len(chosen))]
        extra = [d for d in self.desks if d["x1"] - d["x0"] >= 1.2 or d["y1"] - d["y0"] >= 1.2]
        rng.shuffle(extra)
        while len(chosen) < max(6, min(n_target, 2 * len(self.desks))) and extra:
            chosen.append(extra.pop())
        self.sensors = []
        seen: dict[int, int] = {}
        for d in chosen:
            twice = sum(1 for c in chosen if c is d) > 1
            x, y = spot(d, seen.get(d["id"], 0) if twice else None)
            seen[d["id"]] = seen.get(d["id"], 0) + 1
            k = len(self.sensors) + 1
            note = f"desk {d['id']} ({d['where']})"
            if d["id"] in notes:
                note += ", " + notes[d["id"]]
            self.sensors.append({"id": k, "position": [x, y, 0.751], "normal": [0.0, 0.0, 1.0],
                                 "note": note})

    def _states(self):
        ids = [l["id"] for l in self.luminaires]
        pos = {l["id"]: l["position"] for l in self.luminaires}
        west = [i for i in ids if pos[i][0] < self.w / 2] or ids[:1]
        east = [i for i in ids if pos[i][0] >= self.w / 2] or ids[-1:]
        xs = sorted({pos[i][0] for i in ids})
        ys = sorted({pos[i][1] for i in ids})
        checker = [i for i in ids if (xs.index(pos[i][0]) + ys.index(pos[i][1])) % 2 == 0]
        # the row of luminaires nearest the window wall off (daylight harvesting)
        e = self.window_edge
        n = len(self.outline)
        p, q = self.outline[e], self.outline[(e + 1) % n]
        dwin = {i: dist_to_outline_segment(pos[i][0], pos[i][1], p, q) for i in ids}
        near = min(dwin.values())
        window_off = [i for i in ids if dwin[i] > near + 0.5] or ids
        a = self.nodes[0]["position"]
        by_dist = sorted(ids, key=lambda i: math.hypot(pos[i][0] - a[0], pos[i][1] - a[1]))
        self.states = [(1, ids), (2, west), (3, east), (4, checker), (5, window_off),
                       (6, [by_dist[0]]), (7, [by_dist[-1]])]

    # ---- geometry as quads (group, material, corners CCW seen from the front)
    def quads(self):
        q = []
        rects = ([(0, self.w, 0, self.d)] if self.notch is None else
                 [(0, self.w, 0, self.notch[1]), (0, self.notch[0], self.notch[1], self.d)])
        for x0, x1, y0, y1 in rects:
            q.append(("floor", "floor", [(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)]))
        for x0, x1, y0, y1 in rects:
            q.append(("ceiling", "ceiling", [(x0, y1, self.h), (x1, y1, self.h),
                                             (x1, y0, self.h), (x0, y0, self.h)]))
        n = len(self.outline)
        for e in range(n):
            p, qq = self.outline[e], self.outline[(e + 1) % n]
            length = math.dist(p, qq)
            g = f"wall_{e + 1}"
            wp = lambda t, z: self.wall_point(e, t, z)  # noqa: E731
            if e != self.window_edge:
                q.append((g, "wall", [wp(0, 0), wp(0, self.h), wp(length, self.h), wp(length, 0)]))
                continue
            s, hd = self.windows[0][2], self.windows[0][3]
            q.append((g, "wall", [wp(0, 0), wp(0, s), wp(length, s), wp(length, 0)]))
            q.append((g, "wall", [wp(0, hd), wp(0, self.h), wp(length, self.h), wp(length, hd)]))
            t = 0.0
            for t0, t1, _, _ in self.windows + [(length, length, s, hd)]:
                if t0 > t + 1e-6:
                    q.append((g, "wall", [wp(t, s), wp(t, hd), wp(t0, hd), wp(t0, s)]))
                t = t1
        for name, c in self.window_quads():
            q.append((name, "glazing", c))
        for d in self.desks:
            q += box(d["group"], "desk", d["x0"], d["x1"], d["y0"], d["y1"], 0.72, DESK_Z)
        for k, m in enumerate(self.monitors):
            q += box(f"monitor_{k + 1}", "monitor", m[0], m[1], m[2], m[3], DESK_Z + 0.002,
                     DESK_Z + 0.42)
        for k, r in enumerate(self.dividers):
            q += box(f"divider_{k + 1}", "divider", r[0], r[1], r[2], r[3], 0.0, r[4])
        for k, r in enumerate(self.cabinets):
            q += box(f"cabinet_{k + 1}", "cabinet", r[0], r[1], r[2], r[3], 0.0, r[4])
        for l in self.luminaires:
            x, y, _ = l["position"]
            z = self.lum_z
            q.append((l["name"], "luminaire_opening",
                      [(x - 0.3, y - 0.3, z), (x - 0.3, y + 0.3, z), (x + 0.3, y + 0.3, z),
                       (x + 0.3, y - 0.3, z)]))
        return q

    def room_plan(self) -> dict:
        return {"format": "luxnode-room-plan/1", "outline_m": self.outline, "floor_z_m": 0.0,
                "ceiling_z_m": self.h,
                "windows": [{"id": name.replace("window_", "w"), "corners_m": [list(p) for p in c],
                             "transmittance": self.transmittance}
                            for name, c in self.window_quads()],
                "site": SITE}

    def params(self) -> dict:
        return {"name": self.name, "kind": self.kind, "size_m": [self.w, self.d, self.h],
                "area_m2": self.area, "outline_m": self.outline, "notch": self.notch,
                "reflectances": self.rho, "window_wall": self.window_edge + 1,
                "windows": len(self.windows), "transmittance": self.transmittance,
                "layout": self.layout, "desks": len(self.desks), "monitors": len(self.monitors),
                "dividers": len(self.dividers), "cabinets": len(self.cabinets),
                "luminaires": len(self.luminaires), "luminaire_spacing_m": self.lum_spacing,
                "sensors": len(self.sensors),
                "nodes": [f"{n['id']}: {n['lens']} at ({n['position'][0]}, {n['position'][1]})"
                          + (f", tilted {n['tilt_deg']:+.0f} deg" if n["tilt_deg"] else "")
                          for n in self.nodes]}


def dist_to_outline_segment(x, y, p, q) -> float:
    dx, dy = q[0] - p[0], q[1] - p[1]
    t = max(0.0, min(1.0, ((x - p[0]) * dx + (y - p[1]) * dy) / (dx * dx + dy * dy)))
    return math.hypot(x - p[0] - t * dx, y - p[1] - t * dy)


def camera_pose(nid: str, lens: str, pos, tilt_deg: float) -> dict:
    """A node's pose: pinhole image x along the room's y (office_a's), tilted about it so that
    the optical axis leans toward +x (tilt > 0) or -x; fisheye image x along the room's x
    (open_plan_nodes')."""
    if lens.startswith("pinhole"):
        t = math.radians(tilt_deg)
        x = np.array([0.0, 1.0, 0.0])
        y = np.array([math.cos(t), 0.0, math.sin(t)])
        z = np.array([math.sin(t), 0.0, -math.cos(t)])
    else:
        x, y, z = np.array([1.0, 0, 0]), np.array([0, -1.0, 0]), np.array([0, 0, -1.0])
    r = np.column_stack([x, y, z])
    return {"id": nid, "lens": "pinhole" if lens.startswith("pinhole") else "fisheye",
            "tilt_deg": round(tilt_deg, 1), "position": [pos[0], pos[1], pos[2]],
            "R_world_from_camera": [[round(v, 6) for v in row] for row in r.tolist()]}


def camera_json(node: dict, width: int, height: int, room: str) -> dict:
    s = width / 320.0
    c = {"position": node["position"], "R_world_from_camera": node["R_world_from_camera"],
         "width": width, "height": height, "cx": (width - 1) / 2, "cy": (height - 1) / 2,
         "luminance_cd_m2_per_unit": GAIN,
         "note": f"{room}, node {node['id']} ({node['lens']}); bench/radiance/rooms.py"}
    if node["lens"] == "pinhole":
        c.update({"model": "pinhole", "fx": 160.0 * s, "fy": 160.0 * s})
    else:
        c.update({"model": "kannala_brandt", "k": FISHEYE_K, "fx": 105.0 * s, "fy": 105.0 * s})
    c["encodings"] = {
        "depth_png": "uint16 millimetres along the camera optical axis (z_cam), 0 = no return",
        "luminance_png": "uint16 linear, luminance_cd_per_m2 = value * luminance_cd_m2_per_unit, "
                         "clipped at 65535",
    }
    return c


# ------------------------------------------------------------------ writing


def glass_transmissivity(tn: float) -> float:
    """Radiance `glass` transmissivity for a normal-incidence transmittance (Radiance manual)."""
    return (math.sqrt(0.8402528435 + 0.0072522239 * tn * tn) - 0.9166530661) / 0.0036261119 / tn


def poly(mat: str, name: str, pts) -> str:
    coords = "\n".join("\t{:.6f} {:.6f} {:.6f}".format(*p) for p in pts)
    return f"{mat} polygon {name}\n0\n0\n{3 * len(pts)}\n{coords}\n"


def write_room(room: Room, out: Path) -> Path:
    d = out / room.name
    desks = [{k: v for k, v in x.items() if k != "where"} for x in room.desks]
    write_scene_files(d, room.name, room.rho, room.quads(), room.luminaires, room.sensors, desks,
                      room.states, 0.25)
    obj = (d / "scene.obj").read_text().split("\n", 1)
    (d / "scene.obj").write_text(
        f"# generated room '{room.name}' (bench/radiance/rooms.py): metres, z up, CCW front faces\n"
        + obj[1])
    for f in ("luminaire.ldt", "luminaire.ies"):
        shutil.copy(LUMINAIRE_SRC / f, d / f)
    (d / "room.json").write_text(json.dumps(room.room_plan(), indent=1) + "\n")
    (d / "nodes.json").write_text(json.dumps(room.nodes, indent=1) + "\n")
    rad = d / "radiance"
    rad.mkdir(exist_ok=True)
    for f in ("luminaire.rad", "luminaire.dat"):
        shutil.copy(LUMINAIRE_SRC / "radiance" / f, rad / f)
    tg = glass_transmissivity(room.transmittance)
    with open(rad / "materials.rad", "w") as f:
        for m, r in room.rho.items():
            if m == "glazing":
                f.write(f"# normal-incidence transmittance {room.transmittance}\n"
                        f"void glass glazing\n0\n0\n3 {tg:.4f} {tg:.4f} {tg:.4f}\n\n")
            else:
                f.write(f"void plastic {m}\n0\n0\n5 {r} {r} {r} 0 0\n\n")
        f.write("void plastic luminaire_off\n0\n0\n5 0 0 0 0 0\n\n")
    with open(rad / "geometry.rad", "w") as f:
        for k, (g, m, c) in enumerate(room.quads()):
            if m != "luminaire_opening":
                f.write(poly(m, f"{g}.{k}", c))
    for l in room.luminaires:
        x, y, _ = l["position"]
        z = room.lum_z
        (rad / f"lum_on_{l['id']}.rad").write_text(
            f"!xform -n {l['name']} -t {x} {y} {z + 0.00025:.6f} luminaire.rad\n")
        (rad / f"lum_off_{l['id']}.rad").write_text(poly(
            "luminaire_off", f"{l['name']}.off",
            [(x - 0.3, y - 0.3, z), (x - 0.3, y + 0.3, z), (x + 0.3, y + 0.3, z),
             (x + 0.3, y - 0.3, z)]))
    (rad / "sky_overcast.rad").write_text(sky_rad(SKY[1], SKY[2], SKY[3], SKY[0]))
    p = room.params()
    rho = ", ".join(f"{k} {v}" for k, v in room.rho.items())
    lines = [
        f"# {room.name}: {room.kind}",
        "",
        "Generated by `bench/radiance/rooms.py --write` (issue 28's generalization bench); do not",
        "edit by hand. Scene format of the shared scenes' README; `room.json` is its room plan",
        "(`luxnode-room-plan/1`), `nodes.json` the node poses (camera.json is written at render",
        "time, at the rendered resolution).",
        "",
        f"- Size {room.w} x {room.d} m, ceiling {room.h} m, floor area {room.area} m²"
        + (f"; L-shaped: the corner x > {room.notch[0]}, y > {room.notch[1]} m is not room"
           if room.notch else "") + ".",
        f"- Reflectances: {rho}.",
        f"- Window wall: wall_{room.window_edge + 1} ({len(room.windows)} glazed openings, "
        f"sill {room.windows[0][2]} m, head {room.windows[0][3]} m, transmittance "
        f"{room.transmittance}; Radiance glass transmissivity {tg:.3f}; in scene.obj a diffuse "
        f"{GLAZING_RHO} surface).",
        f"- {len(room.luminaires)} luminaires (office_a's batwing louvre, 7913 lm) at "
        f"{room.lum_spacing[0]} x {room.lum_spacing[1]} m.",
        f"- Layout: {room.layout}; {len(room.desks)} desks, {len(room.monitors)} monitors, "
        f"{len(room.dividers)} dividers, {len(room.cabinets)} cabinets.",
        f"- {len(room.sensors)} desk sensors (ideal cosine, facing up): "
        + "; ".join(f"{s['id']}: {s['note']}" for s in room.sensors) + ".",
        "- Nodes: " + "; ".join(p["nodes"]) + f" (camera {room.cam_z} m above the floor).",
        "- States: " + "; ".join(f"{sid}: {len(on)} on" for sid, on in room.states)
        + " (all, west half, east half, checkerboard, window row off, the luminaire nearest "
          "node a alone, the farthest alone).",
        "",
        "```json",
        json.dumps(p),
        "```",
    ]
    (d / "README.md").write_text("\n".join(lines) + "\n")
    return d


def rel(p: Path) -> str:
    try:
        return str(p.resolve().relative_to(REPO))
    except ValueError:
        return p.name


def rooms_in(out: Path) -> list[Path]:
    return sorted(p for p in out.glob("room_*") if (p / "nodes.json").exists())


def write_all(a) -> None:
    a.out.mkdir(parents=True, exist_ok=True)
    dirs = []
    for i in range(a.count):
        room = Room(a.seed, i)
        d = write_room(room, a.out)
        dirs.append(d)
        p = room.params()
        print(f"{room.name}: {room.kind}, {room.w} x {room.d} x {room.h} m, "
              f"{len(room.luminaires)} luminaires, {len(room.desks)} desks, "
              f"{len(room.sensors)} sensors, nodes {', '.join(p['nodes'])}")
    (a.out / "README.md").write_text(
        "# Generated rooms (issue 28's generalization bench)\n\n"
        f"`python3 bench/radiance/rooms.py --write --seed {a.seed} --count {a.count} --out "
        f"{rel(a.out)}`; each room's README gives its "
        "parameters. Method and results: `bench/radiance/rooms.md`.\n")
    if a.check:
        lux = luxnode_bin(a)
        for d in dirs:
            p = subprocess.run([str(lux), "scene", "check", str(d)], capture_output=True,
                               text=True)
            last = [ln for ln in p.stdout.splitlines() if ln.strip()][-1:] or [""]
            print(f"scene check {d.name}: {'ok' if p.returncode == 0 else 'FAILED'} "
                  f"{last[0].strip()[:100]}")
            if p.returncode != 0:
                print(p.stdout[-2000:], p.stderr[-2000:])


# ------------------------------------------------------------------ rendering


def files_for(d: Path, on: set[int], sky: str | None) -> list[str]:
    """The Radiance files of a frame: these luminaires on, the others' openings dark, and the
    sky `sky` ("overcast", "clear") or none."""
    lums = json.loads((d / "luminaires.json").read_text())
    f = ["materials.rad", "geometry.rad"] + [
        f"lum_on_{l['id']}.rad" if l["id"] in on else f"lum_off_{l['id']}.rad" for l in lums]
    return f + ([f"sky_{sky}.rad"] if sky else [])


def inside_outline(pts: list, x: float, y: float) -> bool:
    """Even-odd test of (x, y) against a polygon."""
    inside = False
    for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1]):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


def window_azimuth_deg(d: Path) -> float | None:
    """Compass azimuth (0 north, 90 east) of the first window's outward normal, from room.json
    (its outline, its site's north); None without a window."""
    plan = json.loads((d / "room.json").read_text())
    wins = plan.get("windows") or []
    if not wins:
        return None
    c = wins[0]["corners_m"]
    ex, ey = c[3][0] - c[0][0], c[3][1] - c[0][1]
    ln = math.hypot(ex, ey)
    nx, ny = ey / ln, -ex / ln
    mx = sum(p[0] for p in c) / len(c)
    my = sum(p[1] for p in c) / len(c)
    if inside_outline(plan["outline_m"], mx + 0.05 * nx, my + 0.05 * ny):
        nx, ny = -nx, -ny
    north = plan.get("site", SITE)["north"]
    east = (north[1], -north[0])  # north turned 90 degrees clockwise, seen from above
    return math.degrees(math.atan2(nx * east[0] + ny * east[1],
                                   nx * north[0] + ny * north[1])) % 360.0


def clear_hour(d: Path) -> float:
    """The solar hour of the clear day: when the sun's azimuth (15 degrees an hour from south
    at noon) faces the window wall, within 9:00-15:00, to the half hour; noon for a window
    that faces the northern half of the sky (no sun comes in, the sky does)."""
    az = window_azimuth_deg(d)
    if az is None or math.cos(math.radians(az - 180.0)) <= 0.0:
        return 12.0
    return min(15.0, max(9.0, round(2.0 * (12.0 + (az - 180.0) / 15.0)) / 2.0))


def write_clear_sky(d: Path) -> None:
    """radiance/sky_clear.rad of room d (the sky file rotates gensky's north to the site's -y,
    the plans' SITE north)."""
    north = json.loads((d / "room.json").read_text()).get("site", SITE)["north"]
    if north != SITE["north"]:
        sys.exit(f"{d.name}: the clear sky is written for north {SITE['north']}, not {north}")
    (d / "radiance" / "sky_clear.rad").write_text(
        sky_rad(CLEAR[1], CLEAR[2], clear_hour(d), CLEAR[0]))


def res_dir(a, d: Path) -> Path:
    return a.work / d.name / f"{a.width}x{a.height}"


def set_frame_opts(a) -> list[str]:
    opts = list(opn.FRAME_OPTS)
    for flag, val in (("-ab", a.frame_ab), ("-ad", a.frame_ad)):
        if val is not None:
            opts[opts.index(flag) + 1] = str(val)
    opn.FRAME_OPTS = opts  # render_frame reads the module's settings
    return opts


def render_room(a, d: Path) -> float:
    nodes = json.loads((d / "nodes.json").read_text())
    ids = [l["id"] for l in json.loads((d / "luminaires.json").read_text())]
    rd = res_dir(a, d)
    frames = rd / "frames"
    frames.mkdir(parents=True, exist_ok=True)
    rad = d / "radiance"
    write_clear_sky(d)
    jobs = []
    for n in nodes:
        c = camera_json(n, a.width, a.height, d.name)
        cam = f"node_{n['id']}"
        jobs.append((c, f"{cam}_sky", files_for(d, set(), "overcast"), False))
        jobs.append((c, f"{cam}_clear", files_for(d, set(), "clear"), False))
        jobs.append((c, f"{cam}_all", files_for(d, set(ids), None), False))
        jobs += [(c, f"{cam}_L{k}", files_for(d, {k}, None), False) for k in ids]
        jobs.append((c, f"{cam}_depth", files_for(d, set(), None), True))
    t0 = time.time()
    with ThreadPoolExecutor(a.jobs) as ex:
        list(ex.map(lambda j: render_frame(j[0], j[1], j[2], frames, j[3], rad), jobs))
    dt = time.time() - t0
    for o in frames.glob("*.oct"):
        o.unlink()
    # assembly: capture sets and live frames
    live = rd / "live"
    live.mkdir(exist_ok=True)
    for i, n in enumerate(nodes):
        cam = f"node_{n['id']}"
        cap = rd / cam
        cap.mkdir(exist_ok=True)
        c = camera_json(n, a.width, a.height, d.name)
        (cap / "camera.json").write_text(json.dumps(c, indent=1) + "\n")
        assemble_set(cap, frames, cam, ids, 500 + 10 * i)
        z = np.load(frames / f"{cam}_depth.npy")
        write_png16(live / f"{cam}_depth.png", noisy_depth(z, 900 + i))
        all_on = np.load(frames / f"{cam}_all.npy")
        sky = np.load(frames / f"{cam}_sky.npy")
        write_png16(live / f"{cam}_night.png", quantise(all_on, GAIN))
        clear = np.load(frames / f"{cam}_clear.npy")
        for light, frame in (("day", sky), ("clear", clear), ("hazy", HAZY * clear)):
            q = quantise(all_on + frame, GAIN)
            write_png16(live / f"{cam}_{light}.png", q)
            print(f"{d.name} {cam}: {light} frame {100 * float(np.mean(q == 65535)):.1f} % "
                  "saturated")
    return dt


def render_all(a) -> None:
    opts = set_frame_opts(a)
    timings = load_timings(a)
    for d in selected(a):
        dt = render_room(a, d)
        n = len(json.loads((d / "nodes.json").read_text()))
        k = len(json.loads((d / "luminaires.json").read_text()))
        timings.setdefault(d.name, {})["render_s"] = round(dt, 1)
        timings[d.name]["render_frames"] = n * (k + 4)
        timings[d.name]["render_settings"] = f"{a.width}x{a.height} " + " ".join(opts[2:])
        print(f"{d.name}: rendered {n * (k + 4)} frames in {dt:.0f} s", flush=True)
        save_timings(a, timings)


# ------------------------------------------------------------------ truth


def truth_one(a, d: Path, name: str, files: list[str], sky: bool) -> dict:
    sens = json.loads((d / "sensors.json").read_text())
    rays = "".join("{} {} {} {} {} {}\n".format(*s["position"], *s["normal"]) for s in sens)
    tmp = a.work / d.name / "truth"
    tmp.mkdir(parents=True, exist_ok=True)
    rad = d / "radiance"
    oct_ = octree(files, tmp, name, rad)
    out = {}
    # the sky through a window is a small bright source to -I's hemisphere sampling: many more
    # samples (2 passes at -ad 4096 differed by up to 7 % at room_02's desks)
    parts = ([("total", a.truth_ab, 2 * a.seeds)] if sky else
             [("total", a.truth_ab, a.seeds), ("direct", 0, 1)])
    for part, ab, seeds in parts:
        ad = a.sky_ad if sky else a.truth_ad
        opts = ["-I", "-h", "-ov", "-aa", "0", "-ab", str(ab), "-ad", str(ad), "-lw", "1e-4",
                "-ds", "0.05", "-dj", "1", "-dt", "0", "-dc", "1"]
        dummy = "60 60 1.5 0 0 1\n" * (sum(map(ord, name)) % 89)
        vals = rtrace(opts, oct_, dummy + rays * seeds, rad)[dummy.count("\n"):]
        lux = [EFFICACY * sum(w * x for w, x in zip(RGB_Y, v[:3])) for v in vals]
        n = len(sens)
        out[part] = [[lux[s * n + i] for s in range(seeds)] for i in range(n)]
        out["opts_" + part] = " ".join(opts)
    oct_.unlink()
    return out


def truth_room(a, d: Path) -> float:
    ids = [l["id"] for l in json.loads((d / "luminaires.json").read_text())]
    sens = json.loads((d / "sensors.json").read_text())
    jobs = [("sky", files_for(d, set(), "overcast"), True)]
    jobs += [(f"L{k}", files_for(d, {k}, None), False) for k in ids]
    t0 = time.time()
    with ThreadPoolExecutor(a.jobs) as ex:
        res = dict(zip([j[0] for j in jobs],
                       ex.map(lambda j: truth_one(a, d, j[0], j[1], j[2]), jobs)))
    dt = time.time() - t0
    states = read_states(d)
    seeds = a.seeds
    with open(d / "truth.csv", "w") as f:
        f.write("scenario_id,luminaires_on,sensor_id,lux,lux_direct,lux_indirect,lux_stderr,"
                "lux_sky,lux_sky_stderr\n")
        for sid, on in states:
            for i, s in enumerate(sens):
                per = [sum(res[f"L{k}"]["total"][i][j] for k in on) for j in range(seeds)]
                lux = sum(per) / seeds
                se = (sum((x - lux) ** 2 for x in per) / (seeds - 1) / seeds) ** 0.5 \
                    if seeds > 1 else 0.0
                dr = sum(res[f"L{k}"]["direct"][i][0] for k in on)
                sk = res["sky"]["total"][i]
                sky = statistics.fmean(sk)
                sky_se = statistics.stdev(sk) / len(sk) ** 0.5 if len(sk) > 1 else 0.0
                f.write(f"{sid},{';'.join(map(str, on))},{s['id']},{lux:.3f},{dr:.3f},"
                        f"{lux - dr:.3f},{se:.3f},{sky:.3f},{sky_se:.3f}\n")
    (d / "truth.txt").write_text(
        f"truth.csv: rtrace {res['L1']['opts_total']}, {seeds} passes, one luminaire at a time, "
        f"scenarios summed; lux_direct with -ab 0; lux_sky (CIE overcast {SKY[1]}/{SKY[2]} "
        f"{SKY[3]:.0f}:00 solar, every luminaire off): rtrace {res['sky']['opts_total']}, "
        f"{2 * seeds} passes\n")
    return dt


def truth_clear(a, d: Path) -> float:
    """truth_clear.csv: the clear sky's illuminance at each sensor, every luminaire off
    (`sensor_id,lux_sky,lux_sky_stderr`), with the overcast sky's settings and passes; the day
    truth of the clear frame is truth.csv's all-on lux plus lux_sky."""
    write_clear_sky(d)
    sens = json.loads((d / "sensors.json").read_text())
    t0 = time.time()
    res = truth_one(a, d, "clear", files_for(d, set(), "clear"), True)
    with open(d / "truth_clear.csv", "w") as f:
        f.write("sensor_id,lux_sky,lux_sky_stderr\n")
        for i, s in enumerate(sens):
            v = res["total"][i]
            se = statistics.stdev(v) / len(v) ** 0.5 if len(v) > 1 else 0.0
            f.write(f"{s['id']},{statistics.fmean(v):.3f},{se:.3f}\n")
    with open(d / "truth.txt", "a") as f:
        f.write(f"truth_clear.csv: the CIE clear sky with sun ({CLEAR[1]}/{CLEAR[2]} "
                f"{clear_hour(d):.1f} solar, every luminaire off): rtrace {res['opts_total']}, "
                f"{2 * a.seeds} passes\n")
    return time.time() - t0


def clear_sky_all(a) -> None:
    """The clear day alone, for rooms rendered and truthed before it: the missing frames
    (render_frame skips those that exist) and truth_clear.csv."""
    set_frame_opts(a)
    timings = load_timings(a)
    for d in selected(a):
        dt = render_room(a, d)
        dt += truth_clear(a, d)
        timings.setdefault(d.name, {})["clear_s"] = round(dt, 1)
        print(f"{d.name}: clear day in {dt:.0f} s", flush=True)
        save_timings(a, timings)


def truth_all(a) -> None:
    timings = load_timings(a)
    for d in selected(a):
        dt = truth_room(a, d) + truth_clear(a, d)
        timings.setdefault(d.name, {})["truth_s"] = round(dt, 1)
        timings[d.name]["truth_settings"] = (f"-ab {a.truth_ab} -ad {a.truth_ad} seeds {a.seeds}"
                                             f" (sky -ad {a.sky_ad}, {2 * a.seeds} passes)")
        print(f"{d.name}: truth in {dt:.0f} s", flush=True)
        save_timings(a, timings)


# ------------------------------------------------------------------ evaluation


def read_states(d: Path) -> list[tuple[int, list[int]]]:
    out = []
    with open(d / "states.csv") as f:
        for r in csv.DictReader(f):
            out.append((int(r["scenario_id"]), [int(x) for x in r["luminaires_on"].split(";") if x]))
    return out


def read_truth_clear(d: Path) -> dict | None:
    """Per sensor, the clear sky's lux (truth_clear.csv), or None before it was computed."""
    p = d / "truth_clear.csv"
    if not p.exists():
        return None
    with open(p) as f:
        return {int(r["sensor_id"]): float(r["lux_sky"]) for r in csv.DictReader(f)}


def read_truth(d: Path) -> dict:
    t = {}
    with open(d / "truth.csv") as f:
        for r in csv.DictReader(f):
            t[(int(r["scenario_id"]), int(r["sensor_id"]))] = (float(r["lux"]), float(r["lux_sky"]))
    return t


def luxnode_bin(a) -> Path:
    p = a.luxnode if a.luxnode else REPO / "target" / "release" / "luxnode"
    if not Path(p).exists():
        sys.exit(f"no luxnode binary at {p}: cargo build --release, or --luxnode PATH")
    return Path(p)


def run(cmd: list[str]) -> subprocess.CompletedProcess:
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))}\n{p.stdout[-3000:]}\n{p.stderr[-3000:]}")
    return p


def table_after(text: str, header: str) -> list[list[str]]:
    lines = text.splitlines()
    for i, ln in enumerate(lines):
        if ln.strip() == header:
            rows = []
            for r in lines[i + 1:]:
                if not r[:1].isdigit():
                    break
                rows.append(r.split(","))
            return rows
    return []


def commission(a, d: Path, rd: Path, cams: list[str], tag: str, plan: bool) -> dict:
    lux = luxnode_bin(a)
    img_dir = rd / "eval" / tag
    img_dir.mkdir(parents=True, exist_ok=True)
    cmd = [lux, "commission"]
    for c in cams:
        cmd += ["--capture", rd / c]
    cmd += ["--luminaires", d / "luminaires.json", "--sensors", d / "sensors.json",
            "--desks", d / "desks.json", "--truth", d / "truth.csv", "--states", d / "states.csv"]
    for c in cams:
        cmd += ["--out", img_dir / f"{c}.img"]
    if plan:
        cmd += ["--room-plan", d / "room.json"]
    cmd += a.commission_args.split()
    t0 = time.time()
    note = ""
    try:
        p = run(cmd)
    except RuntimeError as e:
        if "FORMFACTORS region" not in str(e):
            raise
        # the image does not fit the flash (room_05's two nodes: 11.35 MiB at the defaults,
        # 8.93 MiB with --patch-size 2): the fast preset with 8-bit form factors
        note = ("image over the 4 MiB flash region at the defaults; commissioned with "
                "--preset fast --precision u8")
        print(f"{d.name} {tag}: {note}", flush=True)
        p = run(cmd + ["--preset", "fast", "--precision", "u8"])
    dt = time.time() - t0
    (img_dir / "commission.txt").write_text(p.stdout + p.stderr)
    unc = {int(r[0]): float(r[1]) / 100.0 for r in
           table_after(p.stdout, "sensor,stated_uncertainty_pct,all_on_lx,largest_source,its_share_pct")}
    flags = {int(r[0]): int(r[1]) for r in
             table_after(p.stdout, "sensor,flags,mean_abs_error_lx,mean_truth_lx,error_pct")}
    return {"images": {c: img_dir / f"{c}.img" for c in cams}, "unc": unc, "flags": flags,
            "seconds": dt, "note": note}


def night_model(a, d: Path, com: dict, truth: dict) -> dict:
    """Per sensor: lists of (estimate, truth, stated relative u) over the scenarios."""
    img = next(iter(com["images"].values()))
    p = run([luxnode_bin(a), "simulate", "--image", img, "--states", d / "states.csv",
             "--format", "csv"])
    out = {}
    for r in csv.DictReader(p.stdout.splitlines()):
        sid, s = int(r["scenario_id"]), int(r["sensor_id"])
        est = float(r["lux"])
        # the image's own statement per dimming state when simulate prints it (stop 39 on),
        # else commission's all-on relative uncertainty at this state's value
        u = r.get("uncertainty_lx")
        u = float(u) if u not in (None, "") else com["unc"].get(s, float("nan")) * est
        out.setdefault(s, []).append((est, truth[(sid, s)][0], u))
    return out


# The frames' time for `luxnode live --time`: the day sky is gensky's for 21 March, 12:00 at
# longitude 0 (`-o 0 -m 0`); the plans' site is at 8.5 E, where the sun stands as high and in
# the same direction 34 minutes earlier in UTC (8.5 degrees of longitude). The clear day's
# frame is at `clear_hour` the same way.
def frame_time(d: Path, hour: float = 12.0) -> str:
    site = json.loads((d / "room.json").read_text()).get("site") or {}
    minutes = round(hour * 60) - round(4 * float(site.get("longitude_deg", 0.0)))
    return f"2026-03-21T{minutes // 60:02d}:{minutes % 60:02d}:00Z"


def stated_lx(row: dict) -> float:
    """A live CSV row's stated uncertainty, lx (infinite when it states none)."""
    return float(row["uncertainty_lx"] or "inf")


def live_rows(lux: Path, d: Path, rd: Path, cam: str, img: Path, light: str,
              has_time: bool = True) -> dict:
    """`luxnode live`'s CSV rows by sensor for node `cam`'s image `img` on its live frame
    `light`, every luminaire at 100 %, at the frame's time (the clear hour on a sunny day)."""
    arc = ",".join(["254"] * len(json.loads((d / "luminaires.json").read_text())))
    cmd = [lux, "live", "--image", img, "--frame", rd / "live" / f"{cam}_{light}.png",
           "--arc", arc, "--depth", rd / "live" / f"{cam}_depth.png", "--format", "csv"]
    if has_time:
        sunny = light in ("clear", "hazy")
        cmd += ["--time", frame_time(d, clear_hour(d) if sunny else 12.0)]
    return {int(r["sensor_id"]): r for r in csv.DictReader(run(cmd).stdout.splitlines())}


def live_values(a, d: Path, rd: Path, com: dict, truth: dict, light: str,
                clear: dict | None = None) -> dict:
    """Per sensor, [(estimate, truth, stated u, source)] of the live frame `light`: night (all
    on), day (all on + the overcast sky), clear (all on + the clear sky with sun)."""
    has_time = "--time" in run([luxnode_bin(a), "live", "--help"]).stdout
    per_node = [live_rows(luxnode_bin(a), d, rd, cam, img, light, has_time)
                for cam, img in com["images"].items()]
    out = {}
    for s in per_node[0]:
        cands = [rows[s] for rows in per_node if s in rows]
        measured = [r for r in cands if r["source"] == "measured"]
        # a node that sees the desk saturated knows it is beyond its range: its "not available"
        # stands over another node's inference
        beyond = [r for r in cands if "saturated" in r["flags"] and "bad_frame" not in r["flags"]
                  and not r["lux_total"]]
        # a node that says the sun may be on the desk (a sun patch it sees as near the windows,
        # or the plan's beam) knows of a sun another node's inference does not: its "not
        # available" stands over that inference too, not over a measurement
        sun = [r for r in cands if "sun_may_reach" in r["flags"] and not r["lux_total"]]
        # a value not available (empty: NaN, flagged) is taken only when no node gives one;
        # of several nodes' inferences, the one with the smallest statement (as of measurements)
        valued = [r for r in cands if r["lux_total"]]
        pick = (min(measured, key=stated_lx) if measured
                else beyond[0] if beyond else sun[0] if sun
                else min(valued, key=stated_lx) if valued else cands[0])
        lux, sky = truth[(1, s)]
        c = (clear or {}).get(s, math.nan)
        t = lux + {"day": sky, "clear": c, "hazy": HAZY * c}.get(light, 0.0)
        out[s] = [(float(pick["lux_total"] or "nan"), t, float(pick["uncertainty_lx"] or "nan"))]
        out[s][0] += (pick["source"],)
    return out


def desk_rows(room: str, config: str, light: str, vals: dict, flags: dict) -> list[dict]:
    rows = []
    for s, v in sorted(vals.items()):
        # values published as not available (NaN) are counted, never scored as numbers
        known = [x for x in v if math.isfinite(x[0])]
        err = (sum(abs(e - t) for e, t, *_ in known) / max(1e-9, sum(t for _, t, *_ in known))
               if known else math.nan)
        cov = [abs(e - t) <= 2 * u for e, t, u, *_ in known if math.isfinite(u)]
        # the stated relative standard uncertainty, over the values that have one
        stated = [u / e for e, t, u, *_ in known if math.isfinite(u) and e > 0]
        rows.append({"room": room, "config": config, "light": light, "sensor": s,
                     "in_view": (flags.get(s, 1) & 1) == 0, "error": err,
                     "stated": statistics.fmean(stated) if stated else math.nan,
                     "values": len(v), "within_2u": sum(cov), "with_u": len(cov),
                     "unknown": len(v) - len(known),
                     "source": v[0][3] if len(v[0]) > 3 else "model"})
    return rows


def project(c: dict, p) -> tuple[float, float, float] | None:
    """Pixel (u, v) and depth along the axis of world point p in camera c, or None."""
    r = np.array(c["R_world_from_camera"], dtype=float)
    q = r.T @ (np.array(p, dtype=float) - np.array(c["position"], dtype=float))
    if q[2] <= 0:
        return None
    if c["model"] == "pinhole":
        mx, my = q[0] / q[2], q[1] / q[2]
    else:
        theta = math.atan2(math.hypot(q[0], q[1]), q[2])
        rr = float(opn.kb_radius(np.array(theta)))
        phi = math.atan2(q[1], q[0])
        mx, my = rr * math.cos(phi), rr * math.sin(phi)
    return c["cx"] + c["fx"] * mx, c["cy"] + c["fy"] * my, float(q[2])


def render_check(a, d: Path) -> list[dict]:
    """The frames themselves against the truth: at each desk sensor a camera sees (the pixel's
    depth within 3 cm of the sensor's), pi L / rho of the all-on frame against truth's all-on
    lux, and of the sky frame against lux_sky. What the renderer's fast settings leave in the
    frames, which the node cannot do better than."""
    rd = res_dir(a, d)
    mtl = (d / "scene.mtl").read_text().split("newmtl ")
    rho_desk = next(float(m.split("Kd ")[1].split()[0]) for m in mtl if m.startswith("desk\n"))
    truth = read_truth(d)
    out = []
    for n in json.loads((d / "nodes.json").read_text()):
        c = camera_json(n, a.width, a.height, d.name)
        cam = f"node_{n['id']}"
        fr = rd / "frames"
        if not (fr / f"{cam}_all.npy").exists():
            continue
        z = np.load(fr / f"{cam}_depth.npy")
        lum = {k: np.load(fr / f"{cam}_{k}.npy") for k in ("all", "sky")}
        for s in json.loads((d / "sensors.json").read_text()):
            pr = project(c, s["position"])
            if pr is None:
                continue
            u, v = int(round(pr[0])), int(round(pr[1]))
            if not (0 <= u < c["width"] and 0 <= v < c["height"]) or abs(z[v, u] - pr[2]) > 0.03:
                continue
            t_all, t_sky = truth[(1, s["id"])]
            out.append({"room": d.name, "node": n["id"], "sensor": s["id"],
                        "all": math.pi * lum["all"][v, u] / rho_desk / t_all - 1.0,
                        "sky": math.pi * lum["sky"][v, u] / rho_desk / t_sky - 1.0})
    return out


def evaluate(a) -> None:
    lux = luxnode_bin(a)
    helptext = run([lux, "commission", "--help"]).stdout
    has_plan = "--room-plan" in helptext
    print(f"luxnode commission --room-plan: {'accepted' if has_plan else 'not offered (n/a)'}")
    rows, info, checks, failures = [], [], [], []
    timings = load_timings(a)
    for d in selected(a):
        rd = res_dir(a, d)
        cache = rd / "eval" / "rows.json"
        if a.reuse and cache.exists():
            c = json.loads(cache.read_text())
            rows += [{k: (math.nan if k == "error" and x is None else x) for k, x in r.items()}
                     for r in c["rows"]]
            checks += c["frames"]
            failures += c["failures"]
            info += c["commissions"]
            print(f"{d.name}: evaluated before ({cache})")
            continue
        if not (rd / "live").exists():
            print(f"{d.name}: not rendered at {a.width}x{a.height}, skipped")
            continue
        n0, f0, i0 = len(rows), len(failures), len(info)
        checks_room = render_check(a, d)
        checks += checks_room
        nodes = [f"node_{n['id']}" for n in json.loads((d / "nodes.json").read_text())]
        truth = read_truth(d)
        clear = read_truth_clear(d)
        lights = ["night", "day"]
        if clear is not None and (rd / "live" / f"{nodes[0]}_clear.png").exists():
            lights.append("clear")
            if (rd / "live" / f"{nodes[0]}_hazy.png").exists():
                lights.append("hazy")
        configs = [("one node", nodes[:1])]
        if len(nodes) > 1:
            configs += [("one node (b)", nodes[1:2]), ("two nodes", nodes[:2])]
        for cname, cams in configs:
            for plan in ([False, True] if has_plan else [False]):
                tag = cname.replace(" ", "_").replace("(", "").replace(")", "") + \
                    ("_plan" if plan else "")
                label = cname + (", plan" if plan else "")
                try:
                    com = commission(a, d, rd, cams, tag, plan)
                except RuntimeError as e:
                    print(f"{d.name} {label}: commissioning FAILED\n{e}", flush=True)
                    failures.append(f"{d.name}, {label}: commissioning failed "
                                    f"({str(e).strip().splitlines()[-1][:160]})")
                    continue
                timings.setdefault(d.name, {})[f"commission_s {label}"] = round(com["seconds"], 1)
                if com["note"]:
                    failures.append(f"{d.name}, {label}: {com['note']}")
                rows += desk_rows(d.name, label, "night, model", night_model(a, d, com, truth),
                                  com["flags"])
                for light in lights:
                    try:
                        rows += desk_rows(d.name, label, f"{light}, live",
                                          live_values(a, d, rd, com, truth, light, clear),
                                          com["flags"])
                    except RuntimeError as e:
                        print(f"{d.name} {label} {light}: live FAILED\n{e}", flush=True)
                        failures.append(f"{d.name}, {label}, {light}: live failed "
                                        f"({str(e).strip().splitlines()[-1][:160]})")
                info.append({"room": d.name, "config": label, "seconds": round(com["seconds"], 1)})
                print(f"{d.name} {label}: commissioned in {com['seconds']:.0f} s", flush=True)
        cache.parent.mkdir(parents=True, exist_ok=True)
        cache.write_text(json.dumps({"rows": [{k: (None if isinstance(x, float) and
                                                   not math.isfinite(x) else x)
                                               for k, x in r.items()} for r in rows[n0:]],
                                     "frames": checks_room,
                                     "failures": failures[f0:], "commissions": info[i0:]}) + "\n")
    save_timings(a, timings)
    text = report(rows, has_plan, a)
    if checks:
        ea = [abs(c["all"]) for c in checks]
        es = [abs(c["sky"]) for c in checks]
        text += ("\n### The frames against the truth\n\nAt the " + str(len(checks)) +
                 " (node, sensor) pairs where a camera sees the sensor's desk top, pi L / rho of the "
                 "rendered frame against the truth (|deviation|, %): all-on frame median "
                 f"{pct(statistics.median(ea))}, p90 {pct(quantile(ea, 0.9))}, worst {pct(max(ea))}; "
                 f"sky frame median {pct(statistics.median(es))}, p90 {pct(quantile(es, 0.9))}, "
                 f"worst {pct(max(es))}. (Single pixels: includes the renderer's noise.)\n")
    if failures:
        text += "\n### Failures and fallbacks\n\n" + "".join(f"- {f}\n" for f in failures)
    print(text)
    if a.md:
        Path(a.md).write_text(text)
    if a.json:
        # a desk whose every value was not available has no error: null, not a NaN (JSON has none)
        clean = [{k: (None if isinstance(x, float) and not math.isfinite(x) else x)
                  for k, x in r.items()} for r in rows]
        Path(a.json).write_text(json.dumps({"rows": clean, "commissions": info, "frames": checks,
                                            "room_plan_accepted": has_plan}, indent=1) + "\n")


def pct(x: float) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{100 * x:.1f}"


def quantile(xs: list[float], q: float) -> float:
    if not xs:
        return float("nan")
    return float(np.quantile(np.array(xs), q))


def report(rows: list[dict], has_plan: bool, a) -> str:
    out = []
    lights = ["night, model", "night, live", "day, live"]
    for light in ("clear, live", "hazy, live"):
        if any(r["light"] == light for r in rows):
            lights.append(light)
    configs = sorted({r["config"] for r in rows}, key=lambda c: (c.startswith("two"), c))
    out.append(f"Rendered at {a.width}x{a.height}. Desk error = Σ|lux − truth| / Σ truth over the "
               "desk's values (night, model: every scenario of states.csv; live: one all-on "
               "frame, day with the overcast sky at noon, clear with the CIE clear sky and its "
               "sun at the hour the window wall faces it, hazy with a quarter of that sky and "
               "sun). Errors in %.\n")
    out.append("### Over rooms and desks\n")
    out.append("| config | light | desks | view | median | p90 | worst | room means: median | "
               "worst room mean | truth within 2 u | live: measured |")
    out.append("|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for c in configs + ([] if has_plan else ["one node, plan", "two nodes, plan"]):
        for lt in lights:
            for view in ("all", "in view", "out of view"):
                sel = [r for r in rows if r["config"] == c and r["light"] == lt and
                       (view == "all" or r["in_view"] == (view == "in view"))]
                if c.endswith("plan") and not has_plan:
                    if view == "all" and lt == lights[0]:
                        out.append(f"| {c} | (every light) | | | n/a | n/a | n/a | n/a | n/a | "
                                   "n/a (`luxnode commission` has no `--room-plan`) | |")
                    continue
                if not sel:
                    continue
                errs = [r["error"] for r in sel if math.isfinite(r["error"])]
                if not errs:
                    continue
                rooms = sorted({r["room"] for r in sel if math.isfinite(r["error"])})
                means = [statistics.fmean(r["error"] for r in sel
                                          if r["room"] == rm and math.isfinite(r["error"]))
                         for rm in rooms]
                cov_n = sum(r["within_2u"] for r in sel)
                cov_d = sum(r["with_u"] for r in sel)
                unknown = sum(r.get("unknown", 0) for r in sel)
                cov = f"{100 * cov_n / cov_d:.0f} % of {cov_d}" if cov_d else "—"
                if unknown:
                    cov += f" ({unknown} not available)"
                out.append(f"| {c} | {lt} | {len(sel)} | {view} | {pct(statistics.median(errs))} "
                           f"| {pct(quantile(errs, 0.9))} | {pct(max(errs))} | "
                           f"{pct(statistics.median(means))} | {pct(max(means))} | {cov} | "
                           + (f"{sum(r['source'] == 'measured' for r in sel)} of {len(sel)} |"
                              if "live" in lt else "— |"))
    out.append("\n### Per room (mean / worst desk, %)\n")
    head = "| room | config | " + " | ".join(f"{lt} all | {lt} in view | {lt} out of view"
                                             for lt in lights) + " |"
    out.append(head)
    out.append("|---|---|" + "---:|" * (3 * len(lights)))
    for rm in sorted({r["room"] for r in rows}):
        for c in configs:
            cells = []
            for lt in lights:
                for view in ("all", "in view", "out of view"):
                    sel = [r["error"] for r in rows if r["room"] == rm and r["config"] == c and
                           r["light"] == lt and math.isfinite(r["error"]) and
                           (view == "all" or r["in_view"] == (view == "in view"))]
                    cells.append(f"{pct(statistics.fmean(sel))} / {pct(max(sel))}" if sel else "—")
            if any(r["room"] == rm and r["config"] == c for r in rows):
                out.append(f"| {rm} | {c} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------ bookkeeping


def selected(a) -> list[Path]:
    ds = rooms_in(a.out)
    if a.only:
        ds = [d for d in ds if d.name in a.only]
    if not ds:
        sys.exit(f"no rooms in {a.out} (--write first)")
    return ds


def load_timings(a) -> dict:
    p = a.work / "timings.json"
    return json.loads(p.read_text()) if p.exists() else {}


def save_timings(a, t: dict) -> None:
    a.work.mkdir(parents=True, exist_ok=True)
    (a.work / "timings.json").write_text(json.dumps(t, indent=1) + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", action="store_true", help="generate the rooms' scene directories")
    ap.add_argument("--check", action="store_true", help="with --write: luxnode scene check each")
    ap.add_argument("--render", action="store_true", help="render capture sets and live frames")
    ap.add_argument("--truth", action="store_true", help="truth.csv per room with Radiance")
    ap.add_argument("--evaluate", action="store_true", help="commission and score")
    ap.add_argument("--clear-sky", action="store_true",
                    help="the clear day alone for rooms rendered before it: its frames (existing "
                    "frames are kept) and truth_clear.csv")
    ap.add_argument("--seed", type=int, default=28)
    ap.add_argument("--count", type=int, default=8)
    ap.add_argument("--out", type=Path, default=REPO / "scenes" / "rooms",
                    help="the rooms' scene directories")
    ap.add_argument("--work", type=Path, default=Path("/tmp/luxnode_rooms"),
                    help="frames, capture sets, images")
    ap.add_argument("--only", nargs="*", help="only these rooms (room_01 ...)")
    ap.add_argument("--resolution", default="320x240", help="WxH of the rendered cameras")
    ap.add_argument("--frame-ab", type=int, help="override the frames' -ab (smoke runs)")
    ap.add_argument("--frame-ad", type=int, help="override the frames' -ad (smoke runs)")
    ap.add_argument("--truth-ab", type=int, default=8)
    ap.add_argument("--truth-ad", type=int, default=1024)
    ap.add_argument("--sky-ad", type=int, default=32768, help="the sky's truth -ad")
    ap.add_argument("--seeds", type=int, default=2, help="truth passes (the sky: twice as many)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--luxnode", type=Path, help="the luxnode binary "
                    "(default: target/release/luxnode of this repository)")
    ap.add_argument("--commission-args", default="", help="further `luxnode commission` options")
    ap.add_argument("--reuse", action="store_true",
                    help="--evaluate: take a room's rows from its last evaluation (W/room/WxH/eval)")
    ap.add_argument("--md", help="--evaluate: write the tables as Markdown")
    ap.add_argument("--json", help="--evaluate: write the raw rows as JSON")
    a = ap.parse_args(argv)
    a.width, a.height = (int(x) for x in a.resolution.lower().split("x"))
    if not (a.write or a.render or a.truth or a.evaluate or a.clear_sky):
        ap.error("nothing to do: --write, --render, --truth, --clear-sky, --evaluate")
    if a.write:
        write_all(a)
    if a.render:
        render_all(a)
    if a.truth:
        truth_all(a)
    if a.clear_sky:
        clear_sky_all(a)
    if a.evaluate:
        evaluate(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
