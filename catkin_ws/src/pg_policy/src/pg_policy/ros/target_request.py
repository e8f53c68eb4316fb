"""The checks of a request's target (pg_msgs GraspTarget / Infer: `target`, `point`, `mask`), no rospy: plain values
in, a pg_policy.target_loop.target_spec spec or a ValueError out whose message starts with the request field at
fault ("point: ...", "mask: ...", "target and point: ...").

Forms: `target` (a colour name; "" = "green" when nothing else is set), `point` (set when its header.frame_id is
non-empty) and `mask` (set when its data is non-empty); exactly one may be set. A point, transformed to `world`
(metres), must lie in the workspace box in x and y and within Z_TOLERANCE_M of its height range; whether it lies on
an object is known on the call's first heightmap (the loop's TargetRefused, reported as the `point` field's). A mask
is a mono8 image (nonzero = the target) of the colour camera's size, stamped within the node's skew of the
heightmap it is projected with (pg_policy.perception.mask_projection), and must mark some pixel and some cell.
"""

from __future__ import annotations

import math

import numpy as np

from pg_policy.target_loop.target_spec import MaskTarget, PointTarget

MASK_ENCODING = "mono8"
Z_TOLERANCE_M = 0.02  # how far below / above the workspace's z range a point may lie (a click on the table top)
REFUSED = "invalid request, nothing moved"


def refusal(why: str) -> str:
    """The answer's message for a refused request: REFUSED plus the reason (which starts with the field)."""
    return f"{REFUSED}: {why}"


def request_form(target: str, point_frame: str, mask_bytes: int) -> str:
    """"target", "point" or "mask": the one form the request sets (none set: "target", i.e. the default colour).
    ValueError naming the fields when more than one is set."""
    named = [name for name, on in (("target", bool(target)), ("point", bool(point_frame)), ("mask", mask_bytes > 0))
             if on]
    if len(named) > 1:
        raise ValueError(f"{' and '.join(named)}: set exactly one of target (colour name), point "
                         "(header.frame_id non-empty) and mask (data non-empty)")
    return named[0] if named else "target"


def point_target(xyz: tuple[float, float, float], workspace: np.ndarray) -> PointTarget:
    """The PointTarget of point `xyz` (metres in `world`); `workspace`: (3, 2) box [[xmin, xmax], [ymin, ymax],
    [zmin, zmax]]. ValueError naming `point` for a non-finite point or one outside the box (z: Z_TOLERANCE_M)."""
    x, y, z = (float(v) for v in xyz)
    if not all(math.isfinite(v) for v in (x, y, z)):
        raise ValueError(f"point: ({x}, {y}, {z}) in world is not finite")
    b = np.asarray(workspace, dtype=np.float64)
    tol = np.array([0.0, 0.0, Z_TOLERANCE_M])
    p = np.array([x, y, z])
    if np.any(p < b[:, 0] - tol) or np.any(p > b[:, 1] + tol):
        raise ValueError(f"point: ({x:.3f}, {y:.3f}, {z:.3f}) m in world lies outside the workspace "
                         f"x [{b[0, 0]:g}, {b[0, 1]:g}], y [{b[1, 0]:g}, {b[1, 1]:g}], z [{b[2, 0]:g}, {b[2, 1]:g}] m")
    return PointTarget(x, y)


def mask_image(encoding: str, width: int, height: int, step: int, data: bytes,
               camera_size: tuple[int, int] | None) -> np.ndarray:
    """(height, width) uint8 image of a sensor_msgs/Image mask. `camera_size`: the colour camera's (width, height)
    px (None: unknown, refused). ValueError naming `mask` for another encoding than mono8, another size than the
    camera's, too little data for its rows, or no nonzero pixel."""
    if encoding != MASK_ENCODING:
        raise ValueError(f"mask: encoding must be {MASK_ENCODING}, got {encoding!r}")
    if camera_size is None:
        raise ValueError("mask: the colour camera's size is unknown (no camera_info received)")
    if (int(width), int(height)) != tuple(camera_size):
        raise ValueError(f"mask: size {width} x {height} differs from the colour camera's "
                         f"{camera_size[0]} x {camera_size[1]}")
    if step < width or len(data) < step * height:
        raise ValueError(f"mask: {len(data)} bytes with step {step} do not hold {height} rows of {width} pixels")
    image = np.frombuffer(bytes(data), np.uint8, count=step * height).reshape(height, step)[:, :width]
    if not image.any():
        raise ValueError("mask: every pixel is zero (it marks no target)")
    return image


def check_skew(mask_stamp: float, heightmap_stamp: float, max_skew_s: float) -> None:
    """ValueError naming `mask` for a zero stamp or one more than `max_skew_s` seconds (ROS time) from the
    heightmap's."""
    if mask_stamp <= 0.0:
        raise ValueError("mask: header.stamp is zero (stamp it with the colour image it was computed on)")
    skew = heightmap_stamp - mask_stamp
    if abs(skew) > max_skew_s:
        raise ValueError(f"mask: stamped {abs(skew):.2f} s {'before' if skew > 0 else 'after'} the heightmap "
                         f"(at most {max_skew_s:g} s apart)")


def mask_target(grid: np.ndarray) -> MaskTarget:
    """The MaskTarget of a projected (H, W) bool grid mask; ValueError naming `mask` when it marks no cell."""
    if not np.asarray(grid).any():
        raise ValueError("mask: it covers no heightmap cell (no valid cell projects into its set pixels)")
    return MaskTarget(np.asarray(grid, dtype=bool))


def first_view_field(form: str, why: str) -> str:
    """The reason of a point or mask refused on the call's first heightmap, led by its request field."""
    return f"{form}: {why}"
