"""The project's Markdown describes the product in the present tense; its history lives in CHANGELOG.md, by date.

Every tracked Markdown file (``git ls-files '*.md'``) is read line by line, and a line fails when it narrates how
the work went instead of what the software is: numbered work periods ("the sixth session", "in the 12th
sprint"), sessions named relative to one another ("an earlier session", "this session"), issue numbers
("issue 5", "issues 3 and 4"), and dating by an ordinal ("since the fourteenth", "until the 9th").
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
EXCLUDED_PREFIXES = ("shared/",)

_ORDINAL_WORDS = (
    "first second third fourth fifth sixth seventh eighth ninth tenth eleventh twelfth thirteenth fourteenth "
    "fifteenth sixteenth seventeenth eighteenth nineteenth twentieth"
).split()
_ORDINAL_NUMBERS = r"(?:1st|2nd|3rd|[4-9]th|1[0-9]th|20th)"
ORDINAL = r"(?:" + "|".join(_ORDINAL_WORDS) + r"|" + _ORDINAL_NUMBERS + r")"
# "-th" ordinals only: "since the first grasp" is a fact about a trial, "since the sixth" dates a change.
TH_ORDINAL = r"(?:" + "|".join(w for w in _ORDINAL_WORDS if w.endswith("th")) + r"|\d+th)"
PERIOD = r"(?:sessions?|work[ -]periods?|sprints?)"

PATTERNS: tuple[tuple[str, re.Pattern[str]], ...] = (
    ("numbered work period", re.compile(rf"\b{ORDINAL}\b(?:\W+\w+){{0,3}}?\W+{PERIOD}\b", re.IGNORECASE)),
    ("relative work period", re.compile(rf"\b(?:earlier|previous|last|this|next|each)\s+{PERIOD}\b", re.IGNORECASE)),
    ("issue number", re.compile(r"\bissues?\s*#\s*\d+|\bissues?\s+\d+", re.IGNORECASE)),
    ("dated by ordinal", re.compile(rf"\b(?:until|since|before|after)\s+the\s+{TH_ORDINAL}\b", re.IGNORECASE)),
)


def narration(line: str) -> list[tuple[str, str]]:
    """(kind, matched phrase) for every piece of history narration in one line of text."""
    return [(kind, m.group(0)) for kind, pattern in PATTERNS for m in pattern.finditer(line)]


def tracked_markdown() -> list[Path]:
    """Tracked Markdown files of the repository, relative to its root, minus the excluded prefixes."""
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.fail("the Markdown docs are found with `git ls-files`: run the tests in a git checkout")
    out = subprocess.run(["git", "ls-files", "-z", "*.md"], cwd=REPO, check=True, capture_output=True, text=True)
    names = [n for n in out.stdout.split("\0") if n and not n.startswith(EXCLUDED_PREFIXES)]
    return [Path(n) for n in names if (REPO / n).is_file()]


@pytest.mark.parametrize(
    "text",
    [
        "the sixth session's simulator fix",
        "Adopted in the Thirteenth Session: jaw-walls",
        "shipped in the 14th work period",
        "in the first two sprints",
        "since the twelfth session, as jaw-strict",
        "an earlier session measured it",
        "this session was lent an H100",
        "(issue 5, in progress)",
        "see issue #12",
        "issues 3 and 4",
        "until the sixth, only one object was credited",
        "since the 14th, the push guards",
    ],
)
def test_matcher_flags_history_narration(text: str) -> None:
    assert narration(text), text


@pytest.mark.parametrize(
    "text",
    [
        "a ROS master per test",
        "each rostest runs against its own ROS session of roscore",
        "the first 30 of a 100-trial run are the 30-trial run",
        "the heuristic grasps the target at the first attempt in all 120 trials",
        "after the depth image arrives, the projector publishes",
        "the fourth rotation index is 67.5 degrees",
        "tissue 5 box",
        "seeds from 1000000; trial i uses seed 1,000,000 + i",
        "## [Unreleased]",
    ],
)
def test_matcher_passes_product_statements(text: str) -> None:
    assert not narration(text), narration(text)


def test_tracked_markdown_is_in_the_present_tense() -> None:
    files = tracked_markdown()
    assert files, "no tracked Markdown found"
    failures = [
        f"{path}:{number}: {kind}: {phrase!r}"
        for path in files
        for number, line in enumerate((REPO / path).read_text(encoding="utf-8").splitlines(), start=1)
        for kind, phrase in narration(line)
    ]
    assert not failures, "history narration in the docs (move it to CHANGELOG.md):\n" + "\n".join(failures)
