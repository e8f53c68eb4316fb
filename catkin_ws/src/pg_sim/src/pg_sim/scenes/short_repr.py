"""Bounded reprs of user-given values for error messages: a long string or list is cut, never echoed whole."""

from __future__ import annotations

import reprlib


def short(value: object, width: int = 60) -> str:
    """The repr of ``value`` with strings over ``width`` characters and containers over 6 items cut ('...')."""
    r = reprlib.Repr()  # Python 3.11: limits are attributes, not constructor arguments
    r.maxstring = r.maxother = width
    r.maxlist = r.maxtuple = r.maxdict = r.maxset = 6
    r.maxlevel = 3
    return r.repr(value)
