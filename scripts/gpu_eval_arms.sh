#!/usr/bin/env bash
# Paired arms of `pushgrasp eval` (the same seeds, other policy options) on a many-core machine without Ray, such as
# a lent GPU machine (docs/RESULTS.md, "The grasp check on household objects"): every (arm, family, seed slice) is
# one `pushgrasp eval --workers 1` process, nets on DEVICE, all stopped DEADLINE_S seconds after the start; the
# slices are then merged into one output folder per arm and family (OUT/merged/ARM/FAMILY/trials.jsonl), which
# `pushgrasp compare ARM=OUT/merged/ARM ...` reads. Trials a stopped slice did not finish are left out; pairing
# counts the common ones.
#   1. PyBullet: `import pybullet` must work, else it is built from PG_PYBULLET_SDIST (the stripped sdist of
#      scripts/gpu_densenet121.sh) into /tmp/site; trimesh and manifold3d come from PG_WHEELS (a folder of wheels
#      for that machine's Python) when missing.
#   2. The repo's packages are found through PYTHONPATH and PG_CATKIN_SRC (no install, no catkin).
# usage: scripts/gpu_eval_arms.sh OUT DEADLINE_S TRIALS SEED FAMILY... -- ARM=ARGS...
#   e.g. scripts/gpu_eval_arms.sh /tmp/arms 540 100 5000 train-household-10 -- walls= strict="--grasp-check jaw-strict"
# env: PG_PYTHON (python3), PG_DEVICE (cuda), PG_SLICES (cores / (arms x families)), PG_PYBULLET_SDIST, PG_WHEELS
set -u
if [ $# -lt 6 ]; then
  sed -n 2,14p "$0" >&2
  exit 2
fi
T0=$(date +%s)
out=$1 deadline=$2 trials=$3 seed0=$4; shift 4
fams=(); while [ $# -gt 0 ] && [ "$1" != "--" ]; do fams+=("$1"); shift; done
[ $# -gt 1 ] || { echo "gpu_eval_arms: give the arms after --, e.g. -- base= strict=\"--grasp-check jaw-strict\"" >&2; exit 2; }
shift
repo=$(cd "$(dirname "$0")/.." && pwd) py=${PG_PYTHON:-python3} device=${PG_DEVICE:-cuda}
export PYTHONUNBUFFERED=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
export PG_CATKIN_SRC=$repo/catkin_ws/src PYTHONPATH=/tmp/site${PYTHONPATH:+:$PYTHONPATH}
for p in pg_core pg_policy pg_sim pg_learning pg_conversions; do PYTHONPATH=$PYTHONPATH:$repo/catkin_ws/src/$p/src; done
mkdir -p "$out/slices" "$out/merged"
log() { echo "[arms] $(( $(date +%s) - T0 )) s: $*" | tee -a "$out/steps.log"; }
if ! $py -c "import trimesh, manifold3d" 2>/dev/null; then
  $py -m pip install -q --no-index --no-deps --target /tmp/site "${PG_WHEELS:?trimesh/manifold3d missing: set PG_WHEELS}"/*.whl || exit 3
fi
if ! $py -c "import pybullet" 2>/dev/null; then
  log "building pybullet from ${PG_PYBULLET_SDIST:?pybullet missing: set PG_PYBULLET_SDIST}"
  build=$(mktemp -d) && tar xf "$PG_PYBULLET_SDIST" -C "$build" || exit 3
  (cd "$build"/pybullet-* && CFLAGS="-Wno-error=incompatible-pointer-types" \
    $py -m pip wheel --no-build-isolation --no-deps --no-index -w "$build/wheel" . >"$out/pybullet_build.log" 2>&1) || exit 3
  $py -m pip install -q --no-deps --no-index --target /tmp/site "$build"/wheel/pybullet-*.whl || exit 3
fi
cpus=$($py -c "import os; print(os.cpu_count())")  # nproc can say 1 inside a sandbox
slices=${PG_SLICES:-$(( cpus / ($# * ${#fams[@]}) ))}; [ "$slices" -lt 1 ] && slices=1
per=$(( (trials + slices - 1) / slices ))
for spec in "$@"; do
  arm=${spec%%=*} args=${spec#*=}
  for fam in "${fams[@]}"; do
    for ((s = 0; s < slices; s++)); do
      start=$(( s * per )); n=$(( trials - start < per ? trials - start : per )); [ $n -le 0 ] && continue
      # shellcheck disable=SC2086
      timeout $(( deadline - ($(date +%s) - T0) )) $py -m pg_policy.cli.main eval --policy lite --scenes "$fam" \
        --trials $n --seed $(( seed0 + start )) --allow-train-seeds --workers 1 --device "$device" --no-progress \
        $args --out "$out/slices/$arm/$fam-$s" >"$out/slices/$arm-$fam-$s.log" 2>&1 &
    done
  done
done
log "$(jobs -r | wc -l) processes on $cpus cores: $slices slices of $per trials per arm and family"
wait
$py - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
for arm in sorted((out / "slices").iterdir()):
    if not arm.is_dir():
        continue
    fams = {}
    for part in sorted(arm.iterdir()):
        journal = part / "trials.jsonl"
        if journal.is_file():
            lines = journal.read_text().splitlines()
            head, trials = fams.setdefault(part.name.rsplit("-", 1)[0], ([], []))
            head[:] = head or [ln for ln in lines if '"run"' in ln[:8]]
            trials += [ln for ln in lines if '"trial"' in ln[:10]]
    for fam, (head, trials) in fams.items():
        folder = out / "merged" / arm.name / fam
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "trials.jsonl").write_text("\n".join(head + trials) + "\n")
        print(f"{arm.name} {fam}: {len(trials)} trials")
PY
log "done: pushgrasp compare ARM=$out/merged/ARM ..."
