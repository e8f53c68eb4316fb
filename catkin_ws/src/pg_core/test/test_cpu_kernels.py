"""pg_core.cpu_kernels: the kernel pin is set where the pinned kernels run, keeps what the user set, and reaches
numpy and OpenBLAS in a fresh interpreter."""

import json
import os
import platform
import subprocess
import sys

from pg_core.cpu_kernels import (
    NUMPY_AVX512,
    ONEDNN_ISA,
    OPENBLAS_CORE,
    OPT_OUT,
    cpu_flags,
    kernels_in_effect,
    pin_cpu_kernels,
    pinned_variables,
)

AVX2 = {"sse3", "avx", "avx2", "fma", "avx512f"}


def test_the_pin_needs_an_x86_64_cpu_with_avx2_and_fma():
    assert pinned_variables(AVX2, "x86_64") == {"OPENBLAS_CORETYPE": OPENBLAS_CORE,
                                                "NPY_DISABLE_CPU_FEATURES": " ".join(NUMPY_AVX512),
                                                "ONEDNN_MAX_CPU_ISA": ONEDNN_ISA}
    assert pinned_variables(AVX2, "AMD64")
    assert pinned_variables(AVX2 - {"fma"}, "x86_64") == {}  # the Haswell kernels would not run
    assert pinned_variables(AVX2, "aarch64") == {}


def test_the_kernels_in_effect_are_named_pinned_or_native():
    env: dict[str, str] = {}
    assert kernels_in_effect(env, flags=AVX2, machine="x86_64") == "native"
    pin_cpu_kernels(env, flags=AVX2, machine="x86_64")
    assert kernels_in_effect(env, flags=AVX2, machine="x86_64") == "pinned"
    assert kernels_in_effect({**env, OPT_OUT: "1"}, flags=AVX2, machine="x86_64") == "native"
    mine = {**env, "OPENBLAS_CORETYPE": "SkylakeX"}
    assert kernels_in_effect(mine, flags=AVX2, machine="x86_64") == "native (OPENBLAS_CORETYPE=SkylakeX)"
    assert kernels_in_effect({}, flags={"sse3"}, machine="x86_64") == "pinned"  # nothing to pin on this CPU


def test_a_variable_the_user_set_is_kept_and_the_opt_out_sets_nothing():
    env = {"OPENBLAS_CORETYPE": "SkylakeX"}
    added = pin_cpu_kernels(env, flags=AVX2, machine="x86_64")
    assert env["OPENBLAS_CORETYPE"] == "SkylakeX" and set(added) == {"NPY_DISABLE_CPU_FEATURES", "ONEDNN_MAX_CPU_ISA"}
    assert pin_cpu_kernels(env, flags=AVX2, machine="x86_64") == {}  # a second call changes nothing
    off = {OPT_OUT: "1"}
    assert pin_cpu_kernels(off, flags=AVX2, machine="x86_64") == {} and off == {OPT_OUT: "1"}
    assert pin_cpu_kernels({}, flags={"sse3"}, machine="x86_64") == {}


def test_cpu_flags_reads_the_flags_line(tmp_path):
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nmodel name\t: Some CPU\nflags\t\t: fpu sse3 avx2 fma\nbugs\t\t: none\n")
    assert cpu_flags(str(info)) == {"fpu", "sse3", "avx2", "fma"}
    assert cpu_flags(str(tmp_path / "missing")) == set()


PROBE = """
import ctypes, json, sys
from pg_core.cpu_kernels import pin_cpu_kernels
added = pin_cpu_kernels()
import numpy
from numpy.core._multiarray_umath import __cpu_features__ as features
core = None
for line in open("/proc/self/maps"):
    if "openblas" in line.lower():
        lib = ctypes.CDLL(line.split()[-1])
        for name in ("openblas_get_corename64_", "openblas_get_corename"):
            f = getattr(lib, name, None)
            if f is not None:
                f.restype = ctypes.c_char_p
                core = f().decode()
                break
        break
print(json.dumps({"added": added, "avx512f": features["AVX512F"], "core": core}))
"""


def test_in_a_fresh_interpreter_the_pin_reaches_numpy_and_openblas():
    env = {k: v for k, v in os.environ.items() if k not in (*pinned_variables(AVX2, "x86_64"), OPT_OUT)}
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=120,
                         check=True)
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    if pinned_variables(cpu_flags(), platform.machine()):
        assert seen["added"]["OPENBLAS_CORETYPE"] == OPENBLAS_CORE
        assert seen["avx512f"] is False  # numpy's AVX-512 loops are off even where the CPU has them
        assert seen["core"] == OPENBLAS_CORE
    else:  # a CPU the pinned kernels do not run on: nothing is set, each library keeps its own choice
        assert seen["added"] == {}
