"""Target masks: palette-derived HSV windows, exclusivity, shading invariance, IoU against simulator ground truth."""

import numpy as np
import pytest

from pg_core import palette
from pg_core.target_mask import (
    WINDOWS,
    dilate_mask,
    hsv_window,
    target_mask,
)

SHADES = (0.55, 0.65, 0.8, 1.0, 1.05)  # the simulator shades between 0.65 (ambient only) and ~1.05 of the palette


def _image(rgb, shape=(8, 8)):
    return np.tile(np.asarray(rgb, np.uint8), (*shape, 1))


def _shade(rgb, k):
    return tuple(int(min(255, round(c * k))) for c in rgb)


def _matches(rgb, name):
    img = _image(rgb)
    return bool(target_mask(img, np.ones(img.shape[:2], bool), name, min_blob_cells=0).all())


# -- windows: pure colour tests (no simulator) --------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(palette.PALETTE))
def test_each_shaded_palette_colour_matches_itself_only(name):
    for k in SHADES:
        rgb = _shade(palette.PALETTE[name], k)
        hits = [other for other in palette.PALETTE if _matches(rgb, other)]
        assert hits == [name], f"{name} shaded x{k} = {rgb} matched {hits}"


def test_table_matches_no_colour():
    for k in SHADES:
        rgb = _shade(palette.BACKGROUND["table"], k)
        assert not any(_matches(rgb, n) for n in palette.PALETTE), rgb


def test_dark_and_unknown():
    assert not _matches((0, 0, 0), "green")
    assert not _matches(_shade(palette.PALETTE["green"], 0.3), "green")  # too dark to trust the hue
    with pytest.raises(ValueError, match="known colours: blue, brown"):
        target_mask(_image((0, 0, 0)), np.ones((8, 8), bool), "magenta")
    assert hsv_window("Grey") is WINDOWS["gray"] and hsv_window(" GREEN ") is WINDOWS["green"]


def test_bad_arrays_raise():
    with pytest.raises(ValueError):
        target_mask(np.zeros((8, 8, 3), np.float32), np.ones((8, 8), bool), "green")
    with pytest.raises(ValueError):
        target_mask(np.zeros((8, 8, 3), np.uint8), np.ones((8, 9), bool), "green")


def test_invalid_cells_and_speckle_are_dropped():
    img = _image(palette.BACKGROUND["table"], (40, 40))
    img[10:20, 10:20] = palette.PALETTE["green"]
    img[30, 30] = palette.PALETTE["green"]  # a lone cell: speckle
    valid = np.ones((40, 40), bool)
    valid[10, 10:20] = False
    m = target_mask(img, valid, "green")
    expected = np.zeros((40, 40), bool)
    expected[11:20, 10:20] = True
    assert np.array_equal(m, expected)
    assert target_mask(img, valid, "green", min_blob_cells=0)[30, 30]


def test_dilate_mask_is_a_disc():
    m = np.zeros((21, 21), bool)
    m[10, 10] = True
    d = dilate_mask(m, 0.002, 0.01)  # 5 cells
    rows, cols = np.nonzero(d)
    assert ((rows - 10) ** 2 + (cols - 10) ** 2 <= 25).all() and d.sum() == 81
    assert np.array_equal(dilate_mask(m, 0.002, 0.0), m)


def test_one_colour_table_for_sim_and_policy():
    from pg_sim.robot.urdf_builder import MATERIALS
    from pg_sim.scenes import colors

    assert colors.PALETTE is palette.PALETTE and colors.COLORS is palette.COLORS
    assert colors.TARGET_COLOR == palette.TARGET_COLOR == "green" and palette.PALETTE["green"] == (89, 161, 79)
    assert palette.BACKGROUND["table"] == tuple(int(round(c * 255)) for c in MATERIALS["table_wood"][:3])


# -- against the simulator's ground truth -------------------------------------------------------------------------
def _iou(a, b):
    return float((a & b).sum()) / max(float((a | b).sum()), 1.0)


@pytest.fixture(scope="module")
def world():
    from pg_sim.world.world import World

    w = World()
    yield w
    w.close()


@pytest.fixture(scope="module")
def random_views(world):
    """seed -> (heightmap, label map, {body: rgb}, target body) of settled random-10 scenes, rendered once."""
    from pg_sim.world.random_scene import drop_scene, sample_drops

    cache = {}

    def get(seed):
        if seed not in cache:
            drop_scene(world, sample_drops(10, seed))
            obs = world.observe()
            cache[seed] = (obs.heightmap, world.label_heightmap(obs.frame),
                           {b: s.color for b, s in world.objects.items()}, world.target_id)
        return cache[seed]

    return get


def _shipped():
    from pg_sim.scenes.scene import list_scenes

    return list_scenes()


def test_all_shipped_scenes_listed():
    names = _shipped()
    assert sum(n.startswith("packed/") for n in names) == 9 and sum(n.startswith("household/") for n in names) == 4


@pytest.mark.parametrize("name", _shipped())
def test_target_iou_on_shipped_scene(world, name):
    from pg_sim.scenes.scene import find_scene, load_scene

    scene = load_scene(find_scene(name))
    world.load_scene(scene)
    obs = world.observe()
    hm = obs.heightmap
    truth = world.label_heightmap(obs.frame) == world.target_id
    assert truth.sum() > 100
    iou = _iou(target_mask(hm.color, hm.valid, scene.target), truth)
    assert iou >= 0.9, f"{name}: IoU {iou:.3f}"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_target_iou_on_random_scene(random_views, seed):
    hm, labels, _, target = random_views(seed)
    truth = labels == target
    assert truth.sum() >= 25, f"seed {seed}: target buried ({truth.sum()} cells visible): choose another seed"
    iou = _iou(target_mask(hm.color, hm.valid, palette.TARGET_COLOR), truth)
    assert iou >= 0.9, f"random-10 seed {seed}: IoU {iou:.3f}"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_non_green_targets_on_random_scene(random_views, seed):
    hm, labels, colours, _ = random_views(seed)
    checked = 0
    for body, rgb in colours.items():
        name = [n for n, c in palette.PALETTE.items() if c == tuple(rgb)][0]
        truth = labels == body
        if name == palette.TARGET_COLOR or list(colours.values()).count(rgb) != 1 or truth.sum() < 25:
            continue
        iou = _iou(target_mask(hm.color, hm.valid, name), truth)
        assert iou >= 0.9, f"random-10 seed {seed}, {name}: IoU {iou:.3f}"
        checked += 1
    assert checked >= 2
