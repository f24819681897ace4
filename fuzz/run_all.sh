#!/usr/bin/env bash
# Runs fuzz targets one after another, each until 10 million executions or one hour (whichever
# comes first), keeping each target's growing corpus in $FUZZ_WORK/<target> beside the committed
# seeds, and its final statistics in $FUZZ_WORK/<target>.log. docs/fuzzing.md.
#   FUZZ_WORK=/tmp/terzaghi-fuzz fuzz/run_all.sh [TARGET...]   (from the repository's top)
set -u
cd "$(dirname "$0")"
work=${FUZZ_WORK:-/tmp/terzaghi-fuzz}
runs=${FUZZ_RUNS:-10000000}
seconds=${FUZZ_SECONDS:-3600}
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(node_wire params csv_log plate_test intrusion_test medium_file mcap steady_runs mesh_file batch_legs)
for t in "${targets[@]}"; do
  mkdir -p "$work/$t"
  start=$(date +%s)
  cargo +nightly fuzz run --sanitizer none "$t" "$work/$t" "corpus/$t" -- \
    -runs="$runs" -max_total_time="$seconds" -max_len=32768 -timeout=10 -rss_limit_mb=4096 \
    -print_final_stats=1 > "$work/$t.log" 2>&1
  rc=$?
  echo "$t rc=$rc seconds=$(( $(date +%s) - start ))" >> "$work/summary"
done
