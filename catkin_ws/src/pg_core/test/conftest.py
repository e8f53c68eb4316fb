"""Shared fixtures of pg_core's tests."""

from collections.abc import Callable
from pathlib import Path

import pytest
import yaml

from pg_core import geometry


@pytest.fixture
def load_edited(tmp_path: Path) -> Callable[[Callable[[dict], object]], geometry.Geometry]:
    """load_edited(edit): the shipped geometry config with `edit` applied to its `primitives` mapping, written to a
    fresh file and loaded (a new path each call: the loader caches by path)."""
    count = [0]

    def load(edit: Callable[[dict], object]) -> geometry.Geometry:
        raw = yaml.safe_load(geometry.DEFAULT_CONFIG.read_text())
        edit(raw["primitives"])
        count[0] += 1
        path = tmp_path / f"ws{count[0]}.yaml"
        path.write_text(yaml.safe_dump(raw))
        return geometry.load(path)

    return load
