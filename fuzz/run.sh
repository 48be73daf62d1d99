#!/usr/bin/env bash
# Longer fuzzing runs with libFuzzer (nightly toolchain and `cargo install cargo-fuzz`):
#   bash fuzz/run.sh [SECONDS per target, default 60] [TARGET ...]
# Each target starts from a scratch copy of fuzz/corpus/TARGET plus fuzz/regressions/TARGET, so
# the committed corpus stays small; crashes land in fuzz/artifacts/TARGET (copy a fixed one to
# fuzz/regressions/TARGET, which the test suite replays). Prints one summary line per target.
set -u
cd "$(dirname "$0")"
secs=${1:-60}; shift || true
targets=${*:-"scene_json obj ply texture mitsuba_xml gltf pbrt scn"}
for t in $targets; do
  work=$(mktemp -d); cp corpus/$t/* "$work"/ 2>/dev/null; cp regressions/$t/* "$work"/ 2>/dev/null
  log=$(mktemp)
  cargo +nightly fuzz run "$t" "$work" -- -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 > "$log" 2>&1
  rc=$?
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$')
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1)
  crash=$(grep -c 'SUMMARY: \|panicked at' "$log")
  echo "$t: exit $rc, ${execs:-?} executions in ${secs}s, ${cov:-cov ?}, corpus $(ls "$work" | wc -l) inputs, crash reports: $crash"
  [ $rc -ne 0 ] && grep -m3 'panicked at\|SUMMARY' "$log"
  rm -rf "$work" "$log"
done
