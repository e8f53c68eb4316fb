"""Helpers shared by the integration test nodes (rt_*.py): bounded waits on services and topics of the stack."""

from __future__ import annotations

import threading
import time
from pathlib import Path

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


def write_robot_bag(path: Path, seconds: float = 6.0) -> None:
    """Camera + per-arm joint states of packed/case01, stamped with sim time, as the drivers would publish them
    (robot.launch's inputs), written to the bag `path` from the ROS-free simulator core."""
    import rosbag
    from sensor_msgs.msg import JointState

    from pg_sim.ros import ros_conversions as conv
    from pg_sim.runtime.runtime_types import RuntimeConfig
    from pg_sim.runtime.sim_runtime import SimRuntime

    config = RuntimeConfig(scene="packed/case01", camera_rate=2.0, idle_real_time_factor=0.0)
    with SimRuntime(config) as sim, rosbag.Bag(str(path), "w") as bag:
        frame = sim.geometry.camera_frame
        t_end = sim.sim_time + seconds
        while sim.sim_time < t_end:
            out = sim.step()
            if out.joint_state is not None:
                msg = conv.joint_state(out.joint_state)
                for arm in ("left", "right"):
                    part = JointState(header=msg.header)
                    for i, name in enumerate(msg.name):
                        if name.startswith(arm + "_"):
                            part.name.append(name)
                            part.position.append(msg.position[i])
                            part.velocity.append(msg.velocity[i] if msg.velocity else 0.0)
                    bag.write(f"/{arm}/joint_states", part, msg.header.stamp)
            if out.camera is not None:
                for topic, m in conv.camera_messages(out.camera, sim.geometry.camera, frame).items():
                    bag.write(f"/camera/{topic}", m, m.header.stamp)
