"""Merges the joint states of several drivers (one ur_robot_driver per arm, grippers) into /joint_states.

Private parameters: ~sources (list of JointState topics, default ["/left/joint_states", "/right/joint_states"]),
~rate (Hz, default 100), ~max_age (s, default 0.5: a source silent for longer is left out and warned about).
Each output message holds the latest position/velocity/effort of every joint seen, stamped with the newest source
stamp, so robot_state_publisher and the primitive controller see one consistent topic, as in simulation.
"""

from __future__ import annotations

import threading

import rospy
from sensor_msgs.msg import JointState


class JointStateMerger:
    def __init__(self, sources: list[str], max_age: float) -> None:
        self.lock_ = threading.Lock()
        self.latest_: dict[str, JointState] = {}
        self.max_age_ = max_age
        self.pub_ = rospy.Publisher("/joint_states", JointState, queue_size=10)
        self.subs_ = [rospy.Subscriber(t, JointState, self._on_msg, callback_args=t, queue_size=10) for t in sources]

    def _on_msg(self, msg: JointState, topic: str) -> None:
        with self.lock_:
            self.latest_[topic] = msg

    def publish(self) -> None:
        now = rospy.Time.now()
        out = JointState()
        with self.lock_:
            msgs = dict(self.latest_)
        for topic, msg in msgs.items():
            if (now - msg.header.stamp).to_sec() > self.max_age_:
                rospy.logwarn_throttle(5.0, f"joint states on {topic} are older than {self.max_age_} s")
                continue
            out.name += msg.name
            out.position += msg.position
            out.velocity += msg.velocity if len(msg.velocity) == len(msg.name) else [0.0] * len(msg.name)
            out.effort += msg.effort if len(msg.effort) == len(msg.name) else [0.0] * len(msg.name)
            out.header.stamp = max(out.header.stamp, msg.header.stamp)
        if out.name:
            self.pub_.publish(out)


def main() -> None:
    rospy.init_node("joint_state_merger")
    merger = JointStateMerger(list(rospy.get_param("~sources", ["/left/joint_states", "/right/joint_states"])),
                              float(rospy.get_param("~max_age", 0.5)))
    rate = rospy.Rate(float(rospy.get_param("~rate", 100.0)))
    while not rospy.is_shutdown():
        merger.publish()
        try:
            rate.sleep()
        except rospy.ROSTimeMovedBackwardsException:
            continue
        except rospy.ROSInterruptException:
            break
