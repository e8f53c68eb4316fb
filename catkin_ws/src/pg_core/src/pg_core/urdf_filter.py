"""Print the robot URDF without some links (and the joints attached to them), e.g. the camera frames on a real robot
whose camera pose comes from a calibration instead of the URDF:

    python3 -m pg_core.urdf_filter --drop camera_link,camera_color_optical_frame
    catkin_ws/src/pg_description/urdf/pushgrasp.urdf

(launch/robot.launch uses it for robot_description). Exit status 2 when a named link is not in the file.
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence


def drop_links(urdf_text: str, links: Iterable[str]) -> str:
    """The URDF without `links`, their child subtrees, and every joint touching them; KeyError for unknown links."""
    root = ET.fromstring(urdf_text)
    names = {link.get("name") for link in root.findall("link")}
    drop = set(links)
    missing = drop - names
    if missing:
        raise KeyError(f"no link(s) {', '.join(sorted(missing))} in the URDF")
    joints = root.findall("joint")
    grown = True
    while grown:  # children of dropped links go too
        before = len(drop)
        drop |= {j.find("child").get("link") for j in joints if j.find("parent").get("link") in drop}
        grown = len(drop) > before
    for joint in joints:
        if joint.find("parent").get("link") in drop or joint.find("child").get("link") in drop:
            root.remove(joint)
    for link in root.findall("link"):
        if link.get("name") in drop:
            root.remove(link)
    return ET.tostring(root, encoding="unicode")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python3 -m pg_core.urdf_filter", description=__doc__.split("\n\n")[0])
    parser.add_argument("urdf", help="URDF file")
    parser.add_argument("--drop", required=True, help="comma-separated link names to remove (with their subtrees)")
    args = parser.parse_args(argv)
    try:
        with open(args.urdf, encoding="utf-8") as f:
            print(drop_links(f.read(), [n for n in args.drop.split(",") if n]))
    except (KeyError, OSError, ET.ParseError) as exc:
        print(f"urdf_filter: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
