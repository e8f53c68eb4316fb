"""pg_core.resources: the packages' folders through ROS's package path, PG_CATKIN_SRC or the editable install."""

from __future__ import annotations

from pathlib import Path

import pytest

from pg_core import geometry, resources

SRC = Path(__file__).resolve().parents[2]  # this source tree's catkin_ws/src


def test_the_source_packages_are_found():
    assert resources.package_path("pg_description") == SRC / "pg_description"
    assert resources.geometry_config() == SRC / "pg_description" / "config" / "workspace.yaml"
    assert geometry.DEFAULT_CONFIG == resources.geometry_config()
    assert (resources.shipped_models() / "lite" / "grasp.pt").is_file()
    assert (resources.scene_folder() / "packed" / "case01.yaml").is_file()
    assert resources.camera_calibration().is_file()
    assert geometry.load().robot.urdf == SRC / "pg_description" / "urdf" / "pushgrasp.urdf"


def test_package_files_and_absolute_entries():
    assert resources.package_file("pg_description/urdf/pushgrasp.urdf").is_file()
    assert resources.package_file("/abs/robot.urdf") == Path("/abs/robot.urdf")


@pytest.mark.parametrize("ros_package_path", ["", "/nonexistent"])
def test_without_ros_the_editable_install_or_pg_catkin_src_is_used(monkeypatch, tmp_path, ros_package_path):
    monkeypatch.setenv("ROS_PACKAGE_PATH", ros_package_path)
    monkeypatch.delenv(resources.CATKIN_SRC_ENV, raising=False)
    assert resources.package_path("pg_policy") == SRC / "pg_policy"  # the editable install of this tree
    (tmp_path / "pg_policy").mkdir()
    (tmp_path / "pg_policy" / "package.xml").write_text("<package><name>pg_policy</name></package>\n")
    monkeypatch.setenv(resources.CATKIN_SRC_ENV, str(tmp_path))
    assert resources.package_path("pg_policy") == (tmp_path / "pg_policy").resolve()


def test_an_unknown_package_names_what_was_searched():
    with pytest.raises(LookupError, match=r"'no_such_package' not found; searched \$ROS_PACKAGE_PATH"):
        resources.package_path("no_such_package")
