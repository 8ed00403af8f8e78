#!/usr/bin/env bash
# Runs the coverage-guided fuzz targets (cargo-fuzz, libFuzzer; needs nightly and
# `cargo install cargo-fuzz`), one after the other, each for RUNS inputs (default 1,000,000),
# with a 1 s limit per input and a 2 GiB cap on RSS and on any single allocation. The corpus
# grows under fuzz/corpus/<target> (not committed), starting from the committed seeds
# fuzz/seeds/<target>; crashes land in fuzz/artifacts/<target>. One summary line per target.
#
#   bash scripts/fuzz.sh                      # every target, 1,000,000 inputs each
#   RUNS=50000 bash scripts/fuzz.sh idnp_scene scenario_toml
#   FUZZ_TARGET_DIR=/tmp/fuzz-target bash scripts/fuzz.sh   # build outside fuzz/target
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS="${RUNS:-1000000}"
# Optional wall-clock cap per target (seconds); 0: none.
MAX_TIME="${MAX_TIME:-0}"
TARGETS=("$@")
if [ ${#TARGETS[@]} -eq 0 ]; then
    mapfile -t TARGETS < <(ls fuzz/fuzz_targets | sed 's/\.rs$//')
fi
mkdir -p fuzz/logs
for t in "${TARGETS[@]}"; do
    mkdir -p "fuzz/corpus/$t"
    log="fuzz/logs/$t.log"
    # -a: debug assertions (integer overflow checks) in the fuzzed code.
    if cargo +nightly fuzz run -a ${FUZZ_TARGET_DIR:+--target-dir "$FUZZ_TARGET_DIR"} "$t" "fuzz/corpus/$t" "fuzz/seeds/$t" -- \
        -runs="$RUNS" -max_total_time="$MAX_TIME" -timeout=1 -rss_limit_mb=2048 -malloc_limit_mb=2048 -max_len=65536 \
        -print_final_stats=1 > "$log" 2>&1; then
        status=clean
    else
        status="FAILED (see $log and fuzz/artifacts/$t)"
    fi
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | awk '{print $2}' | tail -1)
    rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | awk '{print $2}' | tail -1)
    secs=$(grep -o 'Done [0-9]* runs in [0-9]* second' "$log" | awk '{print $5}' | tail -1)
    echo "$t: ${runs:-?} inputs, ${rate:-?} inputs/s, ${secs:-?} s, $status"
done
