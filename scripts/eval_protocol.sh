#!/usr/bin/env bash
# DESIGN.md section 8 for one policy, as docs/RESULTS.md reports it: packed case 1-9, household case 11-14 and
# random 10/15/20, PG_EVAL_TRIALS (default 30) trials per scene from seed PG_EVAL_SEED (default 1,000,000; training
# seeds are below it). One `pushgrasp eval` per family (OUT/packed, OUT/household, OUT/random): a family whose
# results.json exists is skipped, so an interrupted run resumes at the family it was in.
# usage: scripts/eval_protocol.sh POLICY OUT [more `pushgrasp eval` arguments, e.g. --workers 2 --model DIR]
# PG_PYTHON: the Python to run it with (default: the project venv's)
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 POLICY OUT [pushgrasp eval arguments]" >&2
  exit 2
fi
repo=$(cd "$(dirname "$0")/.." && pwd)
policy=$1
out=$2
shift 2
trials="${PG_EVAL_TRIALS:-30}"
seed="${PG_EVAL_SEED:-1000000}"
declare -A FAMILIES=([packed]="packed" [household]="household" [random]="random-10 random-15 random-20")
for family in packed household random; do
  if [ -f "$out/$family/results.json" ]; then
    echo "[eval] $family: $out/$family/results.json exists, skipped"
    continue
  fi
  echo "[eval] $policy on $family: $trials trials per scene from seed $seed"
  # shellcheck disable=SC2086
  "${PG_PYTHON:-$repo/.venv/bin/python}" -m pg_policy.cli.main eval --policy "$policy" --scenes ${FAMILIES[$family]} \
    --trials "$trials" --seed "$seed" --out "$out/$family" "$@"
done
