"""The heightmap conventions are written once, in pg_core.heightmap, and used from there: the cell centre of a cell
((i + 0.5) * resolution + the map's origin), the gripper yaw of a rotation index (r * 2 pi / R), the height above which
a cell holds an object (OBJECT_HEIGHT_M, 0.008 m) and the number of candidates a re-rank walks (TOP_K, 200).

Every Python source of the project (the packages' src/ and nodes/, scripts/, the example plug-in) is scanned for a
retyped copy of one of them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pg_core import heightmap

REPO = Path(__file__).resolve().parents[4]
HOME = "catkin_ws/src/pg_core/src/pg_core/heightmap.py"  # where the conventions are written

CONVENTIONS: dict[str, re.Pattern[str]] = {
    "cell centre ((i + 0.5) * resolution)": re.compile(r"\+\s*0\.5\s*\)\s*\*\s*[\w.]*\bres(olution)?\b"),
    "rotation index -> yaw (r * 2 pi / R)": re.compile(
        r"2(\.0)?\s*\*\s*(math|np|numpy|torch)\.pi\s*/\s*\(?\s*[\w.]*(rotations|\bR\b|\b16\b)"
        r"|(math|np|numpy|torch)\.pi\s*/\s*8\b"),
    "object height (0.008 m)": re.compile(
        r"(?i)\b(occupied\w*|object_height\w*|\w*height\w*\s*[<>]=?)\s*[^\n]{0,40}\b0\.008\b"
        r"|\b0\.008\b[^\n]*hold[s]? an object"),
    "re-rank depth TOP_K (200)": re.compile(r"(?i)\btop_k\b[^=\n]*=\s*200\b"),
}

# Compiled into TorchScript: an exported model carries this code and cannot import pg_core when it runs.
SELF_CONTAINED = {"catkin_ws/src/pg_policy/src/pg_policy/models/nets/qnet.py": {"rotation index -> yaw (r * 2 pi / R)"}}

# Files whose owners have not switched them to pg_core.heightmap yet: remove each entry once its file is converted.
NOT_YET_CONVERTED: dict[str, set[str]] = {}


def sources() -> list[Path]:
    """The project's Python sources, relative to the repository."""
    src = REPO / "catkin_ws" / "src"
    files = [*src.glob("*/src/**/*.py"), *src.glob("*/nodes/*"), *(REPO / "scripts").glob("*.py"),
             *(REPO / "tests" / "plugin_example").glob("**/*.py")]
    return sorted(f.relative_to(REPO) for f in files if f.is_file())


def retyped(text: str) -> dict[str, list[int]]:
    """{convention: line numbers} of the conventions `text` writes out itself (comments included: a comment that
    restates the literal is a copy waiting to drift)."""
    found: dict[str, list[int]] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        for name, pattern in CONVENTIONS.items():
            if pattern.search(line):
                found.setdefault(name, []).append(number)
    return found


def test_the_conventions_live_in_pg_core_heightmap():
    assert heightmap.OBJECT_HEIGHT_M == 0.008 and heightmap.TOP_K == 200
    bounds = [[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]]
    import numpy as np

    assert heightmap.pixel_to_world(0, 223, np.array(bounds), 0.002) == pytest.approx((0.223, -0.223))
    xs, ys = heightmap.cell_centre_axes(2, 3, np.array(bounds), 0.002)
    assert xs == pytest.approx([-0.223, -0.221, -0.219]) and ys == pytest.approx([-0.223, -0.221])
    assert heightmap.rotation_yaw(4, 16) == pytest.approx(np.pi / 2) and heightmap.rotation_step(16) == pytest.approx(
        np.pi / 8)
    assert set(retyped((REPO / HOME).read_text())) == set(CONVENTIONS)  # the scan recognises the originals


@pytest.mark.parametrize("line, name", [
    ("    x = b[0, 0] + (col + 0.5) * hm.resolution", "cell centre ((i + 0.5) * resolution)"),
    ("    yaw = r * 2 * math.pi / self.rotations", "rotation index -> yaw (r * 2 pi / R)"),
    ("    yaw = int(rng.integers(16)) * np.pi / 8", "rotation index -> yaw (r * 2 pi / R)"),
    ("OCCUPIED_M = 0.008  # cells higher than this", "object height (0.008 m)"),
    ("    objects = hm.height > 0.008", "object height (0.008 m)"),
    ("TOP_K = 200  # push candidates examined per decision", "re-rank depth TOP_K (200)"),
    ("    top_k: int = 200", "re-rank depth TOP_K (200)"),
])
def test_the_scan_finds_a_retyped_convention(line, name):
    assert name in retyped(line)


def test_no_python_source_retypes_a_convention():
    offences = []
    for path in sources():
        rel = path.as_posix()
        if rel == HOME:
            continue
        allowed = SELF_CONTAINED.get(rel, set()) | NOT_YET_CONVERTED.get(rel, set())
        for name, lines in retyped((REPO / path).read_text(errors="replace")).items():
            if name not in allowed:
                offences.append(f"{rel}:{','.join(map(str, lines))}: {name}")
    assert not offences, "use pg_core.heightmap instead of retyping:\n" + "\n".join(offences)


def test_the_exceptions_are_still_needed():
    # an entry whose file no longer retypes its convention must go, so the lists only shrink
    stale = []
    for rel, names in {**NOT_YET_CONVERTED, **SELF_CONTAINED}.items():
        found = set(retyped((REPO / rel).read_text(errors="replace"))) if (REPO / rel).is_file() else set()
        stale += [f"{rel}: {name}" for name in names - found]
    assert not stale, "remove these exceptions:\n" + "\n".join(stale)
