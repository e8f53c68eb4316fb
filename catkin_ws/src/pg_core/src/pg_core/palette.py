"""The named object colours (RGB, integers 0-255): the one colour table of the project.

``COLORS`` is the palette of VPG (Zeng et al. 2018) and of the paper's block scenes; ``green`` (89, 161, 79) is the
target colour by default (DESIGN.md section 6). ``PALETTE`` = ``COLORS`` plus ``white``; scenes may use any
``PALETTE`` name, random scenes draw from ``COLORS``. ``pg_sim.scenes.colors`` re-exports these tables (scene parsing,
rendering) and :mod:`pg_core.target_mask` derives its HSV windows from them.

``BACKGROUND`` holds colours that are never a target but are seen in the heightmap (the simulated table top, as
``pg_sim.robot.urdf_builder.MATERIALS['table_wood']`` times 255); the target masks keep clear of them.
"""

from __future__ import annotations

from pg_core.user_text import cut

RGB = tuple[int, int, int]

COLORS: dict[str, RGB] = {  # the VPG palette (random scenes draw from these)
    "blue": (78, 121, 167),
    "green": (89, 161, 79),
    "brown": (156, 117, 95),
    "orange": (242, 142, 43),
    "yellow": (237, 201, 72),
    "gray": (186, 176, 172),
    "red": (255, 87, 87),
    "purple": (176, 122, 161),
    "cyan": (118, 183, 178),
    "pink": (255, 157, 167),
}
PALETTE: dict[str, RGB] = {**COLORS, "white": (255, 255, 255)}  # every name a scene may use

TARGET_COLOR = "green"

BACKGROUND: dict[str, RGB] = {"table": (199, 178, 148)}  # table_wood (0.78, 0.70, 0.58) * 255, rounded


def normalize_name(name: str) -> str:
    """Lower-case, stripped name with the British ``grey`` spelled ``gray`` (no validation)."""
    return name.strip().lower().replace("grey", "gray")


def shown_name(name: object) -> str:
    """`name` quoted for an error message, a long name cut (pg_core.user_text.cut): ``'xxxx'…(100000 chars)``."""
    return cut(name, quoted=True)


def palette_rgb(name: str) -> RGB:
    """RGB of a ``PALETTE`` name (case-insensitive, ``grey`` accepted); ValueError listing the known names."""
    key = normalize_name(name)
    if key not in PALETTE:
        raise ValueError(f"unknown colour {shown_name(name)}; known colours: {', '.join(sorted(PALETTE))}")
    return PALETTE[key]
