#!/usr/bin/env bash
# The Slurm test of the batch runner (docs/slurm.md): starts a single-node
# cluster on this machine (tools/slurm_cluster.sh: munged, slurmctld and slurmd on localhost with
# a generated slurm.conf, all state in a temporary folder), runs a small suite as a job array of
# 3 tasks and the merge job (`graybox bench SUITE --slurm --shards 3`), waits for them, and checks
# that the merged records equal a local run's (all fields but the times). Stops the cluster
# afterwards. Skipped, with the reason, only where the daemons cannot start.
#   bash tools/slurm_test.sh [BUILD_DIR]        (default build/)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
graybox="$build/apps/graybox"
[ -x "$graybox" ] || { echo "slurm test: no $graybox (build first)"; exit 1; }
if [ ! -f "$root/../shared/data/emps/DATA_EMPS.mat" ]; then
  echo "slurm test: SKIPPED: no EMPS data at ../shared/data/emps"
  exit 0
fi
# Short: munge's and slurmd's sockets live in it (at most 108 bytes per socket path).
state=$(mktemp -d /tmp/gb-slurm.XXXXXX)
if ! reason=$(bash "$root/tools/slurm_cluster.sh" start "$state" 2>&1 >/dev/null); then
  echo "slurm test: SKIPPED: the Slurm daemons cannot start here: ${reason##*slurm_cluster: }"
  rm -rf "$state"
  exit 0
fi
cleanup() {
  bash "$root/tools/slurm_cluster.sh" stop "$state" >/dev/null 2>&1 || true
  rm -rf "$state"
}
trap cleanup EXIT
export SLURM_CONF="$state/slurm.conf"

# Four IDIM-LS cases from perturbed starts (a fraction of a second each), in 3 array tasks.
cat >"$state/small.toml" <<TOML
[suite]
name = "slurm_test"
problems = ["$root/problems/emps/emps_idim.toml"]
time_limit = 120
[perturbation]
relative = 0.2
seeds = [1, 2, 3, 4]
TOML
"$graybox" bench "$state/small.toml" --jobs 2 --out "$state/local" >"$state/local.log" 2>&1 ||
  { cat "$state/local.log"; echo "slurm test: the local run failed"; exit 1; }
start=$SECONDS
"$graybox" bench "$state/small.toml" --slurm --shards 3 --out "$state/run" >"$state/submit.log" 2>&1 ||
  { cat "$state/submit.log"; echo "slurm test: submission failed"; exit 1; }
array=$(sed -n 's/^array_job \([0-9]*\)$/\1/p' "$state/submit.log")
merge=$(sed -n 's/^merge_job \([0-9]*\)$/\1/p' "$state/submit.log")
[ -n "$array" ] && [ -n "$merge" ] ||
  { cat "$state/submit.log"; echo "slurm test: no job ids in the output"; exit 1; }
deadline=$((SECONDS + 120))
while [ -n "$(squeue -h -j "$array,$merge" -o %i 2>/dev/null)" ]; do
  if [ $SECONDS -ge $deadline ]; then
    squeue
    echo "slurm test: the jobs are still queued after 120 s"
    exit 1
  fi
  sleep 0.5
done
failed=0
for job in "$array" "$merge"; do
  # The array's tasks are listed one per line; every task and the merge must have completed (and
  # a job scontrol cannot show counts as failed).
  states=$(scontrol show job "$job" 2>/dev/null | grep -o 'JobState=[A-Z_]*' || true)
  if [ -z "$states" ] || grep -qv 'JobState=COMPLETED' <<<"$states"; then
    failed=1
  fi
done
tasks=$(ls "$state/run/slurm/" | grep -c "^${array}_[0-9]*\.log$" || true)
if [ "$failed" -ne 0 ] || [ "$tasks" -ne 3 ]; then
  scontrol show job "$array" "$merge" || true
  tail -n 20 "$state"/run/slurm/*.log "$state"/log/*.log || true
  echo "slurm test: a job did not complete (task logs: $tasks of 3)"
  exit 1
fi
records='[.cases[] | del(.seconds, .case_seconds)]'
if ! diff <(jq -S "$records" "$state/local/bench.json") \
  <(jq -S "$records" "$state/run/merged/bench.json") >"$state/diff.txt"; then
  head -n 40 "$state/diff.txt"
  echo "slurm test: the merged records differ from the local run's"
  exit 1
fi
cases=$(jq '.cases | length' "$state/run/merged/bench.json")
echo "slurm test: passed: $cases cases in 3 array tasks and the merge job (jobs $array, $merge)" \
  "in $((SECONDS - start)) s; the merged records equal the local run's"
