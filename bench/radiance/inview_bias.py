#!/usr/bin/env python3
"""The signed error of the values a node measures (source `measured`) on the generalization
bench, split into the artificial and the daylight part (docs/generalization.md, eighteenth
measurement).

Runs `luxnode live` on each room's live frames (night, overcast day, clear day) with the images
`rooms.py --evaluate` left in WORK/<room>/<res>/eval/one_node{,_plan}/, and compares every
measured desk with Radiance's truth (truth.csv's all-on row and its `lux_sky`, truth_clear.csv).
Prints, per light and configuration, the mean |error| and the signed means of the total, the
artificial part and the daylight part (in per cent of the desk's total), and the daylight
part's median error relative to itself, by overcast day next to the overcast sky frames' own
error at those desks (rows.json's frame checks: the renderer's).

    python3 bench/radiance/inview_bias.py --luxnode target/release/luxnode \\
        --room-set scenes/rooms /tmp/rooms --room-set /tmp/scenes29 /tmp/rooms29
"""
import argparse
import json
import math
import statistics as st
from pathlib import Path

import rooms


def measured_rows(a, d: Path, rd: Path, key: str) -> list[dict]:
    allon = rooms.read_truth(d)
    clear = rooms.read_truth_clear(d) or {}
    out = []
    for cfg in ("one_node", "one_node_plan"):
        for img in sorted((rd / "eval" / cfg).glob("node_*.img")):
            cam = img.stem
            for light in ("night", "day", "clear"):
                if not (rd / "live" / f"{cam}_{light}.png").exists():
                    continue
                for s, r in rooms.live_rows(Path(a.luxnode), d, rd, cam, img, light).items():
                    if r["source"] != "measured" or not r["lux_total"]:
                        continue
                    art_t, sky = allon[(1, s)]
                    day_t = {"night": 0.0, "day": sky, "clear": clear.get(s, math.nan)}[light]
                    out.append(dict(key=key, room=d.name, cfg=cfg, cam=cam, light=light, s=s,
                                    art=float(r["lux_artificial"]), day=float(r["lux_daylight"]),
                                    art_t=art_t, day_t=day_t))
    return out


def frame_sky_errors(rd: Path, key: str) -> dict:
    rows = json.loads((rd / "eval" / "rows.json").read_text())
    return {(key, f["room"], "node_" + f["node"], f["sensor"]): f["sky"] for f in rows["frames"]}


def report(rows: list[dict], sky_err: dict) -> None:
    for light in ("night", "day", "clear"):
        for cfg in ("one_node", "one_node_plan"):
            rs = [r for r in rows if r["light"] == light and r["cfg"] == cfg
                  and math.isfinite(r["day_t"])]
            if not rs:
                continue
            tot = lambda r: r["art_t"] + r["day_t"]  # noqa: E731
            e_tot = [(r["art"] + r["day"] - tot(r)) / tot(r) for r in rs]
            e_art = [(r["art"] - r["art_t"]) / tot(r) for r in rs]
            e_day = [(r["day"] - r["day_t"]) / tot(r) for r in rs]
            line = (f"{light:6} {cfg:14} n={len(rs):3}  |total| {100 * st.mean(map(abs, e_tot)):4.1f} %"
                    f"  signed: total {100 * st.mean(e_tot):+4.1f} %, artificial "
                    f"{100 * st.mean(e_art):+4.1f} %, daylight {100 * st.mean(e_day):+4.1f} %")
            lit = [r for r in rs if r["day_t"] > 20.0]
            if light != "night" and lit:
                rel = [r["day"] / r["day_t"] - 1.0 for r in lit]
                frames = [sky_err.get((r["key"], r["room"], r["cam"], r["s"])) for r in lit]
                frames = [f for f in frames if f is not None]
                line += f"; daylight vs itself: median {100 * st.median(rel):+4.1f} %"
                if frames and light == "day":
                    line += f" (the overcast frames' own {100 * st.median(frames):+4.1f} %)"
            print(line)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--luxnode", required=True)
    ap.add_argument("--room-set", nargs=2, action="append", required=True,
                    metavar=("SCENES", "WORK"), help="a --out and --work pair of rooms.py")
    ap.add_argument("--resolution", default="320x240")
    a = ap.parse_args()
    rows, sky_err = [], {}
    for scenes, work in a.room_set:
        for d in sorted(Path(scenes).glob("room_*")):
            rd = Path(work) / d.name / a.resolution
            if not (rd / "eval").exists():
                continue
            rows += measured_rows(a, d, rd, scenes)
            sky_err.update(frame_sky_errors(rd, scenes))
    report(rows, sky_err)


if __name__ == "__main__":
    main()
