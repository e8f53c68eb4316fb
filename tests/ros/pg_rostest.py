"""Helpers shared by the integration test nodes (rt_*.py): bounded waits on services and topics of the stack."""

from __future__ import annotations

import threading
import time

import rospy

STACK_TIMEOUT_S = 180.0  # wall seconds for the whole stack to come up on a slow machine


def wait_service(name: str, timeout_s: float = STACK_TIMEOUT_S) -> None:
    rospy.wait_for_service(name, timeout=timeout_s)


def scene_state(timeout_s: float = 30.0):
    from pg_msgs.msg import SceneState

    return rospy.wait_for_message("/pg_sim/scene_state", SceneState, timeout=timeout_s)


def fresh_scene_state(after: float, timeout_s: float = 30.0):
    """The first /pg_sim/scene_state stamped after `after` (ROS time, s)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = scene_state(timeout_s)
        if msg.header.stamp.to_sec() > after:
            return msg
        time.sleep(0.2)
    raise TimeoutError(f"no /pg_sim/scene_state after t={after:.2f} within {timeout_s} s")


class Call(threading.Thread):
    """A service call in the background: .result or .error once joined."""

    def __init__(self, proxy, **kwargs) -> None:
        super().__init__(daemon=True)
        self.proxy, self.kwargs, self.result, self.error = proxy, kwargs, None, None

    def run(self) -> None:
        try:
            self.result = self.proxy(**self.kwargs)
        except Exception as exc:  # noqa: BLE001 (reported by the test)
            self.error = exc
