"""The C heap of long-running nodes (glibc): `release_free_memory` returns its free pages to the system (the sim node
after every reset, the policy node after every call; without it the resident set stays at the highest peak any reset
or call reached, and the policy node keeps freed memory on purpose: pg_policy.models.inference.keep_freed_memory);
`cap_arenas` bounds the malloc arenas (rospy serves connections on threads of their own, and glibc gives contending
threads new arenas, up to 8 per core, each keeping free memory of its own)."""

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
