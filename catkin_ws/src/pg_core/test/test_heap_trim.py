"""pg_core.heap_trim.release_free_memory: freed heap memory that glibc keeps (no automatic trimming, no mmap, as a
serving policy node sets it) leaves the resident set when it is called; memory in use stays.
pg_core.heap_trim.map_large_blocks: a large block freed after glibc raised its dynamic mmap threshold leaves the
resident set at once."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent("""
    import ctypes
    import numpy as np
    from pg_core.heap_trim import release_free_memory
    libc = ctypes.CDLL("libc.so.6")
    libc.mallopt(-4, 0)  # M_MMAP_MAX: every block from the heap
    libc.mallopt(-1, 2**31 - 1)  # M_TRIM_THRESHOLD: never trimmed on free
    def rss():
        return int(next(l for l in open("/proc/self/status") if l.startswith("VmRSS")).split()[1]) / 1024
    keep = np.ones(1_000_000)  # 8 MB in use throughout
    base = rss()
    blocks = [np.ones(250_000) for _ in range(120)]  # 240 MB in 2 MB blocks, touched
    del blocks
    kept = rss()
    release_free_memory()
    print(base, kept, rss(), float(keep.sum()))
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim")
def test_free_heap_leaves_the_resident_set_and_memory_in_use_stays():
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    base, kept, after, total = (float(v) for v in out.stdout.split())
    assert kept - base > 200  # freed but still resident: what a serving node showed as growth
    assert after - base < 20  # given back
    assert total == 1_000_000.0


LARGE = textwrap.dedent("""
    import ctypes, sys
    from pg_core.heap_trim import map_large_blocks
    libc = ctypes.CDLL("libc.so.6")
    libc.malloc.restype = ctypes.c_void_p
    libc.free.argtypes = [ctypes.c_void_p]
    def rss():
        return int(next(l for l in open("/proc/self/status") if l.startswith("VmRSS")).split()[1]) / 1024
    if sys.argv[1] == "on":
        assert map_large_blocks()
    n = 24 << 20
    first = libc.malloc(n)  # mapped (over the default 128 KiB threshold); freeing it raises the dynamic threshold
    ctypes.memset(first, 1, n)
    libc.free(first)
    base = rss()
    block = libc.malloc(n)  # an image-sized block after that: from the heap unless the threshold is fixed
    ctypes.memset(block, 1, n)
    libc.free(block)
    print(rss() - base)
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
@pytest.mark.parametrize("mode", ["off", "on"])
def test_a_freed_large_block_leaves_the_resident_set_only_when_mapped_on_its_own(mode):
    out = subprocess.run([sys.executable, "-c", LARGE, mode], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    grown = float(out.stdout)
    if mode == "on":
        assert grown < 4
    else:  # glibc's default: the block stays resident in the heap (what the sim node's RSS showed)
        assert grown > 20
