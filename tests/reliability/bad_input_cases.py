"""The bad-input cases: requests that the stack must refuse (success false, a short clear message, quickly, nothing
moving and nothing changing). A case marked `quick` also runs in the short form. Limits of grasp_target cases that
test another field are kept small (one action, 20 s) so that a request accepted by mistake stays short. A case with
a `field` must name it in its answer (the target forms: "point: ...", "mask: ...", "target and point: ...")."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .client import CENTRE_GRASP

INF, NAN = math.inf, math.nan
INT_MAX, INT_MIN = 2**31 - 1, -(2**31)
CENTRE = CENTRE_GRASP
ECHO_BOUND = 300  # characters: the longest answer to a request holding a huge string (it is repeated cut, if at all)


@dataclass(frozen=True)
class Case:
    service: str  # grasp_target | action | execute_primitive | reset_scene
    name: str
    args: dict[str, Any] = field(default_factory=dict)
    quick: bool = False
    expect_refused: bool = True
    max_message: int | None = None  # a tighter bound on the answer's length than --max-message (None: that one)
    field: str = ""  # the request field the answer must name ("": not checked)


@dataclass(frozen=True)
class PointArg:
    """The `point` of a GraspTarget / Infer request: a frame and a position in it (m); stamp 0 (latest transform)."""

    frame: str
    xyz: tuple[float, float, float]


@dataclass(frozen=True)
class MaskArg:
    """The `mask` of a GraspTarget / Infer request, built by the probe against the colour camera's camera_info: a
    square of 255 at the image centre (none when not `marked`), `size_delta` px added to the camera's (width, height),
    stamped with the ROS time of the call (0 when not `stamped`), frame "" (the camera's)."""

    encoding: str = "mono8"
    size_delta: tuple[int, int] = (0, 0)
    marked: bool = True
    stamped: bool = True


def grasp_cases(service: str) -> list[Case]:
    """grasp_target (service or action): bad target strings, then bad numbers (timeout, max_actions, ...)."""
    one = {"max_actions": 1}
    short = {"timeout": 20.0}
    rows: list[tuple[str, dict[str, Any], bool]] = [
        ("unknown colour", {"target": "mauve"}, True),
        ("huge target (100 000 chars)", {"target": "x" * 100_000}, True),
        ("unicode target", {"target": "gr\u00fcn \U0001f49a \u7eff"}, False),
        ("NUL in target", {"target": "green\x00red"}, False),
        ("shell text as target", {"target": "green'; rm -rf / #"}, False),
        ("timeout -1", {"timeout": -1.0, **one}, False),
        ("timeout NaN", {"timeout": NAN, **one}, True),
        ("timeout +inf", {"timeout": INF, **one}, False),
        ("timeout -inf", {"timeout": -INF, **one}, False),
        ("timeout 1e308", {"timeout": 1e308, **one}, False),
        ("max_actions -1", {"max_actions": -1, **short}, True),
        ("max_actions INT_MAX", {"max_actions": INT_MAX, **short}, False),
        ("max_actions INT_MIN", {"max_actions": INT_MIN, **short}, False),
        ("max_failed_grasps -1", {"max_failed_grasps": -1, **one}, False),
        ("max_failed_grasps INT_MAX", {"max_failed_grasps": INT_MAX, **one}, False),
    ]
    in_quick_action = ("unknown colour", "timeout NaN")
    cases = [Case(service, name, {"target": "green", **args},
                  quick if service == "grasp_target" else name in in_quick_action,
                  max_message=ECHO_BOUND if name.startswith("huge") else None)
             for name, args, quick in rows]
    # "" means green (GraspTarget.srv): accepted, one action at most
    cases.append(Case(service, "empty target means green", {"target": "", "max_actions": 1}, False, False))
    return cases


BARE_TABLE = (-0.18, 0.18, 0.0)  # world, m: inside the workspace, no object of the baseline scene near it
OUTSIDE = (0.5, 0.0, 0.0)        # world, m: beyond the workspace's +x border (0.224 m)


def target_form_cases(service: str) -> list[Case]:
    """grasp_target or infer: the target as a point or a mask (GraspTarget.srv), each refused naming its field."""
    centre = PointArg("world", (0.0, 0.0, 0.0))
    rows: list[tuple[str, dict[str, Any], str, bool]] = [
        ("target and point set", {"target": "red", "point": centre}, "target and point", True),
        ("point and mask set", {"target": "", "point": centre, "mask": MaskArg()}, "point and mask", False),
        ("point outside the workspace", {"point": PointArg("world", OUTSIDE)}, "point", True),
        ("point on bare table", {"point": PointArg("world", BARE_TABLE)}, "point", True),
        ("point in an unknown frame", {"point": PointArg("nowhere", (0.0, 0.0, 0.0))}, "point", False),
        ("huge point frame (10 000 chars)", {"point": PointArg("f" * 10_000, (0.0, 0.0, 0.0))}, "point", True),
        ("mask encoding rgb8", {"mask": MaskArg(encoding="rgb8")}, "mask", True),
        ("mask 1 px narrower than the camera", {"mask": MaskArg(size_delta=(-1, 0))}, "mask", False),
        ("mask all zeros", {"mask": MaskArg(marked=False)}, "mask", True),
        ("mask stamp zero", {"mask": MaskArg(stamped=False)}, "mask", False),
    ]
    limits = {"max_actions": 1, "timeout": 20.0} if service == "grasp_target" else {}
    in_quick_infer = ("target and point set", "mask encoding rgb8")
    return [Case(service, name, {"target": "", **limits, **args},
                 quick if service == "grasp_target" else name in in_quick_infer,
                 max_message=ECHO_BOUND if name.startswith("huge") else None, field=fld)
            for name, args, fld, quick in rows]


def primitive_cases() -> list[Case]:
    """execute_primitive: non-finite and out-of-workspace positions, bad frames, arms, primitives and timeouts."""
    def c(name: str, quick: bool = False, **kw: Any) -> Case:
        args = {"primitive": 1, "position": CENTRE, "frame": "world", "yaw": 0.0, "arm": "", "timeout": 0.0}
        args.update(kw)
        return Case("execute_primitive", name, args, quick, max_message=ECHO_BOUND if name.startswith("huge") else None)

    return [
        c("x NaN", True, position=(NAN, 0.0, 0.02)),
        c("z +inf", position=(0.0, 0.0, INF)),
        c("y -inf", position=(0.0, -INF, 0.02)),
        c("x 0.5 m (outside)", True, position=(0.5, 0.0, 0.02)),
        c("z -0.05 m (below the table)", position=(0.0, 0.0, -0.05)),
        c("z 1.0 m (above the box)", position=(0.0, 0.0, 1.0)),
        c("x 1e6 m", position=(1e6, 0.0, 0.02)),
        c("y 1e308 m", position=(0.0, 1e308, 0.02)),
        c("push from outside", primitive=0, position=(0.0, 0.3, 0.02)),
        c("yaw NaN", yaw=NAN),
        c("yaw +inf", yaw=INF),
        c("empty frame", frame=""),
        c("unknown frame", True, frame="nowhere"),
        c("frame '../world'", frame="../world"),
        c("unicode frame", frame="w\u00f6rld"),
        c("huge frame (10 000 chars)", True, frame="f" * 10_000),
        c("unknown arm", True, arm="middle"),
        c("arm 'LEFT'", arm="LEFT"),
        c("arm 'left ' (trailing space)", arm="left "),
        c("huge arm name (10 000 chars)", True, arm="a" * 10_000),
        c("primitive 2", primitive=2),
        c("primitive 255", primitive=255),
        c("timeout NaN", True, timeout=NAN),
        c("timeout +inf", True, timeout=INF),
        c("timeout -inf", timeout=-INF),
        c("timeout -1", True, timeout=-1.0),
        c("timeout 1e308", timeout=1e308),
        c("timeout 1e-9 (shorter than any motion)", timeout=1e-9),
    ]


def reset_cases(outside_scene: Path) -> list[Case]:
    """reset_scene: unknown names, paths outside the scene folders, absurd counts and seeds. `outside_scene` is a
    valid scene file in a folder the simulator does not serve scenes from."""
    up = "../" * 16
    def c(name: str, scene: str, quick: bool = False, num: int = 0, seed: int = 0) -> Case:
        return Case("reset_scene", name, {"scene": scene, "num_objects": num, "seed": seed}, quick,
                    max_message=ECHO_BOUND if name.startswith("huge") else None)

    return [
        c("unknown scene", "no/such/scene", True),
        c("empty scene", ""),
        c("path traversal to /etc/passwd", up + "etc/passwd", True),
        c("absolute /proc/self/environ", "/proc/self/environ"),
        c("traversal to a valid scene outside the scene folders", up + str(outside_scene).lstrip("/"), True),
        c("absolute path of a valid scene outside the scene folders", str(outside_scene)),
        c("huge name (100 000 chars)", "s" * 100_000, True),
        c("unicode name", "packed/c\u00e4se01\U0001f4a5"),
        c("NUL in name", "packed/case01\x00.yaml"),
        c("random, 100 000 objects", "random", True, num=100_000, seed=1_000_000),
        c("random, INT_MAX objects", "random", num=INT_MAX, seed=1_000_000),
        c("random, -5 objects", "random", num=-5, seed=1_000_000),
        c("random, 0 objects", "random", num=0, seed=1_000_000),
        c("random, seed -1", "random", True, num=5, seed=-1),
        c("random, seed INT_MIN", "random", num=5, seed=INT_MIN),
        c("random-15 with num_objects 3", "random-15", num=3, seed=1_000_000),
    ]
