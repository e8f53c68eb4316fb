"""One set of CPU kernels on every x86-64 machine, so that a seed plays the same trial on any of them.

numpy and the OpenBLAS it bundles choose their SIMD kernels when they load, by the CPU they find (AVX-512 on one
machine, AVX2 on another). The kernels round differently in the last bit, and a simulated push or grasp turns such a
difference into another scene within one action: on one machine, household-10 trials run with OpenBLAS's Haswell
kernels, or with numpy's AVX-512 loops switched off, part from the default run at their first or second action
(docs/RESULTS.md, "One set of CPU kernels"). `pin_cpu_kernels` fixes the choice through the environment variables
the libraries read when they load, on any x86-64 CPU with AVX2 and FMA (Intel since 2013, AMD since 2015):
OPENBLAS_CORETYPE=Haswell (AVX2 and FMA; left to itself, the OpenBLAS numpy 1.26 bundles falls back to its
SSE3 kernels on a CPU it does not know, a Sapphire Rapids Xeon among them), NPY_DISABLE_CPU_FEATURES listing
numpy's AVX-512 dispatch targets, and ONEDNN_MAX_CPU_ISA=AVX2 for torch's convolutions (their AVX-512 kernels move
Q values in the sixth decimal). Elsewhere it changes nothing: the native kernels run, and trials may differ from
other machines'.

The entry points call it before anything imports numpy: the `pushgrasp` CLI, the ROS nodes and the test suite's
conftest; so do the packages that play trials, pg_sim and pg_learning, when they are imported (their `python -m`
tools then run pinned; a program that imported numpy before them keeps its native kernels). A variable the user
has set is kept; PG_NATIVE_KERNELS=1 turns the pin off (each library's own choice). `kernels_in_effect` names
the choice a process runs with ("pinned" or "native ..."), which `pushgrasp eval` records in results.json so that
`pushgrasp compare` can say when it pairs runs of different kernels.
Importing this module imports neither numpy nor torch.
"""

from __future__ import annotations

import os
import platform
import sys
from collections.abc import Mapping, MutableMapping, Set
from functools import lru_cache

OPENBLAS_CORE = "Haswell"  # OpenBLAS's AVX2 + FMA kernels, which every CPU pinned here runs
NUMPY_AVX512 = ("AVX512F", "AVX512CD", "AVX512_KNL", "AVX512_KNM", "AVX512_SKX", "AVX512_CLX", "AVX512_CNL",
                "AVX512_ICL")  # numpy 1.26's AVX-512 dispatch targets (numpy.core._multiarray_umath.__cpu_dispatch__)
ONEDNN_ISA = "AVX2"  # the highest instruction set torch's oneDNN convolutions may use
NEEDED_FLAGS = ("avx2", "fma")  # /proc/cpuinfo flags the pinned kernels need
PIN_VARIABLES = ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES", "ONEDNN_MAX_CPU_ISA")  # what the pin sets
OPT_OUT = "PG_NATIVE_KERNELS"  # set to 1: leave the libraries' own kernel choice


@lru_cache(maxsize=4)
def cpu_flags(path: str = "/proc/cpuinfo") -> frozenset[str]:
    """The CPU's feature flags as Linux lists them (lower case); empty where the file is missing or unreadable. Read
    once per process and path (the CLI, pg_sim and pg_learning each pin at start-up)."""
    try:
        with open(path, encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    return frozenset(line.split(":", 1)[1].split())
    except OSError:
        pass
    return frozenset()


def pinned_variables(flags: Set[str], machine: str) -> dict[str, str]:
    """The environment variables that pin the kernels on a CPU with `flags` and architecture `machine`
    (platform.machine()); empty where the pinned kernels would not run (not x86-64, or no AVX2 and FMA)."""
    if machine.lower() not in ("x86_64", "amd64") or not all(f in flags for f in NEEDED_FLAGS):
        return {}
    return dict(zip(PIN_VARIABLES, (OPENBLAS_CORE, " ".join(NUMPY_AVX512), ONEDNN_ISA), strict=True))


def pin_cpu_kernels(environ: MutableMapping[str, str] | None = None, flags: Set[str] | None = None,
                    machine: str | None = None, warn: bool = True) -> dict[str, str]:
    """Set the pinning variables in `environ` (os.environ) that are not set already; returns those set. Nothing
    is set with PG_NATIVE_KERNELS=1 or on a CPU the pinned kernels do not run on. Call it before numpy loads: once
    numpy is imported the variables no longer act on this process (its children still read them), and with
    `warn` a RuntimeWarning says so."""
    env = os.environ if environ is None else environ
    if env.get(OPT_OUT, "") == "1":
        return {}
    wanted = pinned_variables(cpu_flags() if flags is None else flags, platform.machine() if machine is None
                              else machine)
    added = {k: v for k, v in wanted.items() if k not in env}
    env.update(added)
    if warn and added and environ is None and "numpy" in sys.modules:
        import warnings

        warnings.warn("pg_core.cpu_kernels.pin_cpu_kernels called after numpy was imported: this process keeps "
                      "its native kernels", RuntimeWarning, stacklevel=2)
    return added


def kernels_in_effect(environ: Mapping[str, str] | None = None, flags: Set[str] | None = None,
                      machine: str | None = None) -> str:
    """"pinned" when `environ` (os.environ) holds every variable `pin_cpu_kernels` sets on this CPU, with its pinned
    value (also where the CPU has none to pin); else "native", followed in parentheses by the pinning variables set
    to other values (a user's choice, e.g. "native (OPENBLAS_CORETYPE=SkylakeX)")."""
    env = os.environ if environ is None else environ
    wanted = pinned_variables(cpu_flags() if flags is None else flags, platform.machine() if machine is None
                              else machine)
    if env.get(OPT_OUT, "") != "1" and all(env.get(k) == v for k, v in wanted.items()):
        return "pinned"
    other = [f"{k}={env[k]}" for k in PIN_VARIABLES if k in env and env[k] != wanted.get(k)]
    return "native" + (f" ({', '.join(other)})" if other else "")
