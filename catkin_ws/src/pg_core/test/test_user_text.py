"""pg_core.user_text: user-given text in messages is repeated whole when short, cut with its length when long."""

from __future__ import annotations

from pg_core.user_text import ECHOED_CHARS, cut


def test_short_text_is_kept_whole():
    assert cut("") == ""
    assert cut("world") == "world"
    assert cut("f" * ECHOED_CHARS) == "f" * ECHOED_CHARS
    assert cut("green", quoted=True) == "'green'"
    assert cut(42) == "42"


def test_long_text_is_cut_with_its_length():
    frame = "f" * 10_000
    assert cut(frame) == "f" * ECHOED_CHARS + "…(10000 chars)"
    assert len(cut(frame)) < 100
    assert cut("abcdef", 3) == "abc…(6 chars)"
    assert cut("abc", 0) == "…(3 chars)"


def test_quoted_escapes_the_kept_text_and_leaves_the_suffix_outside():
    assert cut("a\nb" * 100, 3, quoted=True) == "'a\\nb'…(300 chars)"
    assert cut("x\x00" * 5, quoted=True) == repr("x\x00" * 5)


def test_characters_not_bytes_are_counted():  # as the C++ cutUserText, which counts UTF-8 code points
    assert cut("\u00f6" * 100) == "\u00f6" * ECHOED_CHARS + "…(100 chars)"
    assert cut("\U0001f49a" * 3, 2) == "\U0001f49a\U0001f49a…(3 chars)"
