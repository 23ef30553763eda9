#!/usr/bin/env python3
"""Greg Ward's 1990 empty grey room with Radiance: ceiling (and floor) radiosity per point.

The room (Ward, "example calculation", globillum mailing list, 9 Oct 1990; the Radiance
test suite's tests/empty/diffuse/grey): 10 x 6 x 3, a 0.5 x 0.5 Lambertian source at the centre
of the ceiling with emittance 31.416 W/m^2 (radiance 10 W/m^2/sr), reflectance 0 there;
ceiling 0.70, walls 0.50, floor 0.30, all Lambertian. Points on a 0.5 grid starting 0.25 from
the corner; by symmetry one quarter (x <= 5, y <= 3) is enough.

Method (the one of docs/formats.md): `rtrace -I` without irradiance cache
(-aa 0), 4096 first-bounce samples, 12 bounces (-ab 12 -lw 5e-5), every source shadow-tested,
the source subdivided (-ds 0.05 -dj 1); `--seeds` passes in one rtrace process, averaged (each
pass continues the random stream). Irradiance E [W/m^2] at the point, facing into the room;
radiosity B = rho E (ceiling and floor receive no self-emission).

Writes a CSV: surface,x_m,y_m,irradiance_w_m2,radiosity_w_m2,stderr_w_m2 (stderr of B over the
passes). Needs Python >= 3.11 and pyradiance only.

    python3 ward.py --seeds 8 --out results/ward_radiance.csv
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

try:
    import pyradiance  # noqa: F401  (puts its bin/ on PATH and lib/ on RAYPATH)
except ImportError:  # pragma: no cover
    sys.exit("pyradiance is not installed: pip install pyradiance")

BIN = Path(pyradiance.BINPATH)
LX, LY, LZ = 10.0, 6.0, 3.0
RHO = {"ceiling": 0.70, "wall": 0.50, "floor": 0.30}
SOURCE_RADIANCE = 31.416 / 3.141592653589793  # W/m^2/sr: exitance / pi


def poly(mat: str, name: str, pts: list[tuple[float, float, float]]) -> str:
    coords = "\n".join(f"\t{x:.6f} {y:.6f} {z:.6f}" for x, y, z in pts)
    return f"{mat} polygon {name}\n0\n0\n{3 * len(pts)}\n{coords}\n"


def scene() -> str:
    s = []
    for m, r in RHO.items():
        s.append(f"void plastic {m}\n0\n0\n5 {r} {r} {r} 0 0\n")
    L = SOURCE_RADIANCE
    s.append(f"void light source\n0\n0\n3 {L:.6f} {L:.6f} {L:.6f}\n")
    # faces counter-clockwise seen from inside the room (Radiance: front by the right-hand rule)
    s.append(poly("floor", "floor", [(0, 0, 0), (LX, 0, 0), (LX, LY, 0), (0, LY, 0)]))
    s.append(poly("wall", "wall_s", [(0, 0, 0), (0, 0, LZ), (LX, 0, LZ), (LX, 0, 0)]))
    s.append(poly("wall", "wall_n", [(LX, LY, 0), (LX, LY, LZ), (0, LY, LZ), (0, LY, 0)]))
    s.append(poly("wall", "wall_w", [(0, LY, 0), (0, LY, LZ), (0, 0, LZ), (0, 0, 0)]))
    s.append(poly("wall", "wall_e", [(LX, 0, 0), (LX, 0, LZ), (LX, LY, LZ), (LX, LY, 0)]))
    x0, x1, y0, y1 = 4.75, 5.25, 2.75, 3.25

    def down(a, b, c, d):  # rectangle [a,b] x [c,d] on the ceiling, facing down
        return [(a, d, LZ), (b, d, LZ), (b, c, LZ), (a, c, LZ)]

    for k, r in enumerate([(0, x0, 0, LY), (x1, LX, 0, LY), (x0, x1, 0, y0), (x0, x1, y1, LY)]):
        s.append(poly("ceiling", f"ceiling.{k}", down(*r)))
    s.append(poly("source", "source", down(x0, x1, y0, y1)))
    return "".join(s)


def points() -> list[tuple[str, float, float]]:
    xs = [0.25 + 0.5 * i for i in range(10)]
    ys = [0.25 + 0.5 * j for j in range(6)]
    return [(surf, x, y) for surf in ("ceiling", "floor") for x in xs for y in ys]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("-ab", type=int, default=12)
    ap.add_argument("-ad", type=int, default=4096)
    ap.add_argument("-lw", type=float, default=5e-5)
    ap.add_argument("--out", default="results/ward_radiance.csv")
    a = ap.parse_args(argv)
    pts = points()
    rays = []
    for surf, x, y in pts:
        if surf == "ceiling":
            rays.append(f"{x} {y} {LZ - 1e-4} 0 0 -1")
        else:
            rays.append(f"{x} {y} 1e-4 0 0 1")
    stdin = "\n".join(rays * a.seeds) + "\n"
    with tempfile.TemporaryDirectory() as tmp:
        rad = Path(tmp) / "ward.rad"
        rad.write_text(scene())
        oct_ = Path(tmp) / "ward.oct"
        with open(oct_, "wb") as f:
            subprocess.run([str(BIN / "oconv"), str(rad)], stdout=f, check=True)
        opts = ["-I", "-h", "-ov", "-aa", "0", "-ab", str(a.ab), "-ad", str(a.ad),
                "-lw", str(a.lw), "-ds", "0.05", "-dj", "1", "-dt", "0", "-dc", "1"]
        t0 = time.perf_counter()
        p = subprocess.run([str(BIN / "rtrace"), *opts, str(oct_)], input=stdin,
                           capture_output=True, text=True, check=True)
        dt = time.perf_counter() - t0
    vals = [float(ln.split()[0]) for ln in p.stdout.splitlines() if ln.strip()]
    n = len(pts)
    if len(vals) != n * a.seeds:
        sys.exit(f"rtrace gave {len(vals)} values, expected {n * a.seeds}")
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w") as f:
        f.write(f"# rtrace {' '.join(opts)}; {a.seeds} passes; {dt:.0f} s\n")
        f.write("surface,x_m,y_m,irradiance_w_m2,radiosity_w_m2,stderr_w_m2\n")
        for k, (surf, x, y) in enumerate(pts):
            e = [vals[s * n + k] for s in range(a.seeds)]
            rho = RHO[surf]
            se = statistics.stdev(e) / len(e) ** 0.5 if len(e) > 1 else 0.0
            f.write(f"{surf},{x},{y},{statistics.fmean(e):.6g},{rho * statistics.fmean(e):.6g},"
                    f"{rho * se:.3g}\n")
    print(f"{n} points x {a.seeds} passes in {dt:.1f} s -> {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
