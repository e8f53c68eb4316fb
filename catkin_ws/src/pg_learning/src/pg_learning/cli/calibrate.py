"""`pushgrasp calibrate`: the camera's hand-eye calibration board, and the calibration run in simulation.

- `pushgrasp calibrate board --out board.png [--dpi 300]`: the ChArUco board to print (pg_policy.perception.charuco;
  `python -m pg_policy.perception.charuco` does the same where pg_learning is not installed).
- `pushgrasp calibrate --sim [--pose-error-mm 20 --pose-error-deg 2 --seed S --poses 12 --sensor NAME]
  [--out camera_calibration.yaml]`: a simulated cell whose camera renders from its configured pose times a pose
  error (pg_sim.world.sensor_model) of the given size in a random direction of the seed; the board
  (pg_sim.world.calibration_board) on the left arm's tool visits the poses, the camera sees it, and
  pg_policy.perception.hand_eye solves the camera pose in `world` and the depth scale and offset against the table.
  Prints the residuals and the error against the true (perturbed) pose; writes the YAML with --out.
The real cell calibrates with `roslaunch launch/calibrate.launch` (pg_policy.ros.hand_eye_node).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from pg_learning.environment.sim_calibration import SimCalibration

DESCRIPTION = "The camera's hand-eye calibration board; the calibration in simulation (--sim)."


def _arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("what", nargs="?", choices=("board",), help="board: write the board's PNG to --out")
    parser.add_argument("--sim", action="store_true", help="calibrate the simulated camera")
    parser.add_argument("--out", default=None,
                        help="board: the PNG (default board.png); --sim: the calibration YAML (default: none)")
    parser.add_argument("--dpi", type=float, default=300.0, help="board: print resolution (default 300)")
    parser.add_argument("--pose-error-mm", type=float, default=20.0, help="--sim: camera position error (mm)")
    parser.add_argument("--pose-error-deg", type=float, default=2.0, help="--sim: camera rotation error (deg)")
    parser.add_argument("--seed", type=int, default=0, help="--sim: seed of the error's direction (and noise)")
    parser.add_argument("--poses", type=int, default=12, help="--sim: board poses (default 12)")
    parser.add_argument("--sensor", default="perfect",
                        help="--sim: sensor profile for the noise (perfect, d435, d415, a YAML); the pose error "
                             "comes from --pose-error-*")
    parser.set_defaults(run=_run)


def add_parser(sub: argparse._SubParsersAction) -> None:
    _arguments(sub.add_parser("calibrate", help="the hand-eye calibration board; calibration in simulation",
                              description=DESCRIPTION))


def simulate(pose_error_mm: float = 20.0, pose_error_deg: float = 2.0, seed: int = 0, poses: int = 12,
             sensor: str = "perfect", arm: str = "left") -> SimCalibration:
    """Run the calibration in a fresh simulated world (DIRECT); raises CalibrationFailed as hand_eye.solve."""
    from pg_learning.environment.sim_calibration import calibrate_camera
    from pg_sim.world.sensor_model import load_profile
    from pg_sim.world.world import World

    profile = dataclasses.replace(load_profile(sensor), name=f"{load_profile(sensor).name}+pose",
                                  pose_translation_m=pose_error_mm * 1e-3, pose_rotation_deg=pose_error_deg)
    with World(sensor=profile, sensor_seed=seed) as world:
        return calibrate_camera(world, poses, arm)


def _run(args: argparse.Namespace) -> int:
    from pg_policy.perception.charuco import DEFAULT_BOARD, describe, write_image

    if args.what == "board":
        out = args.out or "board.png"
        w, h = write_image(out, DEFAULT_BOARD, args.dpi)
        print(f"{out}: {w} x {h} px at {args.dpi:g} dpi; {describe(DEFAULT_BOARD)}")
        return 0
    if not args.sim:
        print("pushgrasp calibrate: give `board` or --sim; a real camera calibrates with "
              "`roslaunch launch/calibrate.launch` (README, \"Calibrating the camera\")", file=sys.stderr)
        return 2
    from pg_policy.perception.hand_eye import CalibrationFailed, angle_deg, summary, write_calibration

    try:
        run = simulate(args.pose_error_mm, args.pose_error_deg, args.seed, args.poses, args.sensor)
    except CalibrationFailed as exc:
        print(f"pushgrasp calibrate: {exc}", file=sys.stderr)
        return 1
    print(summary(run.result, run.depth))  # type: ignore[arg-type]
    before_mm = 1e3 * float(np.linalg.norm(run.configured[:3, 3] - run.true_pose[:3, 3]))
    pos, rot = run.errors
    print(f"true camera: {before_mm:.2f} mm, {angle_deg(run.configured, run.true_pose):.3f} deg from the configured "
          f"pose (seed {args.seed}); calibrated: {pos:.3f} mm, {rot:.4f} deg from the true pose")
    if args.out:
        print(f"wrote {write_calibration(args.out, run.result, run.depth)}")  # type: ignore[arg-type]
    return 0


def main(argv: list[str] | None = None) -> int:
    """`python -m pg_learning.cli.calibrate ...`: the same as `pushgrasp calibrate ...`."""
    parser = argparse.ArgumentParser(prog="pushgrasp calibrate", description=DESCRIPTION)
    _arguments(parser)
    parsed = parser.parse_args(argv)
    return int(parsed.run(parsed))


if __name__ == "__main__":
    sys.exit(main())
