"""A robot install without the simulator, for tests/test_runtime_without_sim.py: with this folder first on PYTHONPATH,
every Python process started (roslaunch, the nodes, the test node, the `python3 -m ...` commands of the launch files)
loads this file at start-up, and importing pybullet, pybullet_data, pg_sim or pg_learning in it raises
ModuleNotFoundError, as where those packages are not installed.

When $PG_WITHOUT_SIM_LOG names a file, each process appends a line "<pid> loaded <command line>" on start-up and a line
"<pid> blocked <module> <command line>" for every import it attempted of a blocked module, so that the test can tell
which processes ran without the simulator and whether any of them reached for it.
"""

from __future__ import annotations

import os
import sys

BLOCKED = ("pybullet", "pybullet_data", "pg_sim", "pg_learning")


def _command_line() -> str:
    try:
        with open("/proc/self/cmdline", "rb") as f:
            text = f.read().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        text = " ".join(sys.argv)
    return text.replace("\n", "\\n")  # one line per event


def _log(event: str) -> None:
    path = os.environ.get("PG_WITHOUT_SIM_LOG")
    if path:
        with open(path, "a", encoding="utf-8") as f:
            f.write(f"{os.getpid()} {event} {_command_line()}\n")


class SimulatorBlocker:
    """A sys.meta_path finder, first in line: the blocked top-level packages and their modules are not found."""

    def find_spec(self, fullname: str, path: object = None, target: object = None) -> None:
        if fullname.partition(".")[0] in BLOCKED:
            _log(f"blocked {fullname}")
            raise ModuleNotFoundError(f"No module named {fullname!r} (a robot install without the simulator)",
                                      name=fullname)
        return None


sys.meta_path.insert(0, SimulatorBlocker())
_log("loaded")
