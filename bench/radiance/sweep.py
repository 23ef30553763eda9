#!/usr/bin/env python3
"""Time-versus-error ladder for Radiance on office_a: runs office_a.py once per rung and repeat.

rtrace seeds itself from the clock, so every run is a fresh Monte Carlo sample: each rung is
repeated (--repeats) and the table gives the mean (and range) of error and wall time.
Writes one JSON per run to --out/runs/ and the table to --out/sweep.md and --out/sweep.json.

Standard library only; office_a.py needs pyradiance.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

# (mode, office_a.py options): cheap to costly
RUNGS = [
    ("superpose", "-ab 2 -ad 256 -lw 1e-3"),
    ("superpose", "-ab 4 -ad 512 -lw 5e-4"),
    ("superpose", "-ab 6 -ad 512 -lw 2e-4"),
    ("superpose", "-ab 6 -ad 1024 -lw 1e-4"),
    ("superpose", "-ab 8 -ad 512 -lw 1e-4"),
    ("superpose", "-ab 8 -ad 1024 -lw 1e-4"),
    ("superpose", "-ab 8 -ad 2048 -lw 1e-4"),
    ("superpose", "-ab 8 -ad 512 -lw 1e-4 -ds 0.02"),
    ("superpose", "-ab 8 -ad 1024 -lw 1e-4 -ds 0.02"),
    ("superpose", "-ab 8 -ad 2048 -lw 1e-4 -ds 0.02"),
    ("superpose", "-ab 8 -ad 1024 -lw 1e-4 --seeds 2"),
    ("superpose", "-ab 8 -ad 512 -lw 1e-4 --seeds 4"),
    ("superpose", "-ab 10 -ad 2048 -lw 5e-5"),
    ("superpose", "-ab 8 -ad 4096 -lw 5e-5"),
    ("superpose", "-ab 12 -ad 4096 -lw 5e-5"),
    ("superpose", "-ab 12 -ad 4096 -lw 5e-5 --seeds 2"),
    ("each", "-ab 8 -ad 1024 -lw 1e-4"),
    ("each", "-ab 8 -ad 1024 -lw 1e-4 -ds 0.02"),
]

# --ad-ladder: the issue 33 comparison's ladder, the cited `-ab 8 -lw 1e-4` at several -ad
AD_LADDER = [("superpose", f"-ab 8 -ad {ad} -lw 1e-4") for ad in (256, 512, 1024, 2048, 4096)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="runs per rung (default %(default)s)")
    ap.add_argument("--out", type=Path, default=HERE / "results", help="output directory (default %(default)s)")
    ap.add_argument("--only", type=int, nargs="*", help="rung numbers (1-based) to run; default all")
    ap.add_argument("--ad-ladder", action="store_true",
                    help="run the -ab 8 -lw 1e-4 ladder over -ad 256..4096 instead of RUNGS")
    a = ap.parse_args()
    rungs = AD_LADDER if a.ad_ladder else RUNGS

    runs_dir = a.out / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for n, (mode, opts) in enumerate(rungs, 1):
        if a.only and n not in a.only:
            continue
        reps = []
        for r in range(a.repeats):
            out = runs_dir / f"rung{n:02d}_{mode}_rep{r + 1}.json"
            cmd = [sys.executable, str(HERE / "office_a.py"), "--mode", mode, *opts.split(),
                   "--quiet", "--json", str(out)]
            subprocess.run(cmd, check=True)
            reps.append(json.loads(out.read_text()))
        def mean(key):
            return sum(x[key] for x in reps) / len(reps)
        rows.append({
            "rung": n, "mode": mode, "options": opts, "repeats": len(reps),
            "settings": reps[0]["settings"],
            "wall_time_s": mean("wall_time_s"), "cpu_time_s": mean("cpu_time_s"),
            "error": mean("error"),
            "error_min": min(x["error"] for x in reps), "error_max": max(x["error"] for x in reps),
            "worst_sensor_error": mean("worst_sensor_error"),
            "worst_sensor_ids": [x["worst_sensor_id"] for x in reps],
            "bias": mean("bias"),
            "loadavg_max": max(max(x["loadavg_before"][0], x["loadavg_after"][0]) for x in reps),
        })

    lines = ["| # | mode | settings (others: -aa 0 -as 0 -ds 0.05 -dj 1 -dt 0 -dc 1 -lr -10) | wall s | cpu s | error % (min-max) | worst sensor % | bias % |",
             "|---|---|---|---|---|---|---|---|"]
    for x in rows:
        lines.append(
            f"| {x['rung']} | {x['mode']} | `{x['options']}` | {x['wall_time_s']:.2f} | {x['cpu_time_s']:.2f} | "
            f"{100 * x['error']:.2f} ({100 * x['error_min']:.2f}-{100 * x['error_max']:.2f}) | "
            f"{100 * x['worst_sensor_error']:.2f} (s{','.join(map(str, x['worst_sensor_ids']))}) | "
            f"{100 * x['bias']:+.2f} |")
    table = "\n".join(lines)
    stamp = _dt.datetime.now().astimezone().isoformat(timespec="seconds")
    head = (f"Radiance sweep on office_a, {stamp}, {platform.node() or 'host'} "
            f"({os.cpu_count()} cores, {platform.platform()}), {a.repeats} repeats per rung, "
            f"2 Radiance processes at a time.\n\n")
    (a.out / "sweep.md").write_text(head + table + "\n")
    (a.out / "sweep.json").write_text(json.dumps({"date": stamp, "cpus": os.cpu_count(),
                                                  "repeats": a.repeats, "rungs": rows}, indent=1) + "\n")
    print(head + table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
