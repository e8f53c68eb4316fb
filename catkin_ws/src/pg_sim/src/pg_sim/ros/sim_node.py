"""pg_sim sim node (`rosrun pg_sim sim_node`, the entry point nodes/sim_node calls `main`): the PyBullet cell
speaking the real robot's and camera's topics (DESIGN.md section 5).

Publishes /clock (sim time; run with /use_sim_time true), /joint_states, the RealSense-named camera topics under
~camera_ns, /pg_sim/scene_state (latched), /pg_sim/markers and /pg_sim/scene_resets (std_msgs/UInt32, latched: the
number of successful resets since start-up, 0 for the initial scene, published before the reset is answered);
subscribes /<arm>/scaled_pos_joint_traj_controller/command and /<arm>/gripper/command; serves /pg_sim/reset_scene
(pg_sim.runtime.sim_runtime: answered once the scene is at rest; refused while an arm executes a trajectory).
TF comes from robot_state_publisher (same URDF).
Threading: callbacks only enqueue into the runtime; this main thread owns PyBullet and publishes.
Params: ~scene ("packed/case01", a YAML path, "random" or "random-N"), ~num_objects (10), ~seed (0), ~gui (false),
~camera_rate (2 Hz sim), ~joint_state_rate (50), ~clock_rate (100), ~scene_state_rate (2),
~real_time_factor (0: as fast as possible while something moves), ~idle_real_time_factor (1: real time when idle),
~trajectory_topic ("/{arm}/scaled_pos_joint_traj_controller/command"), ~gripper_topic ("/{arm}/gripper/command"),
~camera_ns ("/camera"), ~reset_timeout (60 s wall), ~rest_timeout (3 s sim: damping of objects still moving after a
reset's settling).
Scene limits (every scene file, the initial one included; pg_sim.scenes.scene_limits): ~max_objects (40),
~max_object_size (0.3 m, largest bounding-box extent), ~min_object_size (0.002 m), ~max_pose_distance (0.5 m outside
the workspace box). ~scene_folders ([]): folders added to those that /pg_sim/reset_scene may name scene and mesh files
in (default: the scene folders, $ROS_HOME/pg_sim/scenes, the pushgrasp cache and pybullet_data for meshes;
pg_sim.scenes.scene_folders).
~sensor ("perfect"): the camera's sensor profile (pg_sim.world.sensor_model: perfect, d435, d415 or a YAML path),
seeded with ~seed; an unknown one stops the node at start-up with the known ones listed.
~calibration_board (""): an arm name ("left", "right") mounts the printed ChArUco board
(pg_core.charuco_board.DEFAULT_BOARD) on that arm's tool, as launch/calibrate.launch needs it; visual only.
"""

from __future__ import annotations

import threading

import rospy
from pg_msgs.msg import SceneState
from pg_msgs.srv import ResetScene
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image, JointState, PointCloud2
from std_msgs.msg import Float64, UInt32
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from pg_core.heap_trim import cap_arenas, map_large_blocks
from pg_core.user_text import cut
from pg_sim.ros import ros_conversions as conv
from pg_sim.runtime.runtime_types import RuntimeConfig
from pg_sim.runtime.sim_runtime import SimRuntime
from pg_sim.scenes.scene_limits import SceneLimits
from pg_sim.world.sensor_model import PERFECT, make_sensor

CAMERA_TOPICS = {"color/image_raw": Image, "color/camera_info": CameraInfo,
                 "aligned_depth_to_color/image_raw": Image, "aligned_depth_to_color/camera_info": CameraInfo,
                 "depth/color/points": PointCloud2}


def log(level: str, text: str) -> None:
    """rospy's `level` ("loginfo", "logwarn", ...) of `text`. The node logs through this function, never from
    main()'s loop: rosgraph's logger reads its caller frame's f_locals to name the caller's class, and on Python
    3.11 that leaves a snapshot of every local on the frame, which for main() pins that moment's camera
    capture and messages (about 13 MB) until the next log call."""
    getattr(rospy, level)(text)


def limits() -> SceneLimits:
    """The scene limits of the node's parameters; raises ValueError for values that contradict each other."""
    d = SceneLimits()
    return SceneLimits(
        max_objects=int(rospy.get_param("~max_objects", d.max_objects)),
        max_object_size=float(rospy.get_param("~max_object_size", d.max_object_size)),
        min_object_size=float(rospy.get_param("~min_object_size", d.min_object_size)),
        max_pose_distance=float(rospy.get_param("~max_pose_distance", d.max_pose_distance)),
    )


def scene_folders() -> tuple[str, ...]:
    """~scene_folders: a list of folders (a single string is one folder); raises ValueError otherwise."""
    value = rospy.get_param("~scene_folders", [])
    if isinstance(value, str):
        value = [value] if value else []
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ValueError(f"~scene_folders must be a list of folder paths, got {cut(value)}")
    return tuple(value)


def config() -> RuntimeConfig:
    d = RuntimeConfig()
    return RuntimeConfig(
        scene=str(rospy.get_param("~scene", d.scene)), seed=int(rospy.get_param("~seed", d.seed)),
        num_objects=int(rospy.get_param("~num_objects", d.num_objects)), gui=bool(rospy.get_param("~gui", d.gui)),
        camera_rate=float(rospy.get_param("~camera_rate", d.camera_rate)),
        joint_state_rate=float(rospy.get_param("~joint_state_rate", d.joint_state_rate)),
        clock_rate=float(rospy.get_param("~clock_rate", d.clock_rate)),
        scene_state_rate=float(rospy.get_param("~scene_state_rate", d.scene_state_rate)),
        real_time_factor=float(rospy.get_param("~real_time_factor", d.real_time_factor)),
        idle_real_time_factor=float(rospy.get_param("~idle_real_time_factor", d.idle_real_time_factor)),
        limits=limits(), scene_folders=scene_folders(),
        rest_timeout=float(rospy.get_param("~rest_timeout", d.rest_timeout)),
        calibration_board=str(rospy.get_param("~calibration_board", d.calibration_board)),
    )


def main() -> int:
    cap_arenas()  # before rospy's threads: they would each keep an arena's free memory
    map_large_blocks()  # camera images and clouds: freed pages go back at once
    rospy.init_node("pg_sim", disable_signals=False)
    clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)
    try:
        sensor = make_sensor(str(rospy.get_param("~sensor", PERFECT)), int(rospy.get_param("~seed", 0)))
        rt = SimRuntime(config())  # loads and settles the initial scene; validates it first
    except Exception as e:  # report any start-up failure clearly
        log("logfatal", f"pg_sim: cannot start the simulation: {e}")
        return 1
    rt.world.camera.use_sensor(sensor)
    clock_pub.publish(conv.clock(rt.sim_time))  # before anything that reads rospy time
    world_frame, cam_frame = rt.geometry.world_frame, rt.geometry.camera_frame
    cam_ns = str(rospy.get_param("~camera_ns", "/camera")).rstrip("/")
    js_pub = rospy.Publisher("/joint_states", JointState, queue_size=10)
    cam_pubs = {k: rospy.Publisher(f"{cam_ns}/{k}", t, queue_size=2) for k, t in CAMERA_TOPICS.items()}
    scene_pub = rospy.Publisher("/pg_sim/scene_state", SceneState, queue_size=2, latch=True)
    resets_pub = rospy.Publisher("/pg_sim/scene_resets", UInt32, queue_size=1, latch=True)
    resets_pub.publish(UInt32(rt.scene_resets))
    resets_lock = threading.Lock()
    resets_shown = [rt.scene_resets]

    def publish_resets(count: int) -> None:  # any thread; the latched value only grows
        with resets_lock:
            if count > resets_shown[0]:
                resets_shown[0] = count
                resets_pub.publish(UInt32(count))
    marker_pub = rospy.Publisher("/pg_sim/markers", MarkerArray, queue_size=2, latch=True)

    traj_topic = str(rospy.get_param("~trajectory_topic", "/{arm}/scaled_pos_joint_traj_controller/command"))
    grip_topic = str(rospy.get_param("~gripper_topic", "/{arm}/gripper/command"))
    subs = []
    for arm in rt.arms:
        subs.append(rospy.Subscriber(traj_topic.format(arm=arm), JointTrajectory, queue_size=10,
                                     callback=lambda m, a=arm: rt.submit_trajectory(a, conv.trajectory(m))))
        subs.append(rospy.Subscriber(grip_topic.format(arm=arm), Float64, queue_size=10,
                                     callback=lambda m, a=arm: rt.submit_gripper(a, m.data)))
    reset_timeout = float(rospy.get_param("~reset_timeout", 60.0))

    def on_reset(req):  # service thread: queue, then wait for the main loop's answer
        result = rt.submit_reset(conv.reset_request(req)).wait(reset_timeout)
        if result is not None:
            log("loginfo" if result.success else "logwarn",
                f"pg_sim: reset_scene {cut(req.scene, quoted=True)}: {result.message}")
            if result.success:
                publish_resets(result.resets)  # before the caller hears the answer
        return conv.reset_response(result, reset_timeout)

    service = rospy.Service("/pg_sim/reset_scene", ResetScene, on_reset)
    log("loginfo", f"pg_sim: {rt.world.scene.name if rt.world.scene else '-'} loaded; "
        f"real_time_factor {rt.config.real_time_factor} busy / {rt.config.idle_real_time_factor} idle")

    cam_msgs: dict[str, object] = {}
    cam_seq = -1
    while not rospy.is_shutdown():
        out = rt.step()
        if rt.world.camera.sensor is not sensor:  # a renewed world (SimRuntime) gets the same sensor
            rt.world.camera.use_sensor(sensor)
        if rt.scene_resets > resets_shown[0]:  # a reset whose caller stopped waiting (~reset_timeout)
            publish_resets(rt.scene_resets)
        if out.clock or out.joint_state or out.camera or out.scene_state:
            clock_pub.publish(conv.clock(out.sim_time))
        if out.joint_state is not None:
            js_pub.publish(conv.joint_state(out.joint_state))
        cap = out.camera
        if cap is not None and any(p.get_num_connections() for p in cam_pubs.values()):
            if cap.seq != cam_seq:  # a fresh render: build the messages once, re-stamp re-used ones
                cam_msgs, cam_seq = conv.camera_messages(cap, rt.geometry.camera, cam_frame), cap.seq
            conv.restamp(cam_msgs, cap.stamp)
            for key, pub in cam_pubs.items():
                pub.publish(cam_msgs[key])
        if out.scene_state is not None:
            scene_pub.publish(conv.scene_state(out.scene_state, world_frame))
            marker_pub.publish(conv.markers(out.markers or [], out.sim_time, world_frame))
        for message in out.messages:
            log("logwarn", f"pg_sim: {message}")
    service.shutdown()
    for s in subs:
        s.unregister()
    rt.close()
    return 0

