#!/usr/bin/env bash
# Checks that `rust-version` in Cargo.toml is true: it is at least every dependency's own
# rust-version (from cargo metadata), and the library and the binary build with that toolchain.
set -euo pipefail
cd "$(dirname "$0")/.."
msrv=$(sed -n 's/^rust-version = "\(.*\)"/\1/p' Cargo.toml)
echo "rust-version = $msrv"
cargo metadata --format-version 1 --locked | python3 -c '
import json, sys
msrv = tuple(int(x) for x in sys.argv[1].split("."))
m = json.load(sys.stdin)
def v(s): return tuple(int(x) for x in s.split(".")[:3])
need = max(((v(p["rust_version"]), p["name"]) for p in m["packages"] if p.get("rust_version")), default=((0,), ""))
print("highest dependency rust-version: %s (%s)" % (".".join(map(str, need[0])), need[1]))
if need[0] > msrv + (0,) * (3 - len(msrv)):
    sys.exit("rust-version %s is below what %s needs" % (sys.argv[1], need[1]))
' "$msrv"
rustup toolchain list | grep -q "^$msrv-" || rustup toolchain install "$msrv" --profile minimal
cargo "+$msrv" check --locked --lib --bins
