#!/usr/bin/env python3
"""Reference values for src/sky from an independent program: Radiance's gensky.

Writes two files that tests/sky.rs reads:

* tests/data/sky_reference.csv: the sun's altitude and azimuth that gensky computes for a few
  instants and places. gensky is run as

      gensky MONTH DAY HH:MM -y YEAR -a LAT -o LON_WEST -m 0 -s

  with the time in UTC (standard meridian 0). Radiance's conventions, read from gensky.c and
  its manual: longitude and meridian are positive WEST (ours: east positive, so the sign is
  flipped); with -y the solar position is Michalsky's algorithm (Solar Energy 40, 1988,
  0.01 degrees for 1950..2050), without -y an older day-of-year formula. gensky prints
  "# Solar altitude and azimuth: ALT AZI" to 0.1 degree, azimuth measured from SOUTH, west
  positive; its sky line ("7 1 zenith ground F2 dx dy dz") carries the unit vector to the sun
  to 6 decimals in x east, y north, z up, from which altitude = asin(dz) and azimuth from
  north, clockwise = atan2(dx, dy) are recovered to ~1e-4 degree. Both are recorded, and the
  sun of the same command without -y (the older formulas: Spencer-like declination and
  equation of time from the day of the year, no year, so ~0.5..1 degree off).

* tests/data/sky_luminance_reference.csv: gensky's sky luminance shape. gensky's sky is the
  function `skybr` of skybright.cal; its clear sky (`sunnysky`, type 1) is Kittler's CIE clear
  sky, (0.91 + 10 exp(-3 gamma) + 0.45 cos^2 gamma)(1 - exp(-0.32 / cos Z)), i.e. ISO 15469
  type 12; its overcast sky (`cloudysky`, -c) is (1 + 2 cos Z)/3, the 1942 CIE overcast sky.
  `skybr` blends both with the ground brightness near the horizon, so the script evaluates
  `sunnysky` and `cloudysky` themselves with rcalc at a few directions, divided by their value
  at the zenith, with the sun vector gensky printed.

The Radiance binaries come from the pyradiance package (pip install pyradiance); the script
finds them next to it. Run from the repository root:  python3 scripts/sky_reference.py
"""

import math
import os
import subprocess
import sys

import pyradiance

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
RAD = os.path.dirname(pyradiance.__file__)
BIN = os.path.join(RAD, "bin")
LIB = os.path.join(RAD, "lib")

# (UTC date-time, latitude_deg north positive, longitude_deg east positive)
CASES = [
    ("2024-06-21T11:00:00Z", 47.4, 8.5),  # Zurich, summer solstice, near noon
    ("2024-12-21T14:30:00Z", 47.4, 8.5),  # Zurich, winter afternoon, sun low in the south-west
    ("2024-03-20T06:15:00Z", 47.4, 8.5),  # Zurich, equinox morning, sun in the east
    ("2025-09-23T16:45:00Z", 51.5, -0.1),  # London, autumn evening
    ("2023-01-15T17:00:00Z", 40.0, -105.0),  # Boulder (NOAA's home), winter morning
    ("2023-07-04T22:30:00Z", 40.0, -105.0),  # Boulder, summer afternoon
    ("2024-11-05T02:00:00Z", -33.9, 151.2),  # Sydney, southern-hemisphere noon: sun in the north
    ("2026-04-10T09:20:00Z", 1.3, 103.8),  # Singapore, near the equator, afternoon
    ("2024-08-01T05:00:00Z", 64.1, -21.9),  # Reykjavik, sun near the horizon
    ("2024-10-13T12:00:00Z", 0.0, 0.0),  # on the equator at Greenwich
]

# directions (altitude_deg, azimuth_deg from north clockwise) where the sky's shape is compared
SKY_DIRECTIONS = [
    (5.0, 0.0),
    (15.0, 90.0),
    (30.0, 180.0),
    (30.0, 210.0),
    (45.0, 270.0),
    (60.0, 160.0),
    (75.0, 45.0),
    (20.0, 330.0),
    (10.0, 200.0),
]


def run(args, stdin=None):
    env = dict(os.environ, RAYPATH=LIB)
    out = subprocess.run(
        args, input=stdin, capture_output=True, text=True, check=True, env=env
    )
    return out.stdout


def radiance_version():
    return run([os.path.join(BIN, "rtrace"), "-version"]).strip()


def gensky(utc, lat, lon_east, sky="-s", michalsky=True):
    """gensky's command line (without its path), printed angles and sky line's numbers."""
    date, time = utc.rstrip("Z").split("T")
    year, month, day = (int(x) for x in date.split("-"))
    hh, mm, _ = time.split(":")
    args = [
        os.path.join(BIN, "gensky"),
        str(month),
        str(day),
        f"{hh}:{mm}",
        *(["-y", str(year)] if michalsky else []),
        "-a",
        str(lat),
        "-o",
        str(-lon_east),
        "-m",
        "0",
        sky,
    ]
    printed = None
    sky_line = None
    for line in run(args).splitlines():
        if line.startswith("# Solar altitude and azimuth:"):
            printed = [float(x) for x in line.split(":")[1].split()]
        elif line.startswith("7 1 ") or line.startswith("3 2 "):
            sky_line = [float(x) for x in line.split()[1:]]
    if printed is None or sky_line is None:
        sys.exit(f"unexpected gensky output for {args}")
    return " ".join(args[1:]).replace(BIN + os.sep, ""), printed, sky_line


def sky_values(sky_line, function):
    """`function`/A2 of skybright.cal at SKY_DIRECTIONS and the zenith, by rcalc."""
    a = [1.0, sky_line[1], sky_line[2], sky_line[3], *sky_line[4:7]]
    args_a = ";".join(f"A{k + 1}={v!r}" for k, v in enumerate(a))
    dirs = [*SKY_DIRECTIONS, (90.0, 0.0)]
    lines = []
    for alt, azi in dirs:
        ca = math.cos(math.radians(alt))
        dx = ca * math.sin(math.radians(azi))
        dy = ca * math.cos(math.radians(azi))
        dz = 1.0 if alt == 90.0 else math.sin(math.radians(alt))
        lines.append(f"{dx!r} {dy!r} {dz!r}")
    out = run(
        [
            os.path.join(BIN, "rcalc"),
            "-f",
            "rayinit.cal",
            "-f",
            "skybright.cal",
            "-e",
            args_a,
            "-e",
            "Dx=$1;Dy=$2;Dz=$3",
            "-e",
            f"$1={function}",
        ],
        stdin="\n".join(lines) + "\n",
    )
    values = [float(x) for x in out.split()]
    zenith = values[-1]
    return [(alt, azi, v / zenith) for (alt, azi), v in zip(dirs[:-1], values[:-1])]


SUN_HEADER = """\
# written by scripts/sky_reference.py: Radiance gensky ({version}, pyradiance {pyradiance})
# command per row: gensky MONTH DAY HH:MM -y YEAR -a LAT -o -LON -m 0 -s
#   (time in UTC, standard meridian 0, longitude west positive as gensky wants it)
# altitude_deg, azimuth_deg: from gensky's sun vector (x east, y north, z up);
#   azimuth from north, clockwise
# printed_*: gensky's '# Solar altitude and azimuth' line
#   (0.1 deg; azimuth from south, west positive)
# simple_*: the same command without -y: gensky's older day-of-year formulas (sun vector)
utc,latitude_deg,longitude_deg,altitude_deg,azimuth_deg,\
printed_altitude_deg,printed_azimuth_south_deg,simple_altitude_deg,simple_azimuth_deg,command
"""

LUMINANCE_HEADER = """\
# written by scripts/sky_reference.py: Radiance skybright.cal evaluated by rcalc
#   ({version}, pyradiance {pyradiance})
# cie_type 12: gensky -s's sunnysky (Kittler's CIE clear sky); 16: gensky -c's cloudysky
# sun_dx,sun_dy,sun_dz: gensky's sun vector (x east, y north, z up)
# ratio: L(direction) / L(zenith)
cie_type,utc,latitude_deg,longitude_deg,sun_dx,sun_dy,sun_dz,altitude_deg,azimuth_deg,ratio
"""


def angles(sky_line):
    """(altitude, azimuth from north clockwise) in degrees of a sky line's sun vector."""
    dx, dy, dz = sky_line[4:7]
    alt = math.degrees(math.asin(max(-1.0, min(1.0, dz))))
    return alt, math.degrees(math.atan2(dx, dy)) % 360.0


def sun_row(utc, lat, lon, command, printed, sky_line):
    """One row of sky_reference.csv, after checking the vector against the printed angles."""
    alt, azi = angles(sky_line)
    # gensky's own azimuth is from south, west positive: from north clockwise is +180
    check = (printed[1] + 180.0) % 360.0
    if abs((azi - check + 180.0) % 360.0 - 180.0) > 0.06 or abs(alt - printed[0]) > 0.06:
        sys.exit(f"{utc}: the vector and the printed angles disagree: {alt} {azi} {printed}")
    simple_alt, simple_azi = angles(gensky(utc, lat, lon, michalsky=False)[2])
    return (
        f"{utc},{lat},{lon},{alt:.5f},{azi:.5f},{printed[0]},{printed[1]},"
        f"{simple_alt:.5f},{simple_azi:.5f},gensky {command}"
    )


def main():
    names = {"version": radiance_version(), "pyradiance": pyradiance.__version__}
    sun_rows = []
    lum_rows = []
    for utc, lat, lon in CASES:
        command, printed, sky_line = gensky(utc, lat, lon)
        sun_rows.append(sun_row(utc, lat, lon, command, printed, sky_line))
        if printed[0] > 5.0:
            sun = ",".join(repr(v) for v in sky_line[4:7])
            for alt_d, azi_d, ratio in sky_values(sky_line, "sunnysky"):
                lum_rows.append(f"12,{utc},{lat},{lon},{sun},{alt_d},{azi_d},{ratio!r}")
    # the overcast sky does not depend on the sun; one case is enough
    utc, lat, lon = CASES[0]
    _, _, over = gensky(utc, lat, lon, "-c")
    overcast = [0.0, over[0], over[1], 1.0, 0.0, 0.0, 1.0]
    for alt_d, azi_d, ratio in sky_values(overcast, "cloudysky"):
        lum_rows.append(f"16,{utc},{lat},{lon},0,0,1,{alt_d},{azi_d},{ratio!r}")

    data = os.path.join(ROOT, "tests", "data")
    os.makedirs(data, exist_ok=True)
    with open(os.path.join(data, "sky_reference.csv"), "w") as f:
        f.write(SUN_HEADER.format(**names))
        f.write("\n".join(sun_rows) + "\n")
    with open(os.path.join(data, "sky_luminance_reference.csv"), "w") as f:
        f.write(LUMINANCE_HEADER.format(**names))
        f.write("\n".join(lum_rows) + "\n")
    print(f"{len(sun_rows)} sun positions, {len(lum_rows)} sky luminance ratios")


if __name__ == "__main__":
    main()
