"""The folders that scene files and their meshes may come from when a scene path arrives from another process (the
sim node's /pg_sim/reset_scene); paths typed on the command line are the user's own and are not checked.

A path is resolved (``~``, ``..`` and symbolic links followed) and must then lie in one of the allowed folders; a path
outside is refused before the file is opened. Defaults (`AllowedFolders.default`):
- scenes: the scene folders (``$PG_SCENE_PATH`` entries and the package's ``scenes/``: pg_sim.scenes.scene.scene_dirs)
  and the user folder ``$ROS_HOME/pg_sim/scenes`` (default ``~/.ros/pg_sim/scenes``);
- meshes: the scene folders above, the pushgrasp cache (``$PUSHGRASP_CACHE``, default ``~/.cache/pushgrasp``: the
  generated catalogue objects) and pybullet_data's folder (the catalogue's named meshes and procedural objects).
Extra folders (the sim node's ``~scene_folders``) are added to both.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from pg_sim.scenes.scene import SceneError, find_scene, scene_dirs
from pg_sim.scenes.shapes import cache_dir
from pg_sim.scenes.short_repr import short


def user_scene_dir() -> Path:
    """``$ROS_HOME/pg_sim/scenes`` (ROS_HOME defaults to ``~/.ros``); it need not exist."""
    ros_home = os.environ.get("ROS_HOME") or os.path.expanduser("~/.ros")
    return Path(ros_home) / "pg_sim" / "scenes"


def _resolved(folders: Sequence[str | os.PathLike[str]]) -> tuple[Path, ...]:
    out: list[Path] = []
    for f in folders:
        path = Path(os.path.expanduser(os.fspath(f))).resolve()
        if path not in out:
            out.append(path)
    return tuple(out)


def _inside(path: Path, folders: Sequence[Path]) -> bool:
    return any(path.is_relative_to(f) for f in folders)


@dataclass(frozen=True)
class AllowedFolders:
    """Resolved folders that scene files (``scenes``) and mesh files (``meshes``) may lie in."""

    scenes: tuple[Path, ...]
    meshes: tuple[Path, ...]

    @classmethod
    def default(cls, extra: Sequence[str | os.PathLike[str]] = ()) -> AllowedFolders:
        """The default folders (module docstring) plus ``extra`` for both scenes and meshes."""
        import pybullet_data  # here, so that scene files load on a machine without the simulator

        scenes = _resolved([*scene_dirs(), user_scene_dir(), *extra])
        cache = cache_dir("objects").parent
        return cls(scenes, _resolved([*scenes, cache, pybullet_data.getDataPath()]))

    def find_scene(self, text: str) -> Path:
        """The scene file of a scene name or path, resolved; raises SceneError (naming the field ``scene`` and the
        allowed folders) for a path outside them (before it is opened or tested for existence) or an unknown name."""
        given = Path(os.path.expanduser(text))
        if given.is_absolute() or ".." in given.parts:
            self._check(given.resolve(), text)
        path = find_scene(text)
        self._check(path.resolve(), text)
        return path

    def _check(self, path: Path, text: str) -> None:
        if not _inside(path, self.scenes):
            where = "" if str(path) == text else f" (resolved: {short(str(path), 160)})"
            raise SceneError(f"scene {short(text, 160)}{where} is outside the allowed scene folders "
                             f"{short([str(d) for d in self.scenes], 160)} (more: the sim node's ~scene_folders)")
