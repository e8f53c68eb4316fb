"""Conversions between pg_policy's decisions and ROS messages (no rospy: message classes only); heightmap messages
are pg_conversions.heightmap_msg's.

- pg_policy.target_loop.loop_types.ActionRecord -> pg_msgs/Decision.
- Q map / decision overlay image (rgb8, one pixel per heightmap cell, row 0 = y_min) for /pg/q_map.
- visualization_msgs/MarkerArray of the chosen action and the target outline in `world`.
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np
from pg_msgs.msg import Decision as DecisionMsg

from pg_core.heightmap import Heightmap, pixel_to_world

WORLD = "world"


# -- decisions ----------------------------------------------------------------------------------------------------
def decision_msg(rec: Any, stamp: Any) -> Any:
    """pg_policy.target_loop.loop_types.ActionRecord -> pg_msgs/Decision stamped `stamp` (rospy.Time)."""
    import rospy
    from geometry_msgs.msg import Point

    d, ex = rec.decision, rec.execution
    msg = DecisionMsg()
    msg.header.frame_id, msg.header.stamp = WORLD, stamp
    msg.heightmap_stamp = rospy.Time.from_sec(rec.heightmap_stamp)
    msg.target, msg.policy = rec.target, rec.policy
    msg.episode, msg.action_index = rec.episode, rec.index
    msg.primitive = DecisionMsg.GRASP if d.primitive == "grasp" else DecisionMsg.PUSH
    msg.row, msg.col, msg.rotation, msg.yaw = int(d.row), int(d.col), int(d.rotation), float(d.yaw)
    msg.q_value, msg.grasp_q, msg.grasp_threshold = float(d.q), float(d.grasp_q), float(rec.grasp_threshold)
    msg.position = Point(float(d.x), float(d.y), float(d.z))
    msg.target_pixels = int(rec.target_pixels)
    if ex is not None:
        msg.executed, msg.success, msg.arm, msg.grasped = True, ex.success, ex.arm, ex.grasped
        msg.target_grasped, msg.duration, msg.message = rec.target_grasped, ex.duration, ex.message
    return msg


def primitive_name(msg: Any) -> str:
    """"grasp" / "push" of a pg_msgs/Decision."""
    return "grasp" if msg.primitive == msg.GRASP else "push"


# -- visualisation ------------------------------------------------------------------------------------------------
def overlay(hm: Heightmap, target: np.ndarray, rec: Any, q: dict[str, np.ndarray]) -> np.ndarray:
    """(H, W, 3) uint8 RGB: the chosen primitive's Q map (max over rotations, jet) when the policy has Q maps, else
    the colour heightmap; target outline in white, the action as an arrow (push) or a finger line (grasp)."""
    d = rec.decision
    maps = q.get(d.primitive)
    qmax = np.asarray(maps).max(axis=0) if maps is not None else None
    known = np.isfinite(qmax) if qmax is not None else None
    if qmax is not None and known.any():  # cells without Q (-inf outside the q_window regions): dimmed heightmap
        lo, hi = float(qmax[known].min()), float(qmax[known].max())
        scaled = np.where(known, qmax - lo, 0.0) / (hi - lo) * 255 if hi > lo else np.zeros_like(qmax)
        img = cv2.cvtColor(cv2.applyColorMap(scaled.astype(np.uint8), cv2.COLORMAP_JET), cv2.COLOR_BGR2RGB)
        img[~known] = hm.color[~known] // 3
    else:
        img = hm.color.copy()
    contours, _ = cv2.findContours(target.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    cv2.drawContours(img, contours, -1, (255, 255, 255), 1)
    dx, dy = 12 * math.cos(d.yaw), 12 * math.sin(d.yaw)  # cols = x, rows = y
    c, r = float(d.col), float(d.row)
    if d.primitive == "grasp":
        cv2.line(img, (round(c - dx), round(r - dy)), (round(c + dx), round(r + dy)), (255, 0, 0), 2)
    else:
        cv2.arrowedLine(img, (round(c), round(r)), (round(c + 2 * dx), round(r + 2 * dy)), (0, 255, 255), 2)
    return img


def markers(hm: Heightmap, target: np.ndarray, rec: Any, stamp: Any) -> Any:
    """MarkerArray in `world`: the action (arrow along yaw; red grasp, cyan push) and the target outline."""
    from geometry_msgs.msg import Point
    from visualization_msgs.msg import Marker, MarkerArray

    d = rec.decision
    arrow = Marker(type=Marker.ARROW, action=Marker.ADD, ns="pg_action", id=0)
    arrow.header.frame_id, arrow.header.stamp = WORLD, stamp
    length = 0.13 if d.primitive == "push" else 0.06
    start = Point(d.x, d.y, d.z + 0.005) if d.primitive == "push" else Point(
        d.x - length / 2 * math.cos(d.yaw), d.y - length / 2 * math.sin(d.yaw), d.z + 0.005)
    arrow.points = [start, Point(start.x + length * math.cos(d.yaw), start.y + length * math.sin(d.yaw), start.z)]
    arrow.scale.x, arrow.scale.y, arrow.scale.z = 0.008, 0.016, 0.02
    arrow.color.r, arrow.color.g, arrow.color.b, arrow.color.a = (1.0, 0.1, 0.1, 1.0) if d.primitive == "grasp" \
        else (0.1, 0.9, 0.9, 1.0)
    outline = Marker(type=Marker.LINE_LIST, action=Marker.ADD, ns="pg_target", id=0)
    outline.header = arrow.header
    outline.scale.x = 0.003
    outline.color.r, outline.color.g, outline.color.b, outline.color.a = 1.0, 1.0, 1.0, 1.0
    contours, _ = cv2.findContours(target.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    res, b = hm.resolution, hm.bounds
    for contour in contours:
        pts = contour[:, 0, :]
        for (c0, r0), (c1, r1) in zip(pts, np.roll(pts, -1, axis=0), strict=True):
            for c, r in ((c0, r0), (c1, r1)):
                z = float(hm.height[r, c]) + b[2, 0] + 0.002
                outline.points.append(Point(*pixel_to_world(r, c, b, res), z))
    return MarkerArray(markers=[arrow, outline])
