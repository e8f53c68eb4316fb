"""Calibration with the board out of view: `pushgrasp calibrate --sim --poses N --out FILE` (pg_learning.cli
.calibrate; solver pg_policy.perception.hand_eye) with the board hidden below the table in every pose
(hidden_board). No ROS stack.

Invariants: exit status 1 within --render-bound s, the error names how many poses showed the board ("in 0 of N
poses"), no traceback, no calibration file written. (Too few poses with the board in view: pg_sim/test/
test_calibration_sim.py, test_too_few_poses_write_nothing_and_say_how_many.)"""

from __future__ import annotations

import subprocess
import sys
import time

from .report import ProbeResult
from .runner import REPO, Context

TITLE = "Calibration, board out of view"
POSES = 12


def run(ctx: Context, res: ProbeResult) -> None:
    out = ctx.workdir / "calibration" / "camera_calibration.yaml"
    out.parent.mkdir(parents=True, exist_ok=True)
    args = [sys.executable, "-m", "reliability.hidden_board", "--sim", "--poses", str(POSES), "--out", str(out)]
    env = ctx.stack.env()
    env["PYTHONPATH"] = f"{REPO / 'tests'}:{env.get('PYTHONPATH', '')}"
    t0 = time.monotonic()
    try:
        proc = subprocess.run(args, cwd=REPO, env=env, capture_output=True, text=True, timeout=ctx.opts.render_bound)
        code, output = proc.returncode, proc.stdout + proc.stderr
    except subprocess.TimeoutExpired as exc:
        code, output = None, str(exc.stderr or "")
    seconds = time.monotonic() - t0
    reason = next((line.strip() for line in output.splitlines() if line.startswith("pushgrasp calibrate:")), "")
    res.figures.update({"exit status": "timed out" if code is None else code, "wall s": round(seconds, 1),
                        "message": reason[:200]})
    seen = f"in 0 of {POSES} poses"
    why = [w for w, bad in (("did not exit in time", code is None), (f"exit status {code}", code not in (None, 1)),
                            (f"the message does not say '{seen}'", seen not in reason),
                            ("traceback in the output", "Traceback" in output),
                            ("a calibration file was written", out.exists())) if bad]
    detail = f"{'; '.join(why)}; output: {output.strip()[-300:]}" if why else reason[:200]
    res.check("refused with the number of poses that showed the board, nothing written", not why, detail)
