"""The sim node's log calls pin nothing of its main loop (pg_sim.ros.sim_node.log): rosgraph's logger reads the
calling frame's f_locals, which on Python 3.11 leaves a snapshot of the caller's locals on a frame that lives on."""

from __future__ import annotations

import sys
import weakref

import pytest
import rospy

from pg_sim.ros import sim_node


class _Capture:  # stands in for a camera capture held by the loop
    pass


def _loop_body(log_directly: bool) -> bool:
    """A long-lived frame that holds a capture, logs, then drops it; returns whether the capture is still alive."""
    capture = _Capture()
    alive = weakref.ref(capture)
    if log_directly:
        rospy.logwarn("pg_sim test: logged from the frame that holds the capture")
    else:
        sim_node.log("logwarn", "pg_sim test: logged through sim_node.log")
    del capture
    return alive() is not None


def test_logging_through_the_helper_frees_the_loops_locals():
    assert not _loop_body(log_directly=False)


def test_logging_from_the_frame_itself_pins_its_locals():
    """The mechanism the helper avoids, so that this test fails if rospy or Python stop behaving this way (the
    helper would then be unnecessary, not wrong)."""
    if sys.version_info >= (3, 13):
        pytest.skip("PEP 667: f_locals is a write-through proxy, no snapshot")
    assert _loop_body(log_directly=True)
