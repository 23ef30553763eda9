#!/usr/bin/env bash
# Cross-builds luxnode for aarch64-unknown-linux-gnu (the ceiling node's SoC class) and runs its
# tests under qemu-aarch64: every unit test, photometry, scenes, the closed-form physics, the
# store (images, slots, corruption, bit flips, stuck pages, file flash), and office_a's accuracy
# at default settings. Emulation is 40-50 times slower, so the tests that commission office_a
# many times, the exhaustive power-cut sweeps, the extremes suite, the CLI tests and the checks of
# the published figures (timed, and office_a commissioned a dozen times) run natively only
# (scripts/test.sh); they exercise the same code. The Modbus tests that start servers as
# processes and drive them with mbpoll/pymodbus, the HIL rig (processes), commissioning from
# captures and the camera simulator (seconds of ray casting each), the rooms seen by several
# nodes against Radiance (a dozen commissionings), live light and the report
# (commissioning the demo office, a browser) run natively too; the fuzzer,
# the A010 ToF parser, V4L2 decoding and streaming (recorded streams), the replay camera, the
# sensor layer's drivers on simulated buses and the NOR/MTD flash backends run on both.
set -euo pipefail
cd "$(dirname "$0")/.."

rustup target list --installed | grep -q '^aarch64-unknown-linux-gnu$' || rustup target add aarch64-unknown-linux-gnu
if ! command -v aarch64-linux-gnu-gcc >/dev/null || ! command -v qemu-aarch64 >/dev/null; then
  apt-get install -y -q gcc-aarch64-linux-gnu qemu-user >/dev/null || { apt-get update -q >/dev/null && apt-get install -y -q gcc-aarch64-linux-gnu qemu-user >/dev/null; }
fi

export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER="qemu-aarch64 -L /usr/aarch64-linux-gnu"
export LUXNODE_TEST_RUNNER="$CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER"
# An allowlist: a new test binary runs natively only until it is added here (a dozen
# commissionings under emulation take a quarter of an hour). Only these binaries are built:
# nextest's filter alone would build all forty for aarch64 and run fourteen.
tests=(architecture deploy engine_physics flash peripherals photometry scene v4l2_stream
       camera control fixture modbus office_a store)
targets=(--lib --bins)
for t in "${tests[@]}"; do targets+=(--test "$t"); done
cargo nextest run --release --target aarch64-unknown-linux-gnu --no-fail-fast "${targets[@]}" \
  -E '(kind(lib) | kind(bin)
       | binary(architecture) | binary(deploy) | binary(engine_physics) | binary(flash)
       | binary(peripherals) | binary(photometry) | binary(scene) | binary(v4l2_stream)
       | (binary(camera) & not (test(/^sim_/) | test(demo_office) | test(capture_sequence)
                                | test(daylight_drifting)
                                | test(the_live_section)))
       | (binary(control) & not (test(every_desk) | test(a_day_of) | test(published)
                                 | test(closed_loop)))
       | (binary(fixture) & not test(the_cli_))
       | (binary(modbus) & test(fuzzed))
       | (binary(office_a) & test(default_settings))
       | (binary(store) & not (test(image_answers) | test(at_every_precision)
                               | test(shrunk_to_fit))))
      & not (test(power_cut) | test(open_box) | test(registered_frames_come_through)
             | test(reflectance_sensitivity_matches))' "$@"
