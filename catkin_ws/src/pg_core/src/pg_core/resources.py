"""Where the project's catkin packages and their resources are on disk: the one place Python finds them
(pg_description's geometry config, calibration and URDF, pg_policy's shipped models, pg_sim's scene files, the
project's launch files).

`package_path(name)` asks, in this order:
1. the ROS package path (rospkg over $ROS_PACKAGE_PATH, which the catkin devel or install space's setup script sets:
   `source scripts/ros_env.sh`): the source packages in a devel space, `share/<name>` in an install space;
2. $PG_CATKIN_SRC, a folder holding the packages (e.g. a clone's catkin_ws/src), for a machine without ROS;
3. the source tree of the editable install of the `pushgrasp` distribution (`pip install -e .`, what `make setup`
   does): <clone>/catkin_ws/src.
Raises PackageNotFound (a LookupError) naming what it searched. Nothing here imports ROS at run time beyond rospkg,
which reads the package path only.
"""

from __future__ import annotations

import json
import os
from functools import lru_cache
from pathlib import Path

CATKIN_SRC_ENV = "PG_CATKIN_SRC"  # a folder holding the catkin packages, used when ROS's package path lacks them
PROJECT_ENV = "PG_REPO"  # the project's root folder (scripts/ros_env.sh exports it)
DISTRIBUTION = "pushgrasp"  # the pip distribution of pyproject.toml
CATKIN_SRC_IN_PROJECT = Path("catkin_ws") / "src"


class PackageNotFound(LookupError):
    """A catkin package (or the project root) that none of the places of the module docstring holds."""


def _is_package(folder: Path, name: str) -> bool:
    return (folder / "package.xml").is_file() and folder.name == name


def _from_ros_package_path(name: str, ros_package_path: str) -> Path | None:
    if not ros_package_path:
        return None
    try:
        import rospkg
    except ImportError:
        return None
    try:
        return Path(rospkg.RosPack([p for p in ros_package_path.split(os.pathsep) if p]).get_path(name))
    except rospkg.ResourceNotFound:
        return None


@lru_cache(maxsize=1)
def _editable_root() -> Path | None:
    """The project folder of an editable install of the pushgrasp distribution (its direct_url.json), else None."""
    from importlib import metadata

    try:
        text = metadata.distribution(DISTRIBUTION).read_text("direct_url.json")
    except metadata.PackageNotFoundError:
        return None
    if not text:
        return None
    info = json.loads(text)
    url = str(info.get("url", ""))
    if not info.get("dir_info", {}).get("editable") or not url.startswith("file://"):
        return None
    from urllib.parse import unquote, urlparse

    return Path(unquote(urlparse(url).path))


@lru_cache(maxsize=64)
def _package_path(name: str, ros_package_path: str, catkin_src: str) -> Path:
    found = _from_ros_package_path(name, ros_package_path)
    if found is not None:
        return found.resolve()
    searched = [f"$ROS_PACKAGE_PATH ({ros_package_path or 'unset'})"]
    candidates: list[Path] = []
    if catkin_src:
        candidates.append(Path(catkin_src) / name)
    searched.append(f"${CATKIN_SRC_ENV} ({catkin_src or 'unset'})")
    root = _editable_root()
    if root is not None:
        candidates.append(root / CATKIN_SRC_IN_PROJECT / name)
    searched.append(f"the editable install of {DISTRIBUTION} ({root or 'none'})")
    for folder in candidates:
        if _is_package(folder, name):
            return folder.resolve()
    raise PackageNotFound(f"catkin package {name!r} not found; searched {', '.join(searched)}: "
                          "source scripts/ros_env.sh, or set " + CATKIN_SRC_ENV)


def package_path(name: str) -> Path:
    """The folder of catkin package `name` (the one holding its package.xml or, installed, its share/ folder)."""
    return _package_path(name, os.environ.get("ROS_PACKAGE_PATH", ""), os.environ.get(CATKIN_SRC_ENV, ""))


def package_file(entry: str | Path) -> Path:
    """The file of a package-relative entry "<package>/<path inside it>" (e.g. "pg_description/urdf/pushgrasp.urdf",
    the form workspace.yaml's robot.urdf takes); an absolute entry is returned as it is."""
    entry = Path(entry)
    if entry.is_absolute():
        return entry
    package, *rest = entry.parts
    return package_path(package).joinpath(*rest)


def geometry_config() -> Path:
    """pg_description's config/workspace.yaml: the geometry config every part of the project reads."""
    return package_path("pg_description") / "config" / "workspace.yaml"


def camera_calibration() -> Path:
    """pg_description's config/camera_calibration.yaml: the real camera's shipped extrinsics."""
    return package_path("pg_description") / "config" / "camera_calibration.yaml"


def shipped_models() -> Path:
    """pg_policy's models/ folder: one folder per shipped model (grasp.pt + push.pt)."""
    return package_path("pg_policy") / "models"


def scene_folder() -> Path:
    """pg_sim's scenes/ folder: the shipped scene files ({packed,household}/*.yaml)."""
    return package_path("pg_sim") / "scenes"


def project_root() -> Path:
    """The project's root folder (launch/, scripts/): $PG_REPO, else the editable install's folder.

    Raises PackageNotFound when neither is there (an install space has no project folder)."""
    env = os.environ.get(PROJECT_ENV, "")
    if env:
        return Path(env).resolve()
    root = _editable_root()
    if root is not None:
        return root.resolve()
    raise PackageNotFound(f"the project folder is unknown: set ${PROJECT_ENV} (source scripts/ros_env.sh) or install "
                          f"{DISTRIBUTION} editable (pip install -e .)")
