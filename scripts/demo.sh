#!/usr/bin/env bash
# `make demo`: headless simulation demo (no ROS yet): a scripted ground-truth grasp of the green target.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
cd "$repo"
exec "$repo/.venv/bin/python" -m pg_sim.demo --scene household/case11 --out demo_out "$@"
