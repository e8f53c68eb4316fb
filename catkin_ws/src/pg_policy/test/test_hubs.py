"""pg_policy.perception.hubs, through the segmentation: a raised hub crowning a body that falls away from it is one
object with the body; an object lying in a vessel, one of another colour, one standing high on the body and a
look-alike beside a block stay apart."""

from __future__ import annotations

import numpy as np

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.perception.hubs import join_hubs
from pg_policy.perception.segmentation import segment_at, segment_objects

GEO = load()
GREY = (150, 150, 150)


def _radius(centre: tuple[int, int] = (112, 112), shape: tuple[int, int] = (224, 224)) -> np.ndarray:
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    return np.hypot(rows - centre[0], cols - centre[1])


def _dome() -> tuple[Heightmap, np.ndarray]:
    """A grey dome 30 cells across whose top is a hub 12 cells across, 7 mm above the dome's crest: the dome falls
    from 34 mm at the hub to 6 mm at its rim. Returns the heightmap and the object's cells."""
    r = _radius()
    height = np.zeros((224, 224), np.float32)
    colour = np.full((224, 224, 3), (205, 185, 150), np.uint8)
    body, hub = (r <= 30) & (r > 12), r <= 12
    height[body] = 0.034 - (r[body] - 12) / 18 * 0.028
    height[hub] = 0.041
    colour[body | hub] = GREY
    return Heightmap(colour, height, np.ones((224, 224), bool), GEO.heightmap.resolution, GEO.workspace.bounds), \
        body | hub


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def test_a_hub_crowning_a_dome_is_one_object_with_it():
    hm, dome = _dome()
    labels = segment_objects(hm)
    assert len(np.unique(labels[dome])) == 1 and labels[112, 112] > 0
    assert _iou(segment_at(hm, 112, 112), dome) >= 0.9  # a click at the hub names the whole object


def _labels(hub_height: float, body_falls: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Labels of a body (1) around a disc (2) on a 80 x 80 grid, one colour (Lab 0); the body 30 mm high next to
    the disc and falling to 5 mm at its rim (or rising to 40 mm: a vessel), the disc `hub_height` m high."""
    r = _radius((40, 40), (80, 80))
    labels = np.where(r <= 8, 2, np.where((r > 8) & (r <= 30), 1, 0)).astype(np.int32)
    slope = (r - 8) / 22
    body = 0.03 - 0.025 * slope if body_falls else 0.03 + 0.01 * slope
    height = np.where(labels == 1, body, np.where(labels == 2, hub_height, 0.0)).astype(np.float32)
    return labels, height, np.zeros((80, 80, 3), np.float32)


def test_a_disc_on_a_body_joins_it_only_as_a_hub_of_its_colour():
    labels, height, lab = _labels(0.036, body_falls=True)
    assert set(np.unique(join_hubs(labels, height, lab, 18.0))) == {0, 1}  # a hub: one object
    lab[labels == 2] = (50.0, 60.0, 40.0)
    assert np.array_equal(join_hubs(labels, height, lab, 18.0), labels)  # another colour: another object
    labels, height, lab = _labels(0.036, body_falls=False)
    assert np.array_equal(join_hubs(labels, height, lab, 18.0), labels)  # the body rises away: a vessel's content
    labels, height, lab = _labels(0.06, body_falls=True)
    assert np.array_equal(join_hubs(labels, height, lab, 18.0), labels)  # 30 mm above the body: standing on it
    labels, height, lab = _labels(0.025, body_falls=True)
    assert np.array_equal(join_hubs(labels, height, lab, 18.0), labels)  # lower than the body round it


def test_a_look_alike_beside_a_sloping_block_stays_apart():
    labels, height, lab = _labels(0.036, body_falls=True)
    beside = labels.copy()
    beside[(beside == 1) & (np.mgrid[0:80, 0:80][1] < 40)] = 0  # the body on one side of it only
    assert np.array_equal(join_hubs(beside, np.where(beside > 0, height, 0.0), lab, 18.0), beside)
