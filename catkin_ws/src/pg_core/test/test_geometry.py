"""Geometry config loading: clear errors for missing files and keys."""

import pytest
import yaml

from pg_core import geometry


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        geometry.load(tmp_path / "nope.yaml")


def test_missing_key_is_named(tmp_path):
    raw = yaml.safe_load(geometry.DEFAULT_CONFIG.read_text())
    del raw["primitives"]["push_length"]
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(raw))
    with pytest.raises(ValueError, match="primitives.push_length"):
        geometry.load(bad)


def test_workspace_contains():
    ws = geometry.load().workspace
    assert ws.contains([0, 0, 0.1]) and not ws.contains([0.3, 0, 0.1]) and not ws.contains([0, 0, -0.01])


def _write(tmp_path, raw):
    path = tmp_path / "ws.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.parametrize("key", ["grasp_stop_force", "push_stop_force"])
def test_stop_forces_are_optional_and_off_when_absent(tmp_path, key):
    raw = yaml.safe_load(geometry.DEFAULT_CONFIG.read_text())
    raw["primitives"].pop(key, None)
    assert getattr(geometry.load(_write(tmp_path, raw)).primitives, key) == 0.0


@pytest.mark.parametrize("key", ["grasp_stop_force", "push_stop_force"])
@pytest.mark.parametrize("bad", [-1.0, "ten", True, float("inf")])
def test_stop_forces_must_be_non_negative_numbers(tmp_path, key, bad):
    raw = yaml.safe_load(geometry.DEFAULT_CONFIG.read_text())
    raw["primitives"][key] = bad
    with pytest.raises(ValueError, match=key):
        geometry.load(_write(tmp_path, raw))
