#!/usr/bin/env python3
"""The occupancy bench (issue 29): depth frames of rooms with people and things in them, ray
cast here over simple solids, with the ground truth, for `luxnode bench occupancy`.

Two rooms (`room_a`: four desks in two facing rows; `room_b`: six desks in two rows), seen by
a pinhole looking down and an equidistant fisheye looking down (and in room_b a pinhole tilted
50 degrees from a wall). Each room has its desks, a monitor on each, a chair at each (all
present at commissioning: the background). Frames: the empty room, each desk occupied in turn
by a seated person (head sphere, neck, torso, thighs, arms), several at once, people standing
at desks, people leaning over their desks, people standing in the aisles, and each distractor
alone (a chair moved, a box and a bag on a desk, a bag on the floor, a coat over a chair, a
plant, an open laptop, a chair turned sideways).

Per set (room and pose) it writes:

* `camera.json`: the capture-set camera (`position`, `R_world_from_camera` rows, `fx`, `fy`,
  `cx`, `cy`, `width`, `height`, `model`);
* `desks.json`: the desk tops (`id`, `x0`, `x1`, `y0`, `y1`, `z`);
* `background.png`: the commissioned depth (the empty room, noise-free: commissioning fuses
  many frames);
* `frames/NAME.png`: 16-bit depth, mm along the optical axis, 0 = no return; ToF noise
  (2 mm + 0.4 % of the depth, Gaussian) and 0.5 % dropped pixels, seeded;
* `truth.csv`: `frame,kind,desk_id,occupied,seen_fraction`: per frame and desk whether a
  person is in the desk's workstation zone (the floor within 0.75 m of its top, nearest desk),
  and the share of the zone the camera sees: 5 cm points of the zone whose top surface the
  camera sees unoccluded and over which a seated head (1.15 m) is in the frame.

Pixel convention (the capture set's): pixel (u, v) centre at integer coordinates; a pinhole
ray through ((u-cx)/fx, (v-cy)/fy, 1); the equidistant fisheye r = theta.

Usage: `python3 bench/occupancy/generate.py OUT [--small]` (`--small`: 160 x 120, room_a only,
a few frames: the fixture in tests/data/occupancy). Only the standard library and numpy.
"""

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

SEED = 29
HEAD_SEEN_M = 1.15
ZONE_M = 0.75
FISHEYE_MAX_THETA = math.radians(85.0)

# ------------------------------------------------------------------ PNG (16-bit grey)


# the radiance benches' 16-bit PNG writer (numpy and the standard library only)
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "radiance"))
from daylight import write_png16  # noqa: E402


# ------------------------------------------------------------------ solids and the ray caster


def box(lo, hi):
    return ("box", np.array(lo, float), np.array(hi, float))


def vcyl(cx, cy, r, z0, z1):
    return ("cyl", (cx, cy, r, z0, z1))


def sphere(c, r):
    return ("sph", np.array(c, float), r)


def hit_box(o, d, lo, hi):
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1 = (lo - o) * inv
        t2 = (hi - o) * inv
    tmin = np.nanmax(np.minimum(t1, t2), axis=1)
    tmax = np.nanmin(np.maximum(t1, t2), axis=1)
    ok = (tmax >= tmin) & (tmin > 1e-6)
    return np.where(ok, tmin, np.inf)


def hit_cyl(o, d, p):
    cx, cy, r, z0, z1 = p
    ox, oy = o[:, 0] - cx, o[:, 1] - cy
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = 2 * (ox * d[:, 0] + oy * d[:, 1])
    c = ox**2 + oy**2 - r * r
    disc = b * b - 4 * a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        t_side = (-b - np.sqrt(np.maximum(disc, 0))) / (2 * a)
    z = o[:, 2] + t_side * d[:, 2]
    side = np.where((disc >= 0) & (a > 1e-12) & (t_side > 1e-6) & (z >= z0) & (z <= z1), t_side, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_top = (z1 - o[:, 2]) / d[:, 2]
    x, y = ox + t_top * d[:, 0], oy + t_top * d[:, 1]
    top = np.where((d[:, 2] < 0) & (t_top > 1e-6) & (x * x + y * y <= r * r), t_top, np.inf)
    return np.minimum(side, top)


def hit_sphere(o, d, c, r):
    oc = o - c
    b = np.sum(oc * d, axis=1)
    cc = np.sum(oc * oc, axis=1) - r * r
    disc = b * b - cc
    t = -b - np.sqrt(np.maximum(disc, 0))
    return np.where((disc >= 0) & (t > 1e-6), t, np.inf)


def cast(o, d, solids, room_hi):
    """Distance along unit rays d from o to the first hit (the room's inside: floor, walls,
    ceiling)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1 = (np.zeros(3) - o) * inv
        t2 = (np.array(room_hi) - o) * inv
    t = np.nanmin(np.maximum(t1, t2), axis=1)
    for s in solids:
        if s[0] == "box":
            t = np.minimum(t, hit_box(o, d, s[1], s[2]))
        elif s[0] == "cyl":
            t = np.minimum(t, hit_cyl(o, d, s[1]))
        else:
            t = np.minimum(t, hit_sphere(o, d, s[1], s[2]))
    return t


# ------------------------------------------------------------------ cameras


def pose_down(pos, f_px, w, h, model):
    # camera x = world +x, camera y = world -y, camera z = world -z
    r = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
    return dict(position=list(pos), R=r, fx=f_px, fy=f_px, cx=(w - 1) / 2, cy=(h - 1) / 2, width=w, height=h, model=model)


def pose_tilted(pos, tilt_deg, f_px, w, h):
    s, c = math.sin(math.radians(tilt_deg)), math.cos(math.radians(tilt_deg))
    x, z = np.array([1.0, 0, 0]), np.array([0, s, -c])
    y = np.cross(z, x)
    r = np.stack([x, y, z], axis=1).tolist()  # columns are the camera axes
    return dict(position=list(pos), R=r, fx=f_px, fy=f_px, cx=(w - 1) / 2, cy=(h - 1) / 2, width=w, height=h, model="pinhole")


def rays(cam):
    """Unit world rays per pixel (rows v, columns u), their optical-axis component, and the
    mask of pixels in the lens's field."""
    w, h = cam["width"], cam["height"]
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    mx, my = (u - cam["cx"]) / cam["fx"], (v - cam["cy"]) / cam["fy"]
    if cam["model"] == "pinhole":
        dc = np.stack([mx, my, np.ones_like(mx)], axis=-1)
        ok = np.ones_like(mx, bool)
    else:  # equidistant: r = theta
        theta = np.hypot(mx, my)
        phi = np.arctan2(my, mx)
        dc = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1)
        ok = theta <= FISHEYE_MAX_THETA
    dc /= np.linalg.norm(dc, axis=-1, keepdims=True)
    r = np.array(cam["R"])
    dw = dc @ r.T
    return dw.reshape(-1, 3), dc[..., 2].reshape(-1), ok.reshape(-1)


def project(cam, p):
    """Pixel (u, v) of world point p, or None outside the field."""
    r = np.array(cam["R"])
    pc = r.T @ (np.array(p) - np.array(cam["position"]))
    if cam["model"] == "pinhole":
        if pc[2] <= 1e-6:
            return None
        mx, my = pc[0] / pc[2], pc[1] / pc[2]
    else:
        rho = math.hypot(pc[0], pc[1])
        theta = math.atan2(rho, pc[2])
        if theta > FISHEYE_MAX_THETA:
            return None
        mx, my = (theta * pc[0] / rho, theta * pc[1] / rho) if rho > 0 else (0.0, 0.0)
    u, v = cam["fx"] * mx + cam["cx"], cam["fy"] * my + cam["cy"]
    if -0.5 <= u < cam["width"] - 0.5 and -0.5 <= v < cam["height"] - 0.5:
        return u, v
    return None


# ------------------------------------------------------------------ rooms, people, things


def rooms():
    """(name, room extent (x, y, ceiling), desks [(id, x0, x1, y0, y1)], per desk the seat
    (x, y) and the unit direction from the seat to the desk, aisle spots)."""
    a_desks = [(1, 0.8, 2.4, 0.6, 1.4), (2, 3.6, 5.2, 0.6, 1.4), (3, 0.8, 2.4, 3.6, 4.4), (4, 3.6, 5.2, 3.6, 4.4)]
    a_seats = [((1.6, 1.85), (0, -1)), ((4.4, 1.85), (0, -1)), ((1.6, 3.15), (0, 1)), ((4.4, 3.15), (0, 1))]
    b_desks = [
        (1, 1.0, 2.6, 1.6, 2.4), (2, 3.2, 4.8, 1.6, 2.4), (3, 5.4, 7.0, 1.6, 2.4),
        (4, 1.0, 2.6, 3.6, 4.4), (5, 3.2, 4.8, 3.6, 4.4), (6, 5.4, 7.0, 3.6, 4.4),
    ]
    b_seats = [((1.8, 1.15), (0, 1)), ((4.0, 1.15), (0, 1)), ((6.2, 1.15), (0, 1)),
               ((1.8, 4.85), (0, -1)), ((4.0, 4.85), (0, -1)), ((6.2, 4.85), (0, -1))]
    return [
        ("room_a", (6.0, 5.0, 2.85), a_desks, a_seats, [(3.0, 2.5), (0.3, 2.5)]),
        ("room_b", (8.0, 6.0, 2.95), b_desks, b_seats, [(0.3, 3.0), (7.6, 3.0)]),
    ]


def along(seat, f, fwd, side):
    """The point `fwd` towards the desk and `side` to the right of a seat."""
    return (seat[0] + f[0] * fwd - f[1] * side, seat[1] + f[1] * fwd + f[0] * side)


def rect(c, f, depth, width, z0, z1):
    """A box centred at c, `depth` along f and `width` across it."""
    hx = (depth if f[0] != 0 else width) / 2
    hy = (depth if f[1] != 0 else width) / 2
    return box((c[0] - hx, c[1] - hy, z0), (c[0] + hx, c[1] + hy, z1))


def desk_solids(d, seat, f, chair=None):
    _, x0, x1, y0, y1 = d
    out = [box((x0, y0, 0.72), (x1, y1, 0.75))]
    for x in (x0 + 0.05, x1 - 0.08):
        for y in (y0 + 0.05, y1 - 0.08):
            out.append(box((x, y, 0.0), (x + 0.03, y + 0.03, 0.72)))
    # a monitor on a stand at the desk's far edge
    mid = ((x0 + x1) / 2, (y0 + y1) / 2)
    half = ((x1 - x0) if f[0] else (y1 - y0)) / 2
    back = along(mid, f, half - 0.12, 0)
    out.append(rect(back, f, 0.05, 0.55, 0.85, 1.2))
    out.append(rect(back, f, 0.2, 0.25, 0.75, 0.85))
    spot, facing = chair or (seat, f)
    return out + chair_solids(spot, facing)


def chair_solids(seat, f):
    behind = along(seat, f, -0.25, 0)
    return [
        vcyl(seat[0], seat[1], 0.3, 0.0, 0.05),
        vcyl(seat[0], seat[1], 0.03, 0.05, 0.42),
        rect(seat, f, 0.46, 0.46, 0.42, 0.47),
        rect(behind, f, 0.06, 0.44, 0.5, 0.95),
    ]


def seated(seat, f, head_top, lean=0.0):
    """A seated person facing the desk; `lean` moves the head and shoulders towards it."""
    sh = head_top - 0.27
    head = along(seat, f, 0.05 + lean, 0)
    chest = along(seat, f, 0.02 + lean * 0.6, 0)
    out = [
        sphere((head[0], head[1], head_top - 0.1), 0.1),
        vcyl(head[0], head[1], 0.05, sh, head_top - 0.15),
        rect(seat, f, 0.22, 0.40, 0.47, sh - 0.25),
        rect(chest, f, 0.22, 0.42, sh - 0.25, sh),
        rect(along(seat, f, 0.25, 0), f, 0.45, 0.36, 0.47, 0.62),
        rect(along(seat, f, 0.45, 0), f, 0.1, 0.34, 0.0, 0.5),
    ]
    for side in (-0.24, 0.24):
        out.append(rect(along(seat, f, 0.02 + lean * 0.6, side), f, 0.1, 0.08, 0.8, sh - 0.02))
        out.append(rect(along(seat, f, 0.22 + lean, side * 0.8), f, 0.4, 0.08, 0.78, 0.86))
    return out


def standing(p, f, head_top):
    sh = head_top - 0.27
    out = [
        sphere((p[0], p[1], head_top - 0.1), 0.1),
        vcyl(p[0], p[1], 0.05, sh, head_top - 0.15),
        rect(p, f, 0.24, 0.42, 0.9, sh),
        rect(p, f, 0.2, 0.34, 0.0, 0.9),
    ]
    for side in (-0.26, 0.26):
        out.append(rect(along(p, f, 0, side), f, 0.1, 0.08, 0.75, sh - 0.02))
    return out


def plant(c, rng):
    out = [vcyl(c[0], c[1], 0.18, 0.0, 0.35), vcyl(c[0], c[1], 0.02, 0.35, 1.3)]
    for _ in range(25):
        r, a, z = 0.3 * math.sqrt(rng.random()), 2 * math.pi * rng.random(), 1.05 + 0.4 * rng.random()
        out.append(sphere((c[0] + r * math.cos(a), c[1] + r * math.sin(a), z), 0.05))
    return out


def distractors(d, seat, f, rng):
    """(name, solids to add, the desk's chair moved to and its facing, or None) for desk d."""
    _, x0, x1, y0, y1 = d
    on_desk = along(((x0 + x1) / 2, (y0 + y1) / 2), f, -0.1, 0.4)
    beside = along(seat, f, 0.0, 0.55)
    coat_back = along(seat, f, -0.25, 0)
    return [
        ("chair_moved", [], (along(seat, f, -0.2, 0.6), f)),
        ("box_on_desk", [rect(on_desk, f, 0.3, 0.4, 0.75, 1.05)], None),
        ("bag_on_desk", [rect(on_desk, f, 0.15, 0.35, 0.75, 1.05)], None),
        ("bag_on_floor", [rect(beside, f, 0.2, 0.35, 0.0, 0.35)], None),
        ("coat_on_chair", [rect(coat_back, f, 0.14, 0.5, 0.45, 1.0), rect(along(seat, f, -0.18, 0), f, 0.3, 0.5, 0.9, 1.05)], None),
        ("plant", plant(along(seat, f, -0.05, 0.7), rng), None),
        ("laptop_open", [rect(on_desk, f, 0.24, 0.34, 0.75, 0.77), rect(along(on_desk, f, 0.12, 0), f, 0.02, 0.34, 0.77, 1.0)], None),
        # last, so that the frames before it keep their noise
        ("chair_turned", [], (along(seat, f, -0.15, 0.1), (-f[1], f[0]))),
    ]


# ------------------------------------------------------------------ truth


def desk_distance(d, x, y):
    _, x0, x1, y0, y1 = d
    return math.hypot(max(x0 - x, x - x1, 0.0), max(y0 - y, y - y1, 0.0))


def desk_of(desks, p):
    """The desk whose workstation zone holds plan point p (nearest within 0.75 m), or None."""
    dist = [desk_distance(d, *p) for d in desks]
    k = int(np.argmin(dist))
    return desks[k][0] if dist[k] <= ZONE_M else None


def seen_fractions(cam, desks, solids, room):
    """Per desk, the share of its zone (5 cm points) whose top surface the camera sees and over
    which a seated head is in the frame."""
    out = {}
    xs = np.arange(0.025, room[0], 0.05)
    ys = np.arange(0.025, room[1], 0.05)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    # the top surface under each point: a ray straight down from 2.0 m
    o = np.column_stack([pts, np.full(len(pts), 2.0)])
    down = np.tile([0.0, 0.0, -1.0], (len(pts), 1))
    top = 2.0 - cast(o, down, solids, room)
    surf = np.column_stack([pts, top])
    cpos = np.array(cam["position"])
    to = surf - cpos
    dist = np.linalg.norm(to, axis=1)
    t = cast(np.tile(cpos, (len(pts), 1)), to / dist[:, None], solids, room)
    visible = t >= dist - 0.02
    for d in desks:
        n = seen = 0
        for i, p in enumerate(pts):
            if desk_of(desks, p) != d[0]:
                continue
            n += 1
            if visible[i] and project(cam, surf[i]) and project(cam, (p[0], p[1], HEAD_SEEN_M)):
                seen += 1
        out[d[0]] = seen / n if n else 0.0
    return out


# ------------------------------------------------------------------ frames


def frames(desks, seats, aisles, rng, small):
    """(name, kind, extra solids, people plan positions, chairs moved {desk index: (spot, facing)})."""
    out = [("empty", "empty", [], [], {})]
    heads = [1.2, 1.3, 1.4]
    for k, (seat, f) in enumerate(seats):
        out.append((f"seated_{desks[k][0]}", "seated", seated(seat, f, heads[k % 3]), [seat], {}))
    if not small:
        every = list(range(len(seats)))
        for name, ks in [("seated_all", every), ("seated_alternate", every[::2])]:
            s, p = [], []
            for i, k in enumerate(ks):
                s += seated(seats[k][0], seats[k][1], heads[(k + i) % 3])
                p.append(seats[k][0])
            out.append((name, "seated", s, p, {}))
        for k in (0, len(seats) - 1):
            seat, f = seats[k]
            out.append((f"leaning_{desks[k][0]}", "leaning", seated(seat, f, 1.3, lean=0.22), [along(seat, f, 0.27, 0)], {}))
    for k in (0, len(seats) - 1):
        seat, f = seats[k]
        spot = along(seat, f, -0.1, 0)
        out.append((f"standing_{desks[k][0]}", "standing", standing(spot, f, 1.6 + 0.2 * (k % 2)), [spot], {}))
    s, p = [], []
    for i, a in enumerate(aisles):
        s += standing(a, (1, 0), 1.7 + 0.1 * i)
        p.append(a)
    out.append(("aisle", "aisle", s, p, {}))
    if not small:
        seat, f = seats[1]
        out.append(("aisle_and_seated", "aisle", s + seated(seat, f, 1.25), p + [seat], {}))
    seat, f = seats[0]
    for name, solids, chair in distractors(desks[0], seat, f, rng):
        if small and name not in ("plant", "box_on_desk", "coat_on_chair"):
            continue
        out.append((name, name, solids, [], {0: chair} if chair else {}))
    return out


def render(cam, dirs, axis, ok, room, scene):
    t = cast(np.tile(np.array(cam["position"], float), (len(dirs), 1)), dirs, scene, room)
    z = np.where(ok & np.isfinite(t), t * axis, 0.0)
    return z.reshape(cam["height"], cam["width"])


def write_set(out: Path, name, room, desks, seats, aisles, cam, small):
    rng = np.random.default_rng(SEED)
    import random

    prng = random.Random(SEED)
    out.mkdir(parents=True, exist_ok=True)
    (out / "frames").mkdir(exist_ok=True)
    (out / "camera.json").write_text(json.dumps({
        "position": cam["position"], "R_world_from_camera": cam["R"], "fx": cam["fx"], "fy": cam["fy"],
        "cx": cam["cx"], "cy": cam["cy"], "width": cam["width"], "height": cam["height"], "model": cam["model"],
        "note": f"{name}; bench/occupancy/generate.py",
    }, indent=1))
    (out / "desks.json").write_text(json.dumps({"desks": [
        {"id": d[0], "x0": d[1], "x1": d[2], "y0": d[3], "y1": d[4], "z": 0.75} for d in desks]}, indent=1))
    dirs, axis, ok = rays(cam)

    def background(moved):
        s = []
        for k, (d, (seat, f)) in enumerate(zip(desks, seats)):
            s += desk_solids(d, seat, f, chair=moved.get(k))
        return s

    empty = background({})
    write_png16(out / "background.png", np.round(render(cam, dirs, axis, ok, room, empty) * 1e3).astype(np.uint16))
    seen = seen_fractions(cam, desks, empty, room)
    rows = ["frame,kind,desk_id,occupied,seen_fraction"]
    for fname, kind, extra, people, moved in frames(desks, seats, aisles, prng, small):
        z = render(cam, dirs, axis, ok, room, background(moved) + extra)
        noisy = z + rng.normal(0.0, 1.0, z.shape) * (0.002 + 0.004 * z)
        noisy[(z <= 0) | (rng.random(z.shape) < 0.005)] = 0.0
        write_png16(out / "frames" / f"{fname}.png", np.clip(np.round(noisy * 1e3), 0, 65534).astype(np.uint16))
        taken = {desk_of(desks, p) for p in people}
        for d in desks:
            rows.append(f"{fname},{kind},{d[0]},{int(d[0] in taken)},{seen[d[0]]:.4f}")
    (out / "truth.csv").write_text("\n".join(rows) + "\n")
    return len(rows) - 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--small", action="store_true", help="the test fixture: 160 x 120, room_a, a few frames")
    a = ap.parse_args()
    scale = 0.5 if a.small else 1.0
    w, h = int(320 * scale), int(240 * scale)
    for name, room, desks, seats, aisles in rooms():
        if a.small and name != "room_a":
            continue
        c = (room[0] / 2, room[1] / 2, room[2] - 0.05)
        poses = [("pinhole", pose_down(c, 80 * scale, w, h, "pinhole")), ("fisheye", pose_down(c, 100 * scale, w, h, "equidistant"))]
        if name == "room_b" and not a.small:
            poses.append(("tilted", pose_tilted((room[0] / 2, 0.3, room[2] - 0.1), 50.0, 160, w, h)))
        for pose, cam in poses:
            n = write_set(a.out / f"{name}_{pose}", name, room, desks, seats, aisles, cam, a.small)
            print(f"{name}_{pose}: {n} desk-frames", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
