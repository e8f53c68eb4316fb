"""Returning the C heap's free pages to the system (glibc), for a long-running sim that replaces worlds."""

from __future__ import annotations

import ctypes
import ctypes.util


def release_free_memory() -> None:
    """Give the pages that the C heap holds free back to the system (glibc ``malloc_trim``; nothing elsewhere):
    a closed world frees tens of MB in pieces that the next world re-uses only in part."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        trim = libc.malloc_trim
    except (OSError, AttributeError, TypeError):
        return
    trim.argtypes = [ctypes.c_size_t]
    trim(0)
