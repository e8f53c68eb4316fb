"""`make demo`: the ROS stack end to end, headless.

Starts `roslaunch launch/sim.launch` with its own ROS master on a free port, waits for /pg/grasp_target, saves the
camera image before, calls the service for the target, saves the image after, prints the outcome (success, grasps,
pushes, sim and wall time), shuts everything down and exits 0 only when the target was grasped. Every wait has a
timeout. Run it through scripts/demo.sh (it sources the catkin devel space first).
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

from pg_core.resources import project_root


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def save_camera(path: Path, timeout_s: float) -> None:
    import cv2
    import numpy as np
    import rospy
    from sensor_msgs.msg import Image

    msg = rospy.wait_for_message("/camera/color/image_raw", Image, timeout=timeout_s)
    rgb = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.width, 3)
    cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    print(f"[demo] saved {path}")


def stop(proc: subprocess.Popen, timeout_s: float = 20.0) -> None:
    """SIGINT to the launch (nodes shut down, bags close), then SIGTERM/SIGKILL if it lingers."""
    if proc.poll() is not None:
        return
    os.killpg(proc.pid, signal.SIGINT)
    try:
        proc.wait(timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(5.0)


def run(args: argparse.Namespace) -> int:
    port = free_port()
    os.environ["ROS_MASTER_URI"] = f"http://127.0.0.1:{port}"
    args.out.mkdir(parents=True, exist_ok=True)
    log = open(args.out / "roslaunch.log", "w")
    cmd = ["roslaunch", "-p", str(port), str(project_root() / "launch" / "sim.launch"), f"scene:={args.scene}",
           f"policy:={args.policy}", f"seed:={args.seed}"]
    print(f"[demo] policy: {args.policy}")
    print(f"[demo] {' '.join(cmd)}  (log: {args.out / 'roslaunch.log'})")
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        import rosgraph
        import rospy
        from pg_msgs.srv import GraspTarget

        t0 = time.monotonic()
        while not rosgraph.Master("/pg_demo").is_online():  # the master comes up with roslaunch
            if time.monotonic() - t0 > args.startup_timeout or proc.poll() is not None:
                raise RuntimeError("roslaunch did not bring up a ROS master")
            time.sleep(0.3)
        rospy.init_node("pg_demo", anonymous=True, disable_signals=True)
        rospy.wait_for_service("/pg/grasp_target", timeout=args.startup_timeout)
        save_camera(args.out / "before.png", 30.0)
        call = rospy.ServiceProxy("/pg/grasp_target", GraspTarget)
        wall0 = time.monotonic()
        res = call(target=args.target, timeout=args.timeout)
        wall = time.monotonic() - wall0
        save_camera(args.out / "after.png", 30.0)
        print(f"[demo] {args.scene}, target {args.target}: {'SUCCESS' if res.success else 'FAILED'}: {res.message}")
        print(f"[demo] grasps {res.grasps}, pushes {res.pushes}, sim time {res.duration:.1f} s, "
              f"wall time {wall:.1f} s")
        return 0 if res.success else 1
    except Exception as exc:  # noqa: BLE001 (report any failure, then shut down)
        print(f"[demo] error: {exc} (see {args.out / 'roslaunch.log'})", file=sys.stderr)
        return 1
    finally:
        stop(proc)
        log.close()
        print("[demo] shut down")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="scripts/demo.sh", description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="packed/case01", help="scene name, YAML file, or random (default packed/case01)")
    ap.add_argument("--seed", type=int, default=1_000_000, help="seed of random scenes")
    ap.add_argument("--policy", default="lite",
                    help="policy name (heuristic, random), shipped model folder name or model directory (default lite)")
    ap.add_argument("--target", default="green", help="target colour (default green)")
    ap.add_argument("--timeout", type=float, default=600.0, help="wall seconds for the grasp_target call")
    ap.add_argument("--startup-timeout", type=float, default=120.0, help="wall seconds for the stack to come up")
    ap.add_argument("--out", type=Path, default=project_root() / "demo_out",
                    help="folder for before/after PNGs and the log")
    return run(ap.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
