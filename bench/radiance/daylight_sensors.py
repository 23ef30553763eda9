#!/usr/bin/env python3
"""Daylight on office_a's desks over one day, by Radiance: the input of
`luxnode bench control-day --daylight CSV` (docs/control.md).

Method:
  * The room is office_a (`reference/scenes/office_a/radiance/`) with every luminaire off
    (`lum_off_*.rad`). Its window (x 1..5 m, z 0.9..2.4 m in wall_n, y = 7.2 m) becomes a
    real opening: wall_n is rebuilt around it and the pane is Radiance `glass` of normal
    transmittance 0.65 (clear double glazing). The wall has no thickness; nothing outside
    obstructs the sky.
  * The window faces south: the room's +y axis points south, so the sky description from
    `gensky` (+y north) is turned 180 degrees about z (`xform -rz 180`).
  * Sky: `gensky` (CIE skies) for 21 March 2026 at 47.4 N, 8.5 E (Zurich), standard meridian
    15 E, every hour from 07:00 to 18:00 local standard time: `--sky clear` is the CIE clear
    sky with sun (`+s`), `--sky overcast` the CIE overcast sky (`-c`). Ground reflectance 0.2
    (gensky's default); the ground glow is the sky's ground brightness.
  * Illuminance at the 8 sensors of `sensors.json` (position, normal): `rtrace -I -h` with
    `-ab 6 -ad 4096 -as 2048 -aa 0 -lw 5e-5` (no irradiance cache, as the truth tables), each
    sensor traced 4 times in one process and averaged (about 1 % Monte Carlo scatter),
    lux = 179 (0.265 R + 0.670 G + 0.065 B). The sun is a source (shadow-tested through the
    glass); the sky reaches the desks through ambient sampling of the opening.

Output: CSV `time_h,sensor_id,lux` (daylight alone, luminaires off), one row per hour and
sensor, on stdout or `--out`.

Only the standard library and pyradiance (for the binaries) are used. About 20 s per hour
of the day on one core.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

try:
    import pyradiance  # noqa: F401  (importing it puts its bin/ on PATH and lib/ on RAYPATH)
except ImportError:  # pragma: no cover
    sys.exit("pyradiance is not installed: pip install pyradiance")

BINPATH = Path(pyradiance.BINPATH)
GENSKY = str(BINPATH / "gensky")
XFORM = str(BINPATH / "xform")
OCONV = str(BINPATH / "oconv")
RTRACE = str(BINPATH / "rtrace")

DEFAULT_SCENE = Path(__file__).resolve().parents[2] / "reference/scenes/office_a"
LUMINOUS_EFFICACY = 179.0  # lm/W, Radiance's WHTEFFICACY
RGB_TO_Y = (0.265, 0.670, 0.065)
LATITUDE, LONGITUDE_E, MERIDIAN_E = 47.4, 8.5, 15.0
MONTH, DAY = 3, 21
HOURS = range(7, 19)
WINDOW = (1.0, 5.0, 0.9, 2.4)  # x0, x1, z0, z1 in wall_n
ROOM = (6.0, 7.2, 3.0)  # x, y, z extent
TRANSMITTANCE = 0.65
PARAMS = ["-ab", "6", "-ad", "4096", "-as", "2048", "-aa", "0", "-lw", "5e-5"]
PASSES = 4  # each sensor traced this many times in one process (independent samples), averaged


def glass_transmissivity(tn: float) -> float:
    """Radiance's glass takes transmissivity, not transmittance (Radiance reference manual)."""
    return ((0.8402528435 + 0.0072522239 * tn * tn) ** 0.5 - 0.9166530661) / 0.0036261119 / tn


def polygon(material: str, name: str, pts: list[tuple[float, float, float]]) -> str:
    coords = "\n".join(f"\t{x:.6f} {y:.6f} {z:.6f}" for x, y, z in pts)
    return f"{material} polygon {name}\n0\n0\n{3 * len(pts)}\n{coords}\n"


def daylit_room(scene: Path) -> str:
    """office_a's geometry with wall_n opened at the window and a glass pane in it."""
    text = (scene / "radiance" / "geometry.rad").read_text()
    out, skip = [], 0
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        words = lines[i].split()
        if len(words) == 3 and words[1] == "polygon" and (
            words[2].startswith("wall_n.") or words[2].startswith("window_")
        ):
            # a polygon is: header, 0, 0, count, then count/3 vertex lines
            n = int(lines[i + 3].split()[0]) // 3
            i += 4 + n
            skip += 1
            continue
        out.append(lines[i])
        i += 1
    if skip != 4:
        raise SystemExit(f"expected wall_n.0/1 and window_1.0/1 in geometry.rad, found {skip}")
    x0, x1, z0, z1 = WINDOW
    w, y, h = ROOM
    pieces = [
        (0.0, w, 0.0, z0),  # below the window
        (0.0, w, z1, h),  # above
        (0.0, x0, z0, z1),  # left
        (x1, w, z0, z1),  # right
    ]
    rad = "\n".join(out) + "\n"
    for n, (a0, a1, b0, b1) in enumerate(pieces):
        rad += polygon("wall", f"wall_n.open{n}", [(a0, y, b0), (a1, y, b0), (a1, y, b1), (a0, y, b1)])
    rad += f"\nvoid glass pane\n0\n0\n3 {(t := glass_transmissivity(TRANSMITTANCE)):.4f} {t:.4f} {t:.4f}\n"
    rad += polygon("pane", "window_1.glass", [(x0, y, z0), (x1, y, z0), (x1, y, z1), (x0, y, z1)])
    return rad


def sky(hour: int, kind: str) -> str:
    flag = "+s" if kind == "clear" else "-c"
    # gensky: longitude and meridian in degrees west
    gen = subprocess.run(
        [GENSKY, str(MONTH), str(DAY), f"{hour}.0", flag, "-a", str(LATITUDE),
         "-o", str(-LONGITUDE_E), "-m", str(-MERIDIAN_E)],
        check=True, capture_output=True, text=True,
    ).stdout
    glows = (
        "\nskyfunc glow sky_glow\n0\n0\n4 1 1 1 0\n\nsky_glow source sky\n0\n0\n4 0 0 1 180\n"
        "\nskyfunc glow ground_glow\n0\n0\n4 1 1 1 0\n\nground_glow source ground\n0\n0\n4 0 0 -1 180\n"
    )
    turned = subprocess.run(
        [XFORM, "-rz", "180"], input=gen + glows, check=True, capture_output=True, text=True
    ).stdout
    return turned


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", type=Path, default=DEFAULT_SCENE)
    ap.add_argument("--sky", choices=["clear", "overcast"], default="clear")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--hours", type=int, nargs="*", default=list(HOURS), help="local standard time")
    args = ap.parse_args()
    sensors = json.loads((args.scene / "sensors.json").read_text())
    rays = "".join(
        f"{p[0]} {p[1]} {p[2]} {n[0]} {n[1]} {n[2]}\n"
        for s in sensors
        for p, n in [(s["position"], s["normal"])]
    )
    rows = ["time_h,sensor_id,lux"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "room.rad").write_text(daylit_room(args.scene))
        lum_off = sorted((args.scene / "radiance").glob("lum_off_*.rad"))
        for hour in args.hours:
            (tmp / "sky.rad").write_text(sky(hour, args.sky))
            files = [args.scene / "radiance" / "materials.rad", tmp / "sky.rad", tmp / "room.rad", *lum_off]
            with open(tmp / "scene.oct", "wb") as oct_:
                subprocess.run([OCONV, *map(str, files)], check=True, stdout=oct_)
            out = subprocess.run(
                [RTRACE, "-I", "-h", *PARAMS, str(tmp / "scene.oct")],
                input=rays * PASSES, check=True, capture_output=True, text=True,
            ).stdout.splitlines()
            if len(out) != PASSES * len(sensors):
                raise SystemExit(f"rtrace gave {len(out)} values, {PASSES * len(sensors)} expected")
            for n, s in enumerate(sensors):
                lux = 0.0
                for p in range(PASSES):
                    r, g, b = map(float, out[p * len(sensors) + n].split()[:3])
                    lux += LUMINOUS_EFFICACY * (RGB_TO_Y[0] * r + RGB_TO_Y[1] * g + RGB_TO_Y[2] * b)
                rows.append(f"{hour}.0,{s['id']},{lux / PASSES:.1f}")
            print(f"# {args.sky} {hour:02d}:00 done", file=sys.stderr)
    text = "\n".join(rows) + "\n"
    if args.out:
        args.out.write_text(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
