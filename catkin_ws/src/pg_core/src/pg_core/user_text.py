"""User-given text in answers and log lines, bounded: a scene, target, frame or arm name from a request is repeated at
most ECHOED_CHARS characters long, so that a huge request never makes a huge answer. The same wording as
pg_control's C++ ``cutUserText`` (pg_control/user_text.h): ``"ffff…(10000 chars)"``."""

from __future__ import annotations

ECHOED_CHARS = 64  # characters of a user-given string that a message repeats
ELLIPSIS = "\u2026"


def cut(value: object, max_chars: int = ECHOED_CHARS, *, quoted: bool = False) -> str:
    """``str(value)`` whole when it has at most ``max_chars`` characters; otherwise its first ``max_chars``
    characters, an ellipsis and the original length: ``"ffff…(10000 chars)"``. ``quoted``: the kept text as its repr
    (control characters escaped), the suffix outside the quotes: ``'ffff'…(10000 chars)``."""
    text = str(value)
    if len(text) <= max_chars:
        return repr(text) if quoted else text
    kept = repr(text[:max_chars]) if quoted else text[:max_chars]
    return f"{kept}{ELLIPSIS}({len(text)} chars)"
