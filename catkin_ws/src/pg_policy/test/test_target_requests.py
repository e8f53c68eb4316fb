"""A request's target: the checks of pg_policy.ros.target_request (each refusal names its request field) and the
target loop with point and mask targets (pg_policy.target_loop.target_loop with the scripted fakes of
test_target_loop)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_target_loop import make

from pg_policy.ros import target_request as tr
from pg_policy.target_loop.loop_limits import LoopLimits
from pg_policy.target_loop.loop_types import LoopError, TargetRefused, as_spec, target_label
from pg_policy.target_loop.target_spec import ColourTarget, MaskTarget, PointTarget, TargetFollower

WORKSPACE = np.array([[-0.224, 0.224], [-0.224, 0.224], [0.0, 0.4]])
CAMERA = (640, 480)
BOX_XY = (-0.003, -0.003)  # centre of test_target_loop's green box, cells [100, 120) x [100, 120)


def mono8(value: int = 0, size: tuple[int, int] = CAMERA, pad: int = 0) -> bytes:
    img = np.zeros((size[1], size[0] + pad), np.uint8)
    img[200:220, 300:330] = value
    return img.tobytes()


# ---- which form ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("target, frame, nbytes, form", [("", "", 0, "target"), ("red", "", 0, "target"),
                                                         ("", "world", 0, "point"), ("", "", 10, "mask")])
def test_one_form(target: str, frame: str, nbytes: int, form: str) -> None:
    assert tr.request_form(target, frame, nbytes) == form


@pytest.mark.parametrize("target, frame, nbytes, fields", [("red", "world", 0, "target and point"),
                                                           ("red", "", 4, "target and mask"),
                                                           ("", "world", 4, "point and mask"),
                                                           ("red", "world", 4, "target and point and mask")])
def test_two_forms_are_refused_naming_them(target: str, frame: str, nbytes: int, fields: str) -> None:
    with pytest.raises(ValueError, match=f"^{fields}: set exactly one"):
        tr.request_form(target, frame, nbytes)


# ---- point --------------------------------------------------------------------------------------------------------

def test_point_inside_the_workspace() -> None:
    assert tr.point_target((0.1, -0.05, 0.03), WORKSPACE) == PointTarget(0.1, -0.05)
    assert tr.point_target((0.1, -0.05, -0.01), WORKSPACE) == PointTarget(0.1, -0.05)  # table top, within tolerance


@pytest.mark.parametrize("xyz", [(0.3, 0.0, 0.0), (0.0, -0.25, 0.0), (0.0, 0.0, 0.9), (0.0, 0.0, -0.2),
                                 (math.nan, 0.0, 0.0), (0.0, math.inf, 0.0)])
def test_point_outside_the_workspace_is_refused(xyz: tuple[float, float, float]) -> None:
    with pytest.raises(ValueError, match="^point: "):
        tr.point_target(xyz, WORKSPACE)


# ---- mask ---------------------------------------------------------------------------------------------------------

def test_mask_image() -> None:
    img = tr.mask_image("mono8", *CAMERA, CAMERA[0], mono8(255), CAMERA)
    assert img.shape == (480, 640) and img[210, 310] == 255 and img.sum() == 255 * 600
    padded = tr.mask_image("mono8", *CAMERA, CAMERA[0] + 4, mono8(1, pad=4), CAMERA)  # row padding (step > width)
    assert padded.shape == (480, 640) and np.count_nonzero(padded) == 600


@pytest.mark.parametrize("encoding, size, step, data, camera, why", [
    ("rgb8", CAMERA, CAMERA[0], mono8(255), CAMERA, "encoding must be mono8"),
    ("mono16", CAMERA, CAMERA[0], mono8(255), CAMERA, "encoding must be mono8"),
    ("mono8", (320, 240), 320, mono8(255, (320, 240)), CAMERA, "size 320 x 240 differs"),
    ("mono8", CAMERA, CAMERA[0], mono8(255), None, "size is unknown"),
    ("mono8", CAMERA, CAMERA[0], mono8(255)[:-1], CAMERA, "do not hold"),
    ("mono8", CAMERA, CAMERA[0], mono8(0), CAMERA, "every pixel is zero"),
])
def test_bad_masks_are_refused(encoding, size, step, data, camera, why) -> None:
    with pytest.raises(ValueError, match=f"^mask: .*{why}"):
        tr.mask_image(encoding, size[0], size[1], step, data, camera)


def test_mask_stamp_near_the_heightmap() -> None:
    tr.check_skew(100.0, 101.5, 2.0)
    tr.check_skew(100.0, 98.5, 2.0)
    with pytest.raises(ValueError, match=r"^mask: stamped 3.00 s before the heightmap"):
        tr.check_skew(100.0, 103.0, 2.0)
    with pytest.raises(ValueError, match=r"^mask: stamped 2.50 s after"):
        tr.check_skew(100.0, 97.5, 2.0)
    with pytest.raises(ValueError, match=r"^mask: header.stamp is zero"):
        tr.check_skew(0.0, 97.5, 2.0)


def test_mask_projecting_onto_no_cell_is_refused() -> None:
    with pytest.raises(ValueError, match="^mask: it covers no heightmap cell"):
        tr.mask_target(np.zeros((224, 224), bool))
    assert isinstance(tr.mask_target(np.eye(224, dtype=bool)), MaskTarget)


def test_refusal_message() -> None:
    assert tr.refusal("point: off") == "invalid request, nothing moved: point: off"
    assert tr.first_view_field("mask", "MaskTarget.mask covers no object") == "mask: MaskTarget.mask covers no object"


# ---- the loop with point and mask targets -------------------------------------------------------------------------

def test_colour_strings_still_name_targets() -> None:
    assert as_spec("") == ColourTarget("green") and as_spec("GREEN") == ColourTarget("green")
    assert target_label(as_spec("red")) == "red"
    assert target_label(PointTarget(0.1, -0.02)) == "point (0.100, -0.020)"
    with pytest.raises(LoopError, match="unknown|colour|color"):
        as_spec("no-such-colour")


def test_colour_call_gives_the_policy_no_mask() -> None:
    loop, _, _, records = make([(True, True, True)])
    seen = []
    act = loop.policy.act
    loop.policy.act = lambda obs: (seen.append(obs.mask), act(obs))[1]
    assert loop.run("green").success
    assert seen == [None] and records[0].target == "green" and records[0].target_mask is None


@pytest.mark.parametrize("spec", [PointTarget(*BOX_XY), "mask"])
def test_point_and_mask_targets_reach_the_policy_as_masks(spec) -> None:
    box = np.zeros((224, 224), bool)
    box[100:120, 100:120] = True
    if spec == "mask":
        part = np.zeros_like(box)
        part[95:110, 95:110] = True  # partly table: refined to the box
        spec = MaskTarget(part)
    loop, _, ex, records = make([(True, False, False), (True, True, True)])
    masks = []
    act = loop.policy.act
    loop.policy.act = lambda obs: (masks.append(obs.mask), act(obs))[1]
    res = loop.run(spec)
    assert res.success and len(ex.calls) == 2, res.message
    assert "in doubt" not in res.message  # a sure track: the answer says the target was grasped, nothing more
    assert np.array_equal(masks[0], box) and np.array_equal(records[0].target_mask, box)
    assert records[0].target_pixels == 400 and records[1].target_grasped
    assert records[0].target == target_label(spec)


def test_point_on_bare_table_is_refused_before_anything_moves() -> None:
    loop, _, ex, _ = make([(True, True, True)])
    with pytest.raises(TargetRefused, match="PointTarget"):
        loop.run(PointTarget(0.15, 0.15))
    with pytest.raises(TargetRefused, match="PointTarget.x"):
        loop.run(PointTarget(0.5, 0.0))
    with pytest.raises(TargetRefused, match="MaskTarget.mask covers no object"):
        part = np.zeros((224, 224), bool)
        part[10:20, 10:20] = True
        loop.infer(MaskTarget(part))
    assert ex.calls == []


def test_an_unsure_track_is_in_the_note(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(TargetFollower, "unsure", property(lambda self: self.track is not None))
    monkeypatch.setattr(TargetFollower, "why", property(lambda self: "runner-up within 0.02"))
    loop, _, _, records = make([(True, True, True)])
    res = loop.run(PointTarget(*BOX_XY))
    assert records[0].note.startswith("target track unsure: runner-up within 0.02")
    assert res.success and res.message.endswith(
        "grasped; the track was in doubt at that grasp (runner-up within 0.02): the object held may be another one")
    loop, _, _, _ = make([(True, True, True)])  # the first one's target was lifted
    assert loop.infer(PointTarget(*BOX_XY)).note.startswith("target track unsure: ")


def test_an_executed_push_tells_the_tracker_where_it_carried_the_target(monkeypatch: pytest.MonkeyPatch) -> None:
    from types import SimpleNamespace

    from pg_policy.perception.target_tracker import TargetTracker

    shifts = []
    update = TargetTracker.update
    monkeypatch.setattr(TargetTracker, "update", lambda self, hm, shift_xy=None: (shifts.append(shift_xy),
                                                                                  update(self, hm, shift_xy))[1])
    loop, _, ex, _ = make([(True, False, False), (False, False, False)], primitive="push")
    loop.policy.prims = SimpleNamespace(push_length=0.13)  # the geometry's push length, as a policy carries it
    loop.run(PointTarget(*BOX_XY), LoopLimits(max_actions=2))
    assert len(ex.calls) == 2 and len(shifts) >= 1
    dx, dy = shifts[0]  # the push from the box's centre along rotation 1 (22.5 deg) carries it 0.13 m at most
    assert 0.05 < math.hypot(dx, dy) <= 0.13 and dx > 0 and dy > 0
    if len(shifts) > 1:
        assert shifts[1] is None  # the second push was not executed: no move predicted
