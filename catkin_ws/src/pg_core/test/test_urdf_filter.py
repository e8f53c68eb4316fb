"""pg_core.urdf_filter on the shipped URDF."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from pg_core.geometry import load
from pg_core.urdf_filter import drop_links


def test_dropping_the_camera_link_drops_its_subtree_only():
    text = load().robot.urdf.read_text()
    out = ET.fromstring(drop_links(text, ["camera_link"]))
    links = {link.get("name") for link in out.findall("link")}
    assert "camera_link" not in links and "camera_color_optical_frame" not in links
    assert {"world", "camera_mount_link", "left_tool0", "right_gripper_tcp"} <= links
    for joint in out.findall("joint"):
        assert joint.find("parent").get("link") in links and joint.find("child").get("link") in links


def test_unknown_link_is_an_error():
    with pytest.raises(KeyError, match="no link"):
        drop_links(load().robot.urdf.read_text(), ["no_such_link"])
