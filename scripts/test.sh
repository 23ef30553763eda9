#!/usr/bin/env bash
# Runs every test of luxnode. Installs what the tests need when it is missing (rustup targets,
# QEMU, the aarch64 cross compiler), so it works on a fresh machine with only the Rust toolchain.
# This is the README's test command; .ci/run calls it.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! cargo nextest --version >/dev/null 2>&1; then
  echo "== cargo-nextest missing: installing it"
  cargo install cargo-nextest --locked
fi

echo "== client programs for the Modbus tests (mbpoll, socat, pymodbus)"
scripts/install-test-tools.sh

echo "== Cortex-M4 firmware under QEMU (mps2-an386): run-time core equals the host's"
scripts/firmware-check.sh

echo "== aarch64 cross build, tests under qemu-aarch64"
scripts/cross-aarch64.sh

echo "== kernel drivers for the real-device tests"
# The V4L2 streaming test against the kernel's vivid driver and a raw MTD device need kernel
# modules (vivid, mtdram) that a container cannot load: say so, the tests stay ignored (skipped),
# and the recorded-stream and file-backed MTD tests run instead.
if [ -e /sys/module/vivid ]; then
  echo "vivid is loaded: run the ignored V4L2 test with: cargo nextest run --release --test v4l2_stream --run-ignored all"
else
  echo "vivid is not loaded (no /sys/module/vivid): V4L2 streaming is tested on recorded streams only"
fi
if ls /dev/mtd[0-9]* >/dev/null 2>&1; then
  echo "MTD devices exist: $(ls /dev/mtd[0-9]* | tr '\n' ' ')(the tests use a file-backed MTD all the same)"
else
  echo "no /dev/mtdN (mtdram cannot be loaded here): the MTD backend is tested on a file with MTD semantics"
fi

echo "== tests (release build: the physics tests cast millions of rays)"
# one test more than cores: a dozen tests spend most of their time waiting on a node process or
# a client program (the HIL rig's simulated day, BACnet and Modbus timeouts), and a core would
# sit idle under each (stop 54, 2 cores: 830 s before, 611 s with this and the sim board's virtual
# I2C time); the timed tests run alone (.config/nextest.toml)
export NEXTEST_TEST_THREADS="${NEXTEST_TEST_THREADS:-$(($(nproc) + 1))}"
cargo nextest run --release --no-fail-fast "$@"

# coverage-guided fuzz smoke: every target a few seconds (docs/fuzzing.md); the stable smoke
# (tests/fuzz_smoke.rs) has run every target's body above in any case. LUXNODE_SKIP_FUZZ=1
# skips this step (it builds the fuzz crate with the nightly toolchain: minutes).
if [ "${LUXNODE_SKIP_FUZZ:-0}" != 1 ]; then
  echo "== fuzz smoke: every cargo-fuzz target for 3 s"
  scripts/fuzz.sh smoke 3
fi
