#!/usr/bin/env bash
# The table of docs/benchmarks.md's fuzzing section, from the logs fuzz/run_all.sh left in
# $FUZZ_WORK (default /tmp/terzaghi-fuzz): per target, its last run's executions, time, speed,
# the corpus it grew and whether it ended on a crash.
set -u
work=${FUZZ_WORK:-/tmp/terzaghi-fuzz}
echo "| target | executions | time (s) | executions/s | corpus (inputs) | ended | earlier runs, each ended by a finding since fixed (s) |"
echo "|---|---:|---:|---:|---:|---|---|"
for log in "$work"/*.log; do
  t=$(basename "$log" .log)
  stat() { grep -E "^stat::$1:" "$log" | awk '{print $2}'; }
  n=$(stat number_of_executed_units)
  rate=$(stat average_exec_per_sec)
  secs=$(grep -oE "^Done [0-9]+ runs in [0-9]+ second" "$log" | awk '{print $5}')
  corpus=$(find "$work/$t" -type f | wc -l)
  if grep -q "Test unit written" "$log"; then ended="crash"; else ended="no crash"; fi
  # Earlier runs of the target that a finding ended (not the last run, whose log this is;
  # shorter clean runs before it are left out).
  earlier=$(grep -E "^$t rc=" "$work/summary" | head -n -1 | grep -v " rc=0 " | sed 's/.*seconds=//' | paste -sd, - | sed 's/,/, /g')
  echo "| \`$t\` | ${n:-?} | ${secs:-?} | ${rate:-?} | $corpus | $ended | ${earlier:--} |"
done
