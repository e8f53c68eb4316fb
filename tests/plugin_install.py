"""Helpers of the plug-in tests: pip and the pushgrasp CLI of this interpreter's environment.

Every call has a timeout (PIP_TIMEOUT_S); nothing is downloaded (the tests install their examples with --no-index).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

PIP_TIMEOUT_S = 300


def pip(*args: str) -> subprocess.CompletedProcess[str]:
    """`python -m pip ARGS` of this interpreter, output captured; subprocess.TimeoutExpired after PIP_TIMEOUT_S."""
    return subprocess.run([sys.executable, "-m", "pip", "--disable-pip-version-check", "--no-input", *args],
                          capture_output=True, text=True, timeout=PIP_TIMEOUT_S)


def installed(dist: str) -> bool:
    """Whether distribution ``dist`` is installed in this interpreter's environment."""
    return pip("show", "-q", dist).returncode == 0


def pushgrasp(*args: str) -> list[str]:
    """The command line of the pushgrasp CLI of this interpreter's environment."""
    script = Path(sys.executable).with_name("pushgrasp")
    return [str(script), *args] if script.is_file() else [sys.executable, "-m", "pg_policy.cli.main", *args]
