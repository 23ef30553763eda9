#!/usr/bin/env bash
# Coverage-guided fuzzing of luxnode's decoders with cargo-fuzz (libFuzzer, nightly toolchain).
# Targets (fuzz/fuzz_targets/, bodies in fuzz/bodies.rs): modbus_pdu modbus_rtu bacnet_datagram eulumdat ies
# obj_mtl scene_json capture_png board_toml flash_image calibration_record live_section.
# Corpora: fuzz/corpus/<target>/ (seeds from fuzz/make-corpus.py and docs/fuzzing.md; new finds go to fuzz/target/corpus-work/, not into the repository).
#
#   scripts/fuzz.sh smoke [SECONDS]        every target for SECONDS (default 5): CI's smoke
#   scripts/fuzz.sh run TARGET [SECONDS]   one target for SECONDS (default 600), e.g. minutes
#   scripts/fuzz.sh all [SECONDS]          every target for SECONDS each (default 300)
#
# Installs cargo-fuzz (cargo install --locked) when missing. Without a nightly toolchain it
# says so and exits 0: tests/fuzz_smoke.rs (stable, in every test run) still runs every target's
# body on its corpus and on mutations of it, so no target goes unexercised.
set -euo pipefail
cd "$(dirname "$0")/.."

TARGETS=(modbus_pdu modbus_rtu bacnet_datagram eulumdat ies obj_mtl scene_json capture_png board_toml flash_image calibration_record live_section)

if ! cargo +nightly --version >/dev/null 2>&1; then
  echo "== fuzz: no nightly toolchain; the stable smoke (tests/fuzz_smoke.rs) covers every target's body"
  exit 0
fi
if ! cargo fuzz --version >/dev/null 2>&1; then
  echo "== fuzz: installing cargo-fuzz"
  cargo install cargo-fuzz --locked
fi

run() {
  local target=$1 seconds=$2
  local work="fuzz/target/corpus-work/$target" log="fuzz/target/$target.log"
  mkdir -p "$work"
  echo "== fuzz $target for ${seconds} s"
  # -rss_limit_mb: a decoder that allocates without bound is a finding, not a slow run
  local ok=1
  (cd fuzz && cargo +nightly fuzz run -O "$target" "target/corpus-work/$target" "corpus/$target" -- \
     -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1) >"$log" 2>&1 || ok=0
  grep -E "^(stat::number_of_executed_units|stat::peak_rss_mb|#[0-9]+ +DONE)" "$log" || true
  if [ "$ok" -ne 1 ]; then
    echo "== fuzz $target FAILED (crash, leak, timeout or out of memory):"
    tail -60 "$log"
    exit 1
  fi
}

cmd=${1:-smoke}
case "$cmd" in
  smoke)
    (cd fuzz && cargo +nightly fuzz build -O >/dev/null)
    for t in "${TARGETS[@]}"; do run "$t" "${2:-5}"; done ;;
  all)
    for t in "${TARGETS[@]}"; do run "$t" "${2:-300}"; done ;;
  run)
    run "${2:?target}" "${3:-600}" ;;
  *) echo "usage: scripts/fuzz.sh smoke|all [SECONDS] | run TARGET [SECONDS]" >&2; exit 2 ;;
esac
