"""The C heap of long-running nodes (glibc): `release_free_memory` returns its free pages to the system (the sim node
after every reset, the policy node after every call; without it the resident set stays at the highest peak any reset
or call reached, and the policy node keeps freed memory on purpose: pg_policy.models.inference.keep_freed_memory);
`cap_arenas` bounds the malloc arenas (rospy serves connections on threads of their own, and glibc gives contending
threads new arenas, up to 8 per core, each keeping free memory of its own); `map_large_blocks` gives large blocks
(camera images and clouds) pages of their own that go back to the system when they are freed."""

from __future__ import annotations

import ctypes
import ctypes.util


def release_free_memory() -> None:
    """Give the pages that the C heap holds free back to the system, every arena (glibc ``malloc_trim(0)``, a few
    ms; nothing elsewhere). Memory in use is untouched: the next allocations page-fault their memory anew."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        trim = libc.malloc_trim
    except (OSError, AttributeError, TypeError):
        return
    trim.argtypes = [ctypes.c_size_t]
    trim(0)


M_ARENA_MAX = -8  # glibc mallopt parameter
NODE_ARENAS = 2  # arenas a long-running node keeps


def cap_arenas(arenas: int = NODE_ARENAS) -> bool:
    """At most `arenas` malloc arenas in this process from now on (glibc mallopt M_ARENA_MAX; call it before
    threads start). Returns False where glibc's mallopt is unavailable."""
    try:
        return bool(ctypes.CDLL("libc.so.6").mallopt(M_ARENA_MAX, arenas))
    except (OSError, AttributeError):
        return False


M_MMAP_THRESHOLD = -3  # glibc mallopt parameter
LARGE_BLOCK = 1 << 20  # bytes: a 640 x 480 camera image is 0.9-4.9 MB


def map_large_blocks(threshold: int = LARGE_BLOCK) -> bool:
    """Blocks of `threshold` bytes or more are mapped on their own and unmapped when freed, from now on (glibc
    mallopt M_MMAP_THRESHOLD). Setting it also stops glibc's dynamic threshold, which rises to the largest block
    freed so far (up to 32 MiB): after that, images and clouds come from the heap, and the resident set goes up
    and down by tens of MB with where they happened to lie. Costs a page fault per page of every large block, so
    not for a node that allocates large tensors per call (the policy node). Returns False where glibc's
    mallopt is unavailable."""
    try:
        return bool(ctypes.CDLL("libc.so.6").mallopt(M_MMAP_THRESHOLD, threshold))
    except (OSError, AttributeError):
        return False
