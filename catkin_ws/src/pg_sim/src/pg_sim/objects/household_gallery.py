"""Gallery of the household categories: one PNG per category with training and held-out examples at rest.

Each object is spawned alone at its resting pose in a PyBullet DIRECT client on a grey floor and rendered with the
TinyRenderer from 45 deg above, all tiles of a category at the same camera distance, so their sizes compare;
matplotlib lays the tiles out with their id, split, variant and length (``pushgrasp scene household-gallery``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pg_sim.objects.catalog import HOUSEHOLD_KINDS, household_info, object_spec
from pg_sim.objects.household import HELD_OUT_FROM

TRAIN_EXAMPLES = (0, 1, 2, 3)
HELD_OUT_EXAMPLES = (HELD_OUT_FROM, HELD_OUT_FROM + 1, HELD_OUT_FROM + 2, HELD_OUT_FROM + 3)
TILE = (240, 180)  # pixels (width, height) of one rendered object
FOV = 30.0  # deg
COLORS = {"train": (70, 130, 200), "heldout": (215, 120, 50)}  # RGB 0-255 of the objects of each split


def _render(client: int, object_id: str, distance: float, color: tuple[int, int, int]) -> np.ndarray:
    """(H, W, 3) uint8 image of ``object_id`` resting at the origin, seen from ``distance`` m."""
    import pybullet as p

    from pg_sim.scenes.objects import spawn_object

    info = household_info(object_id)
    pose = (0.0, 0.0, info.extents[2] / 2, *info.rest_rpy)
    body = spawn_object(client, object_spec(object_id, color, pose, object_id.replace("/", "-")))
    try:
        view = p.computeViewMatrixFromYawPitchRoll([0.0, 0.0, info.extents[2] / 3], distance, 35.0, -45.0, 0.0, 2,
                                                   physicsClientId=client)
        proj = p.computeProjectionMatrixFOV(FOV, TILE[0] / TILE[1], 0.01, 5.0, physicsClientId=client)
        _, _, rgba, _, _ = p.getCameraImage(TILE[0], TILE[1], view, proj, renderer=p.ER_TINY_RENDERER,
                                            lightDirection=[0.6, -0.4, 1.0], shadow=1, physicsClientId=client)
        return np.asarray(rgba, dtype=np.uint8).reshape(TILE[1], TILE[0], 4)[:, :, :3]
    finally:
        p.removeBody(body, physicsClientId=client)


def render_category_png(category: str, out: str | Path, train: Sequence[int] = TRAIN_EXAMPLES,
                        heldout: Sequence[int] = HELD_OUT_EXAMPLES) -> Path:
    """Write ``out`` (PNG): the training examples ``train`` on the top row and the held-out ``heldout`` below.
    Raises ValueError for an unknown category or index."""
    import pybullet as p
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if category not in HOUSEHOLD_KINDS:
        raise ValueError(f"unknown household category {category!r}; known: {', '.join(HOUSEHOLD_KINDS)}")
    rows = [("train", [f"{category}/{i}" for i in train]), ("heldout", [f"{category}/{i}" for i in heldout])]
    radius = max(0.5 * float(np.linalg.norm(household_info(i).extents)) for _, ids in rows for i in ids)
    distance = 1.05 * radius / math.sin(math.radians(FOV / 2))
    client = p.connect(p.DIRECT)
    try:
        floor = p.createVisualShape(p.GEOM_BOX, halfExtents=[2.0, 2.0, 0.001], rgbaColor=[0.82, 0.82, 0.8, 1.0],
                                    physicsClientId=client)
        p.createMultiBody(0.0, -1, floor, [0.0, 0.0, -0.001], physicsClientId=client)
        cols = max(len(ids) for _, ids in rows)
        fig = Figure(figsize=(2.4 * cols, 2.1 * len(rows)), dpi=100)
        FigureCanvasAgg(fig)
        for r, (split, ids) in enumerate(rows):
            for c, object_id in enumerate(ids):
                ax = fig.add_subplot(len(rows), cols, r * cols + c + 1)
                ax.imshow(_render(client, object_id, distance, COLORS[split]))
                info = household_info(object_id)
                ax.set_title(f"{'held-out' if split == 'heldout' else 'train'} {object_id}\n{info.variant}, "
                             f"{info.length * 100:.1f} cm", fontsize=8, color="#b05a10" if split == "heldout" else
                             "#2a5d9a")
                ax.set_axis_off()
        fig.suptitle(f"household category {category!r}: training (blue) and held-out (orange) examples at rest",
                     fontsize=9)
        fig.tight_layout(rect=(0, 0, 1, 0.96))
        out = Path(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, format="png")
        return out
    finally:
        p.disconnect(client)
