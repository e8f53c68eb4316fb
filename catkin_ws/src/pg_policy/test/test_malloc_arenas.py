"""pg_policy.models.inference.keep_freed_memory caps glibc's malloc arenas: a process serving the policy keeps freed
memory (no trimming), so every arena its threads touch keeps its peak; the ROS node serves each service connection on
a new thread. Eight threads allocating at once get at most MALLOC_ARENAS arenas (nine without the cap)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from pg_policy.models.inference import MALLOC_ARENAS

SCRIPT = textwrap.dedent("""
    import ctypes, os, sys, tempfile, threading
    import numpy as np
    if sys.argv[1] == "cap":
        from pg_policy.models.inference import keep_freed_memory
        assert keep_freed_memory()
    barrier = threading.Barrier(8)
    def work():
        barrier.wait()
        for _ in range(2000):
            chunks = [np.empty(4096) for _ in range(20)]
            del chunks
    threads = [threading.Thread(target=work) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    libc = ctypes.CDLL("libc.so.6")
    libc.fopen.restype = ctypes.c_void_p
    fd, path = tempfile.mkstemp()
    os.close(fd)
    f = libc.fopen(path.encode(), b"w")
    libc.malloc_info(0, ctypes.c_void_p(f))
    libc.fclose(ctypes.c_void_p(f))
    print(open(path).read().count("<heap nr="))
    os.remove(path)
""")


def arenas(mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", SCRIPT, mode], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return int(out.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc arenas")
def test_threads_of_a_serving_process_share_at_most_the_capped_arenas():
    assert arenas("cap") <= MALLOC_ARENAS
    assert arenas("none") > MALLOC_ARENAS  # the test can tell: contending threads do make arenas without the cap
