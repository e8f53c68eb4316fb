"""Named object colours (RGB, integers 0-255), shared by scenes, the importer and the target masks.

The colour data live in :mod:`pg_core.palette` (one source of colours); this module re-exports them.

``COLORS`` is the palette of VPG (Zeng et al. 2018) and of the paper's block scenes; ``green`` (89, 161, 79) is the
target colour by default (DESIGN.md section 6). ``PALETTE`` = ``COLORS`` plus ``white`` (the authors' household milk box
is white); scenes may use any ``PALETTE`` name, random scenes draw from ``COLORS``.
Raises ValueError (with the known names) for an unknown name or a malformed triple.
"""

from __future__ import annotations

from collections.abc import Sequence

from pg_core.palette import COLORS, PALETTE, RGB, TARGET_COLOR, palette_rgb
from pg_sim.scenes.short_repr import short

__all__ = ["COLORS", "PALETTE", "RGB", "TARGET_COLOR", "color_name", "nearest_color_name", "resolve_color", "rgba"]


def resolve_color(value: str | Sequence[int]) -> RGB:
    """A colour name (case-insensitive, ``grey`` accepted) or an [r, g, b] triple of integers 0-255 -> RGB tuple.

    Raises ValueError for an unknown name, a triple of the wrong length, non-integers or values outside 0-255.
    """
    if isinstance(value, str):
        return palette_rgb(value)
    try:
        items = list(value)
    except TypeError:
        raise ValueError(f"colour must be a name or [r, g, b] with 0-255 integers, got {short(value)}") from None
    if len(items) != 3:
        raise ValueError(f"colour must have 3 components [r, g, b], got {len(items)}: {short(value)}")
    out: list[int] = []
    for c in items:
        if isinstance(c, bool) or not isinstance(c, int | float) or float(c) != int(c):
            raise ValueError(f"colour components must be integers 0-255, got {short(value)}")
        if not 0 <= int(c) <= 255:
            raise ValueError(f"colour components must lie in 0-255, got {short(value)}")
        out.append(int(c))
    return (out[0], out[1], out[2])


def color_name(rgb: Sequence[int]) -> str | None:
    """The palette name whose RGB equals ``rgb`` exactly, or None."""
    t = tuple(int(c) for c in rgb)
    for name, value in PALETTE.items():
        if value == t:
            return name
    return None


def nearest_color_name(rgb: Sequence[int]) -> str:
    """The palette name closest to ``rgb`` in RGB Euclidean distance (exact matches win)."""
    t = tuple(int(c) for c in rgb)
    return min(PALETTE, key=lambda n: sum((a - b) ** 2 for a, b in zip(PALETTE[n], t, strict=True)))


def rgba(rgb: Sequence[int], alpha: float = 1.0) -> tuple[float, float, float, float]:
    """RGB 0-255 -> RGBA floats 0-1 (as PyBullet and rviz want them)."""
    r, g, b = resolve_color(rgb)
    return (r / 255.0, g / 255.0, b / 255.0, float(alpha))
