#!/usr/bin/env python3
"""Radiance on office_a: time the 31-scenario sensor table and score it against truth.csv.

Runs the real Radiance binaries shipped in the `pyradiance` wheel (oconv, rtrace):
for each scene to compute, `oconv` builds an octree from the files in the scene's
`radiance/` folder, then `rtrace -I -h` computes irradiance at the 8 sensors.

Modes:
  superpose  compute the 8 single-luminaire scenes once; every scenario is the sum of
             its luminaires (illuminance is linear in emission): 8 octrees, 8 rtrace runs.
  each       compute each of the 31 scenarios as its own scene: 31 octrees, 31 rtrace runs.

Conversion: lux = 179 * (0.265 R + 0.670 G + 0.065 B), R G B the irradiance in W/m^2
(Radiance's white luminous efficacy 179 lm/W, as used by ies2rad; the scene is grey).

Seeds: rtrace has no seed option; with -u+ (the default) it calls srandom(time(0)), so
its stream changes every second and two processes started in the same second draw the
same random numbers. `--seeds N` traces the 8 sensors N times in a row in one rtrace
process (each block continues the stream, so the N blocks are independent samples) and
averages them. So that parallel runs of different scenes never share a stream, run j
first traces j cheap dummy rays (discarded), which shifts its stream.

Error (the paper's Table 1 measure): mean |lux - true lux| / mean true lux over all
(scenario, sensor) pairs; each sensor's error the same over its own 31 pairs.

Only the standard library and pyradiance (for the binaries) are used.
"""

from __future__ import annotations

import argparse
import csv
import datetime as _dt
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

try:
    import pyradiance  # noqa: F401  (importing it puts its bin/ on PATH and lib/ on RAYPATH)
except ImportError:  # pragma: no cover
    sys.exit("pyradiance is not installed: pip install pyradiance")

BINPATH = Path(pyradiance.BINPATH)
OCONV = str(BINPATH / "oconv")
RTRACE = str(BINPATH / "rtrace")

DEFAULT_SCENE = Path(__file__).resolve().parents[2] / "reference/scenes/office_a"
LUMINOUS_EFFICACY = 179.0  # lm/W, Radiance's WHTEFFICACY
RGB_TO_Y = (0.265, 0.670, 0.065)  # Radiance's standard RGB luminance weights
# A point far outside the closed room, facing up: its ambient samples escape and its
# shadow rays hit the room's outside, so it is cheap (~1 ms) but still draws random numbers.
DUMMY_RAY = "60 60 1.5 0 0 1\n"


# ---------------------------------------------------------------- scene files

def read_states(scene: Path) -> list[tuple[int, list[int]]]:
    with open(scene / "states.csv", newline="") as f:
        return [(int(r["scenario_id"]), [int(x) for x in r["luminaires_on"].split(";") if x])
                for r in csv.DictReader(f)]


def read_truth(scene: Path, column: str = "lux") -> dict[tuple[int, int], float]:
    with open(scene / "truth.csv", newline="") as f:
        return {(int(r["scenario_id"]), int(r["sensor_id"])): float(r[column])
                for r in csv.DictReader(f)}


def read_sensors(scene: Path) -> list[dict]:
    with open(scene / "sensors.json") as f:
        return json.load(f)


def luminaire_ids(rad_dir: Path) -> list[int]:
    return sorted(int(p.stem.rsplit("_", 1)[1]) for p in rad_dir.glob("lum_on_*.rad"))


def scene_files(all_ids: list[int], on: set[int]) -> list[str]:
    """Radiance files of a scene, relative to radiance/: shell, then each luminaire on or off."""
    return ["materials.rad", "geometry.rad"] + [
        f"lum_on_{k}.rad" if k in on else f"lum_off_{k}.rad" for k in all_ids]


# ---------------------------------------------------------------- running Radiance

def rtrace_options(a: argparse.Namespace) -> list[str]:
    opts = ["-I", "-h", "-ov",
            "-ab", str(a.ab), "-ad", str(a.ad), "-as", str(a.as_), "-aa", str(a.aa),
            "-lw", str(a.lw), "-lr", str(a.lr),
            "-ds", str(a.ds), "-dj", str(a.dj), "-dt", str(a.dt), "-dc", str(a.dc)]
    if a.extra:
        opts += a.extra.split()
    return opts


def run_scene(name: str, files: list[str], rad_dir: Path, work: Path, opts: list[str],
              rays: str, n_dummy: int, n_sensors: int, seeds: int) -> dict:
    """oconv + rtrace for one scene; returns per-seed lux lists and timings."""
    octree = work / f"{name}.oct"
    t0 = time.perf_counter()
    with open(octree, "wb") as out:
        p = subprocess.run([OCONV, *files], cwd=rad_dir, stdout=out, stderr=subprocess.PIPE)
    t1 = time.perf_counter()
    if p.returncode != 0:
        raise RuntimeError(f"oconv failed for {name}: {p.stderr.decode(errors='replace')}")
    # cwd = radiance/ so that luminaire.dat is found through RAYPATH's '.'
    p = subprocess.run([RTRACE, *opts, str(octree)], cwd=rad_dir, input=rays,
                       capture_output=True, text=True)
    t2 = time.perf_counter()
    if p.returncode != 0:
        raise RuntimeError(f"rtrace failed for {name}: {p.stderr}")
    lines = [ln.split() for ln in p.stdout.splitlines() if ln.strip()]
    expect = n_dummy + n_sensors * seeds
    if len(lines) != expect:
        raise RuntimeError(f"rtrace for {name}: {len(lines)} output lines, expected {expect}")
    lux = [LUMINOUS_EFFICACY * sum(w * float(v) for w, v in zip(RGB_TO_Y, ln[:3]))
           for ln in lines[n_dummy:]]
    per_seed = [lux[s * n_sensors:(s + 1) * n_sensors] for s in range(seeds)]
    return {"name": name, "per_seed": per_seed, "oconv_s": t1 - t0, "rtrace_s": t2 - t1,
            "stderr": p.stderr.strip()}


def mean(xs):
    return sum(xs) / len(xs)


def stderr_of_mean(xs):
    n = len(xs)
    if n < 2:
        return None
    m = mean(xs)
    return (sum((x - m) ** 2 for x in xs) / (n - 1) / n) ** 0.5


# ---------------------------------------------------------------- main

def parse_args(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(
        description="Run Radiance (pyradiance's oconv/rtrace) on office_a, time the "
                    "31-scenario sensor table and score it against truth.csv.")
    ap.add_argument("--scene", type=Path, default=DEFAULT_SCENE, help="scene directory (default %(default)s)")
    ap.add_argument("--mode", choices=("superpose", "each"), default="superpose",
                    help="superpose: 8 single-luminaire runs summed; each: 31 separate scenes (default %(default)s)")
    g = ap.add_argument_group("Radiance settings (rtrace options)")
    g.add_argument("-ab", type=int, default=8, help="ambient bounces (default %(default)s; truth 12)")
    g.add_argument("-ad", type=int, default=1024, help="ambient divisions (default %(default)s; truth 4096)")
    g.add_argument("-as", dest="as_", metavar="AS", type=int, default=0, help="ambient super-samples (default %(default)s)")
    g.add_argument("-aa", type=float, default=0.0, help="ambient accuracy, 0 = no irradiance cache (default %(default)s, as truth)")
    g.add_argument("-lw", type=float, default=1e-4, help="limit weight (default %(default)s; truth 5e-5)")
    g.add_argument("-lr", type=int, default=-10, help="limit reflection (default %(default)s, Radiance's default)")
    g.add_argument("-ds", type=float, default=0.05, help="source subdivision (default %(default)s, as truth)")
    g.add_argument("-dj", type=float, default=1.0, help="source jitter (default %(default)s, as truth)")
    g.add_argument("-dt", type=float, default=0.0, help="direct threshold, 0 = test every source (default %(default)s)")
    g.add_argument("-dc", type=float, default=1.0, help="direct certainty (default %(default)s)")
    g.add_argument("--extra", default="", help="further rtrace options, one string, e.g. \"-lr 12\"")
    ap.add_argument("--seeds", type=int, default=1, help="independent sample blocks averaged (default %(default)s)")
    ap.add_argument("--jobs", type=int, default=2, help="parallel Radiance processes, at most 2 (default %(default)s)")
    ap.add_argument("--truth-column", choices=("lux", "lux_direct", "lux_indirect"), default="lux",
                    help="truth.csv column to score against (lux_direct: check an -ab 0 run) (default %(default)s)")
    ap.add_argument("--json", type=Path, help="write the result to this JSON file")
    ap.add_argument("--keep", type=Path, help="keep octrees in this directory (default: a temporary one)")
    ap.add_argument("--quiet", action="store_true", help="print only the summary line")
    a = ap.parse_args(argv)
    if not 1 <= a.jobs <= 2:
        ap.error("--jobs must be 1 or 2")
    if a.seeds < 1:
        ap.error("--seeds must be >= 1")
    return a


def main(argv=None) -> int:
    a = parse_args(argv)
    scene = a.scene.resolve()
    rad_dir = scene / "radiance"
    states = read_states(scene)
    truth = read_truth(scene, a.truth_column)
    sensors = read_sensors(scene)
    sensor_ids = [s["id"] for s in sensors]
    all_ids = luminaire_ids(rad_dir)
    opts = rtrace_options(a)

    sensor_rays = "".join("%.9g %.9g %.9g %.9g %.9g %.9g\n" % (*s["position"], *s["normal"])
                          for s in sensors)

    # The scenes to compute: (name, files, cost estimate for scheduling)
    if a.mode == "superpose":
        jobs = [(f"lum{k}", scene_files(all_ids, {k}), 1) for k in all_ids]
    else:
        jobs = [(f"scn{sid}", scene_files(all_ids, set(on)), len(on)) for sid, on in states]
    # Longest first, so that the two workers finish together (all-on costs ~8 singles).
    jobs.sort(key=lambda j: -j[2])

    work_ctx = tempfile.TemporaryDirectory(prefix="radbench_") if a.keep is None else None
    work = Path(work_ctx.name) if work_ctx else a.keep.resolve()
    work.mkdir(parents=True, exist_ok=True)

    version = subprocess.run([RTRACE, "-version"], capture_output=True, text=True).stdout.strip()
    load_before = os.getloadavg()
    cpu0 = os.times()
    t_start = time.perf_counter()
    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        futs = [pool.submit(run_scene, name, files, rad_dir, work, opts,
                            DUMMY_RAY * j + sensor_rays * a.seeds, j, len(sensors), a.seeds)
                for j, (name, files, _) in enumerate(jobs)]
        results = {f.result()["name"]: f.result() for f in futs}
    wall = time.perf_counter() - t_start
    cpu1 = os.times()
    load_after = os.getloadavg()
    if work_ctx:
        work_ctx.cleanup()
    cpu_s = (cpu1.children_user - cpu0.children_user) + (cpu1.children_system - cpu0.children_system)

    warnings = sorted({r["stderr"] for r in results.values() if r["stderr"]})

    # Assemble each scenario, per seed, then average over seeds.
    rows = []
    for sid, on in states:
        if a.mode == "superpose":
            per_seed = [[sum(results[f"lum{k}"]["per_seed"][s][i] for k in on)
                         for i in range(len(sensors))] for s in range(a.seeds)]
        else:
            per_seed = results[f"scn{sid}"]["per_seed"]
        for i, sens in enumerate(sensor_ids):
            samples = [per_seed[s][i] for s in range(a.seeds)]
            rows.append({"scenario_id": sid, "luminaires_on": ";".join(map(str, on)),
                         "sensor_id": sens, "lux": mean(samples),
                         "lux_stderr": stderr_of_mean(samples),
                         "lux_true": truth[(sid, sens)]})

    def err(rs):
        return sum(abs(r["lux"] - r["lux_true"]) for r in rs) / sum(r["lux_true"] for r in rs)

    error = err(rows)
    per_sensor = {s: err([r for r in rows if r["sensor_id"] == s]) for s in sensor_ids}
    worst_id = max(per_sensor, key=per_sensor.get)
    bias = sum(r["lux"] - r["lux_true"] for r in rows) / sum(r["lux_true"] for r in rows)

    settings = {"ab": a.ab, "ad": a.ad, "as": a.as_, "aa": a.aa, "lw": a.lw, "lr": a.lr,
                "ds": a.ds, "dj": a.dj, "dt": a.dt, "dc": a.dc, "extra": a.extra,
                "seeds": a.seeds}
    label = " ".join(f"-{k} {v}" for k, v in settings.items()
                     if k not in ("extra", "seeds")) + \
        (f" {a.extra}" if a.extra else "") + f" seeds={a.seeds}"
    result = {
        "scene": scene.name,
        "tool": "radiance",
        "radiance_version": version,
        "radiance_bin": str(BINPATH),
        "mode": a.mode,
        "settings": settings,
        "rtrace_command": [RTRACE, *opts, "<octree>"],
        "runs": len(jobs),
        "jobs": a.jobs,
        "wall_time_s": wall,
        "cpu_time_s": cpu_s,
        "oconv_time_s_sum": sum(r["oconv_s"] for r in results.values()),
        "rtrace_time_s_sum": sum(r["rtrace_s"] for r in results.values()),
        "truth_column": a.truth_column,
        "error": error,
        "bias": bias,
        "worst_sensor_error": per_sensor[worst_id],
        "worst_sensor_id": worst_id,
        "sensor_error": {str(k): v for k, v in per_sensor.items()},
        "lux_conversion": "179 * (0.265 R + 0.670 G + 0.065 B)",
        "loadavg_before": load_before,
        "loadavg_after": load_after,
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                    "processor": platform.processor() or platform.machine()},
        "date": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
        "warnings": warnings,
        "results": rows,
    }

    if not a.quiet:
        print(f"Radiance {version} | office_a | mode {a.mode} | {len(jobs)} runs, {a.jobs} at a time")
        print(f"rtrace {' '.join(opts)}")
        print(f"{'sensor':>6} {'error %':>8} {'mean lux':>9} {'mean true':>9}")
        for s in sensor_ids:
            rs = [r for r in rows if r["sensor_id"] == s]
            print(f"{s:>6} {100 * per_sensor[s]:8.3f} {mean([r['lux'] for r in rs]):9.2f} "
                  f"{mean([r['lux_true'] for r in rs]):9.2f}")
        for w in warnings:
            print("rtrace:", w, file=sys.stderr)
    print(f"{a.mode:9s} {label} | wall {wall:7.2f} s cpu {cpu_s:7.2f} s | error {100 * error:.3f} % "
          f"(bias {100 * bias:+.3f} %) | worst sensor {worst_id}: {100 * per_sensor[worst_id]:.3f} %")
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
