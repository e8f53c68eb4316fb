#!/usr/bin/env bash
# The paper-size `densenet121` variant trained and evaluated on a lent GPU machine (docs/RESULTS.md, "The paper-size
# network"), in one unattended run that fits one lease:
#   1. PyBullet for this machine's Python, built from its sdist (SDIST: pybullet-3.2.7 as .tar.gz or .tar.xz) when
#      `import pybullet` fails: the GPU image's Python is 3.12, PyPI has no pybullet 3.2.7 wheel for it, and nothing
#      can be fetched there. The simulator runs on the CPU cores, the nets on the GPU.
#   2. Offline warm start of both nets on recorded experience (EXP: `pushgrasp offline pack`), PG_OFFLINE_MIN minutes.
#   3. The self-supervised alternate stage in the simulator from that warm start (the recipe of the shipped `lite`
#      model's last stage), PG_TRAIN_MIN minutes, alone on the machine (an evaluation beside it, 10 workers, cut
#      it to 3.4 s per iteration on the H100 machine).
#   4. Export (threshold 0.7, push budget 3, min3 filter, as `lite`) and the evaluation protocol
#      (scripts/eval_protocol.sh, PG_EVAL_TRIALS trials per scene, PG_WORKERS workers), then the same for the
#      warm start when PG_EVAL_WARM=1.
# Everything lands in OUT: offline/, alternate/ (log.csv, curves.png), models_*/ (not to be committed: 2 x 57 MB),
# eval_final/ and eval_warm/ (results per family, each written when its family ends), steps.log (one line per step
# with its wall time).
# To carry the sdist to the lent machine (80 MB as published), drop the meshes the project does not use:
#   pip download --no-deps --no-binary=:all: pybullet==3.2.7; tar xzf pybullet-3.2.7.tar.gz
#   find pybullet-3.2.7/examples/pybullet/gym/pybullet_data -type f ! -name "*.py" -delete
#   rm -rf pybullet-3.2.7/examples/pybullet/gym/pybullet_{envs,examples}; tar cJf SDIST pybullet-3.2.7  # 3.4 MB
# usage: scripts/gpu_densenet121.sh SDIST EXP OUT
# env: PG_PYTHON (default python3), PG_BACKBONE (default densenet121), PG_DEVICE (default cuda),
#      PG_OFFLINE_MIN (4), PG_TRAIN_MIN (8), PG_EVAL_TRIALS (30), PG_WORKERS (8), PG_EVAL_WARM (0),
#      PG_DEADLINE_S (0 = none: else training is cut so that the run may end this many seconds after it started,
#      PG_EVAL_RESERVE_S (480) being left for the final evaluation)
set -euo pipefail
if [ $# -ne 3 ]; then
  echo "usage: $0 SDIST EXP OUT" >&2
  exit 2
fi
repo=$(cd "$(dirname "$0")/.." && pwd)
sdist=$(realpath "$1")
exp=$(realpath "$2")
out=$3
py=${PG_PYTHON:-python3}
backbone=${PG_BACKBONE:-densenet121}
device=${PG_DEVICE:-cuda}
workers=${PG_WORKERS:-8}
offline_min=${PG_OFFLINE_MIN:-4}
train_min=${PG_TRAIN_MIN:-8}
export PG_EVAL_TRIALS=${PG_EVAL_TRIALS:-30}
export PG_PYTHON=$py PYTHONUNBUFFERED=1
export PYTHONPATH="$repo/catkin_ws/src/pg_policy/src:$repo/catkin_ws/src/pg_sim/src${PYTHONPATH:+:$PYTHONPATH}"
mkdir -p "$out"
out=$(realpath "$out")
t0=$(date +%s)
step() { echo "[gpu] $(($(date +%s) - t0)) s: $*" | tee -a "$out/steps.log"; }
pg() { "$py" -m pg_policy.cli.main "$@"; }

if ! "$py" -c "import pybullet" 2>/dev/null; then
  step "building pybullet from $sdist"
  build=$(mktemp -d)
  tar xf "$sdist" -C "$build"
  # gcc >= 14 makes pybullet.c's numpy pointer casts errors; they are warnings in the gcc it was written for
  (cd "$build"/pybullet-* && CFLAGS="-Wno-error=incompatible-pointer-types" \
    "$py" -m pip wheel --no-build-isolation --no-deps --no-index -w "$build/wheel" . >"$out/pybullet_build.log" 2>&1)
  "$py" -m pip install --no-deps --no-index "$build"/wheel/pybullet-*.whl >>"$out/pybullet_build.log" 2>&1
fi
step "pybullet $("$py" -c 'import pybullet, numpy; print(pybullet.__file__, "numpy", numpy.__version__)')"

if [ ! -f "$out/offline/last.pt" ]; then
  step "offline warm start: $backbone on $device, $offline_min min"
  pg offline train --data "$exp" --out "$out" --backbone "$backbone" --device "$device" --steps 100000 --batch 8 \
    --minutes "$offline_min" --seed 11 2>&1 | tr '\r' '\n' | grep -v "step, grasp=" | tail -3
fi
if [ "${PG_DEADLINE_S:-0}" -gt 0 ]; then
  left=$(( (PG_DEADLINE_S - ($(date +%s) - t0) - ${PG_EVAL_RESERVE_S:-480}) / 60 ))
  train_min=$(( left < 1 ? 1 : (left < train_min ? left : train_min) ))
fi
step "self-supervised alternate stage: $train_min min"
pg train --stage alternate --backbone "$backbone" --device "$device" --init "$out/offline/last.pt" --out "$out" \
  --scene dense-8 --iterations 5000 --minutes "$train_min" --lr 1e-4 --seed 21 --grasp-threshold 0.7 \
  --push-budget 3 --guided-exploration 0.7 --epsilon-start 0.3 --epsilon-end 0.1 --epsilon-decay 300 \
  --checkpoint-every 25 2>&1 | tr '\r' '\n' | grep -v "it/s, \|s/it, " | tail -5
pg export --run "$out" --stage alternate --out "$out/models_final" --grasp-threshold 0.7 --push-budget 3 --grasp-filter min3 --low-parts on --grasp-check jaw-walls --grasp-search on --edge-guard on --push-landing on
step "trained $(tail -n +2 "$out/alternate/log.csv" | wc -l) iterations; evaluating them ($workers workers)"
"$repo/scripts/eval_protocol.sh" "$out/models_final" "$out/eval_final" --workers "$workers" --device "$device" \
  --no-progress >"$out/eval_final.log" 2>&1
if [ "${PG_EVAL_WARM:-0}" = 1 ]; then
  pg export --run "$out" --stage offline --out "$out/models_warm" --grasp-threshold 0.7 --push-budget 3 --grasp-filter min3 --low-parts on --grasp-check jaw-walls --grasp-search on --edge-guard on --push-landing on
  step "evaluating the warm start ($workers workers)"
  "$repo/scripts/eval_protocol.sh" "$out/models_warm" "$out/eval_warm" --workers "$workers" --device "$device" \
    --no-progress >"$out/eval_warm.log" 2>&1
fi
step "done"
