"""Returning the C heap's free pages to the system (glibc `malloc_trim`), for long-running nodes: the sim node after
every reset, the policy node after every call. Without it the resident set stays at the highest peak any reset or
call reached (the policy node keeps freed memory on purpose: pg_policy.models.inference.keep_freed_memory)."""

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
