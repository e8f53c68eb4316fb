"""pg_policy.target_loop.target_spec: a bad target spec, or one the heightmap refuses (a point off the workspace or
on the bare table, a mask of another shape or on the table only), is refused with a ValueError naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.target_loop.target_spec import ColourTarget, MaskTarget, PointTarget, TargetFollower

GEO = load()


def _flat(shape: tuple[int, int] = (224, 224)) -> Heightmap:
    height = np.zeros(shape, np.float32)
    height[100:120, 100:120] = 0.04  # one 4 x 4 cm block
    return Heightmap(np.full(shape + (3,), 120, np.uint8), height, np.ones(shape, bool), GEO.heightmap.resolution,
                     GEO.workspace.bounds)


@pytest.mark.parametrize("make, field", [
    (lambda: ColourTarget("octarine"), "ColourTarget.name"),
    (lambda: PointTarget(float("nan"), 0.0), "PointTarget.x"),
    (lambda: MaskTarget(np.zeros((224, 224), bool)), "MaskTarget.mask"),
    (lambda: MaskTarget(np.ones(5, bool)), "MaskTarget.mask"),
])
def test_bad_specs_are_refused_naming_the_field(make, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        make()


@pytest.mark.parametrize("spec, field", [
    (PointTarget(0.5, 0.0), "PointTarget.x"),
    (PointTarget(0.0, -0.3), "PointTarget.y"),
    (PointTarget(-0.15, -0.15), "PointTarget"),  # bare table
    (MaskTarget(np.ones((10, 10), bool)), "MaskTarget.mask"),  # another shape than the heightmap
    (MaskTarget(np.pad(np.ones((5, 5), bool), ((0, 219), (0, 219)))), "MaskTarget.mask"),  # on table only
])
def test_specs_the_heightmap_refuses_name_the_field(spec, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        TargetFollower(spec).mask(_flat())
