#!/usr/bin/env bash
# The run-time core on a Cortex-M4F: builds a demo flash image on the host, links it into the
# FORMFACTORS region of this repository's memory.x, runs the firmware in QEMU (Arm MPS2 AN386)
# and checks that every value it prints equals the host's run-time core on the same image.
set -euo pipefail
cd "$(dirname "$0")/.."

rustup target list --installed | grep -q '^thumbv7em-none-eabihf$' || rustup target add thumbv7em-none-eabihf
if ! command -v qemu-system-arm >/dev/null; then
  apt-get install -y -q qemu-system-arm >/dev/null || { apt-get update -q >/dev/null && apt-get install -y -q qemu-system-arm >/dev/null; }
fi

cargo build --release --bin luxnode
out=target/firmware-check
mkdir -p "$out"
img="$PWD/$out/demo.img"
target/release/luxnode image build --scene demo-office --patch-size 2 --rays 100 --out "$img"
(cd firmware/mps2-an386 && cargo fmt --check && LUXNODE_IMAGE="$img" cargo clippy --release -q -- -D warnings)
(cd firmware/mps2-an386 && LUXNODE_IMAGE="$img" timeout 300 cargo run --release) > "$out/firmware.txt"
grep -v '^#' "$out/firmware.txt" > "$out/firmware.csv"
target/release/luxnode image eval "$img" --demo-states > "$out/host.csv"
head -n 1 "$out/firmware.txt"
if diff -u "$out/host.csv" "$out/firmware.csv"; then
  echo "firmware check: the Cortex-M4 printed the host's values ($(($(wc -l < "$out/host.csv") - 1)) readings)"
else
  echo "firmware check FAILED: the Cortex-M4's values differ from the host's" >&2
  exit 1
fi
