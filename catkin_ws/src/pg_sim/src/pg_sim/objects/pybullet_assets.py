"""Objects that pybullet_data installs with pybullet: named meshes and the 1000 procedural ``random_urdfs`` blobs.

Nothing is downloaded: the files are read from the installed ``pybullet_data`` package. Named meshes use the convex
decomposition pybullet_data ships where it has one (``*_vhacd.obj``, ``mug_col.obj``, ...); the others are decomposed
once with V-HACD and cached (pg_sim.scenes.meshes.decomposed_obj).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

BLOB_COUNT = 1000  # random_urdfs/000 .. 999
BLOB_SCALE = 0.01  # their .obj units -> metres: 0.03-0.12 m objects
# blobs whose .obj pybullet_data ships unusable: random_urdfs/168/168.obj has "nan" for every vertex. The catalogue
# leaves them out (test_catalog checks the installed package against this set).
BROKEN_BLOBS = frozenset({168})


@dataclass(frozen=True)
class NamedMesh:
    """A pybullet_data mesh: file relative to the data folder, scale to metres, density (kg/m^3)."""

    file: str
    scale: tuple[float, float, float]
    density: float


def _s(v: float) -> tuple[float, float, float]:
    return (v, v, v)


# name -> mesh; the split of each is in pg_sim.objects.catalog
NAMED: dict[str, NamedMesh] = {
    "duck": NamedMesh("duck_vhacd.obj", _s(0.05), 500.0),
    "bunny": NamedMesh("bunny.obj", _s(0.04), 500.0),
    "teddy": NamedMesh("teddy2_VHACD_CHs.obj", _s(0.08), 150.0),
    "mug": NamedMesh("objects/mug_col.obj", _s(0.7), 900.0),
    "torus": NamedMesh("torus/torus_textured.obj", _s(0.05), 700.0),
    "lego": NamedMesh("lego/lego_vhacd.obj", _s(0.1), 900.0),
    "jenga": NamedMesh("jenga/jenga.obj", (0.075, 0.025, 0.015), 600.0),
    "domino": NamedMesh("domino/domino.obj", (1.0, 1.0, 1.0), 900.0),
    "soccerball": NamedMesh("soccerball.obj", _s(0.05), 150.0),
    "sphere": NamedMesh("sphere_smooth.obj", _s(0.02), 300.0),
    "prism": NamedMesh("toys/prism.obj", _s(0.6), 600.0),
    "toy_cylinder": NamedMesh("toys/cylinder.obj", _s(0.6), 600.0),
}


def data_path(relative: str) -> Path:
    """Absolute path of a pybullet_data file; raises FileNotFoundError when the installed package lacks it."""
    import pybullet_data  # here, so that the catalogue's ids and splits load on a machine without the simulator

    path = Path(pybullet_data.getDataPath()) / relative
    if not path.is_file():
        raise FileNotFoundError(f"pybullet_data has no {relative} (looked in {pybullet_data.getDataPath()})")
    return path


def blob_path(index: int) -> Path:
    """The .obj file of procedural object ``index`` (0-999). Raises ValueError for an index out of range or in
    BROKEN_BLOBS."""
    if not 0 <= index < BLOB_COUNT:
        raise ValueError(f"blob index must be in [0, {BLOB_COUNT}), got {index}")
    if index in BROKEN_BLOBS:
        raise ValueError(f"blob {index}: pybullet_data ships random_urdfs/{index:03d} with non-finite vertices")
    return data_path(f"random_urdfs/{index:03d}/{index:03d}.obj")
