"""`pushgrasp calibrate --sim` with the board out of the camera's view in every pose (placed HIDDEN_AT, below the
table, wherever the tool is): run as a script by probe_calibration with the calibrate command's arguments; the
exit status is calibrate's. The hook replaces pg_sim.world.calibration_board.SimBoard.follow in this process only."""

from __future__ import annotations

import sys
from typing import Any

HIDDEN_AT = (0.0, 0.0, -1.0)  # world, m: under the table top, out of the camera's view


def hide_board() -> None:
    import pybullet as p

    from pg_sim.world import calibration_board

    def follow(self: Any) -> Any:
        pose = self.pose()
        p.resetBasePositionAndOrientation(self.body, list(HIDDEN_AT), [0.0, 0.0, 0.0, 1.0],
                                          physicsClientId=self.client_)
        return pose

    calibration_board.SimBoard.follow = follow  # type: ignore[method-assign]


def main(argv: list[str]) -> int:
    from pg_learning.cli import calibrate

    hide_board()
    return calibrate.main(argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
