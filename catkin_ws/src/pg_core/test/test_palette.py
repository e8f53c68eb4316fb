"""pg_core.palette: names, and error messages that stay short whatever name they are given."""

from __future__ import annotations

import pytest

from pg_core.palette import palette_rgb, shown_name
from pg_core.target_mask import hsv_window
from pg_core.user_text import ECHOED_CHARS


def test_names_are_case_and_spelling_insensitive():
    assert palette_rgb(" Grey ") == palette_rgb("gray")


@pytest.mark.parametrize("lookup", [palette_rgb, hsv_window])
def test_an_unknown_name_is_not_echoed_whole(lookup):
    huge = "x" * (1 << 20)  # a 1 MiB target string, e.g. from a service request
    with pytest.raises(ValueError) as err:
        lookup(huge)
    message = str(err.value)
    assert len(message) < 300 and "…(1048576 chars)" in message and "green" in message
    with pytest.raises(ValueError, match="unknown .*colour 'teal'; known colours"):
        lookup("teal")  # a short name is quoted as given


def test_shown_name_cuts_at_the_limit():
    assert shown_name("a" * ECHOED_CHARS) == repr("a" * ECHOED_CHARS)
    assert shown_name("a" * (ECHOED_CHARS + 1)) == f"{'a' * ECHOED_CHARS!r}…({ECHOED_CHARS + 1} chars)"
