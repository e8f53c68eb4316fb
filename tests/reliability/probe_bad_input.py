"""Bad input: the cases of bad_input_cases through /pg/grasp_target, its action, /pg/infer, /pg/execute_primitive and
/pg_sim/reset_scene. Invariant of every case: an answer within --refusal-bound s, success false, a message of at most
--max-message characters (at most bad_input_cases.ECHO_BOUND for a request holding a huge string) naming the case's
field when it has one, nothing sent to the arms, no executed action, a refused reset leaves the scene as it was, a
refused primitive names no arm; nodes alive at the end. ("" as target means green and must be accepted.)

Masks are built against the colour camera's camera_info (CAMERA_INFO, waited for at most 10 s)."""

from __future__ import annotations

import shutil
from pathlib import Path

import rospy
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import CameraInfo, Image

from . import bad_input_cases as cases_mod
from .bad_input_cases import Case, MaskArg, PointArg
from .client import GraspAction, MotionWatch, Outcome, Services, fresh_scene_state, same_scene
from .report import ProbeResult
from .runner import REPO, Context

TITLE = "Bad input"
BASELINE = "household/case11"
SERVICES = ("grasp_target", "action", "infer", "execute_primitive", "reset_scene")
CAMERA_INFO = "/camera/color/camera_info"
MARK_PX = 20  # side of the marked square of a mask (px)


def point_msg(arg: PointArg | None) -> PointStamped | None:
    """The stamped point of `arg` (stamp 0: the latest transform); None when `arg` is."""
    if arg is None:
        return None
    msg = PointStamped()
    msg.header.frame_id = arg.frame
    msg.point.x, msg.point.y, msg.point.z = arg.xyz
    return msg


def mask_msg(arg: MaskArg | None, camera: CameraInfo | None) -> Image | None:
    """The mask of `arg` for a camera of `camera`'s size (None: 640 x 480); None when `arg` is."""
    if arg is None:
        return None
    width = (camera.width if camera is not None else 640) + arg.size_delta[0]
    height = (camera.height if camera is not None else 480) + arg.size_delta[1]
    channels = 3 if arg.encoding in ("rgb8", "bgr8") else 1
    msg = Image(encoding=arg.encoding, width=width, height=height, step=width * channels)
    data = bytearray(width * channels * height)
    if arg.marked:
        r0, c0 = (height - MARK_PX) // 2, (width - MARK_PX) // 2
        for r in range(r0, r0 + MARK_PX):
            start = (r * width + c0) * channels
            data[start:start + MARK_PX * channels] = b"\xff" * (MARK_PX * channels)
    msg.data = bytes(data)
    if arg.stamped:
        msg.header.stamp = rospy.Time.now()
    return msg


def _camera_info() -> CameraInfo | None:
    try:
        return rospy.wait_for_message(CAMERA_INFO, CameraInfo, timeout=10.0)
    except rospy.ROSException:
        return None


def _call(case: Case, svc: Services, action: GraspAction, wait_s: float,
          camera: CameraInfo | None = None) -> tuple[Outcome, str]:
    a = case.args
    point, mask = point_msg(a.get("point")), mask_msg(a.get("mask"), camera)
    if case.service == "grasp_target":
        return svc.grasp_target(wait_s, a["target"], a.get("max_actions", 0), a.get("max_failed_grasps", 0),
                                a.get("timeout", 0.0), point, mask), "-"
    if case.service == "infer":
        return svc.infer_(wait_s, a["target"], point, mask), "-"
    if case.service == "action":
        return action.send(wait_s, a["target"], a.get("max_actions", 0), a.get("max_failed_grasps", 0),
                           a.get("timeout", 0.0))
    if case.service == "execute_primitive":
        return svc.execute_primitive(wait_s, a["primitive"], a["position"], a["frame"], a["yaw"], a["arm"],
                                     a["timeout"]), "-"
    return svc.reset_scene(wait_s, a["scene"], a["num_objects"], a["seed"]), "-"


def violations(case: Case, out: Outcome, state: str, moved: int, scene_kept: bool | None, bound: float,
               max_message: int) -> list[str]:
    """What the answer to one case breaks of the contract (empty: the case passed)."""
    if not out.answered:
        return [f"no answer within {out.seconds:.0f} s" + (f" (goal {state})" if state != "-" else "")]
    if out.value is None:
        return [f"call failed: {out.error}"]
    executed = len(out.get("decisions", []) or [])
    if not case.expect_refused:
        ok = out.success or executed > 0
        return [] if ok else [f"not accepted: {out.message[:100]}"]
    bad = []
    if out.seconds > bound:
        bad.append(f"answered after {out.seconds:.1f} s")
    if out.success:
        bad.append("accepted")
    if not out.message.strip():
        bad.append("empty message")
    if case.field and f"{case.field}:" not in out.message:
        bad.append(f"message does not name the field '{case.field}'")
    longest = max_message if case.max_message is None else min(max_message, case.max_message)
    if len(out.message) > longest:
        bad.append(f"message of {len(out.message)} chars (at most {longest})")
    if case.service == "execute_primitive" and out.get("arm", ""):
        bad.append(f"refusal names arm {out.get('arm')!r}")
    if moved:
        bad.append(f"{moved} command(s) sent to the arms")
    if executed:
        bad.append(f"{executed} action(s) executed")
    if case.service == "action" and state not in ("REJECTED", "ABORTED"):
        bad.append(f"goal ended {state}")
    if scene_kept is False:
        bad.append("scene changed")
    return bad


def _outside_scene(ctx: Context) -> Path:
    folder = ctx.workdir / "outside_scene_folders"
    folder.mkdir(exist_ok=True)
    dest = folder / "valid_outside.yaml"
    shutil.copy(REPO / "catkin_ws" / "src" / "pg_sim" / "scenes" / "household" / "case11.yaml", dest)
    return dest


def select(ctx: Context) -> list[Case]:
    every = (cases_mod.grasp_cases("grasp_target") + cases_mod.grasp_cases("action")
             + cases_mod.target_form_cases("grasp_target") + cases_mod.target_form_cases("infer")
             + cases_mod.primitive_cases() + cases_mod.reset_cases(_outside_scene(ctx)))
    return [c for c in every if c.quick] if ctx.opts.bad_input_cases == "quick" else every


def run(ctx: Context, res: ProbeResult) -> None:
    opts, svc = ctx.opts, Services()
    cases = select(ctx)
    watch = MotionWatch().start()
    action = GraspAction()
    action_ok = action.ready()
    camera = _camera_info() if any("mask" in c.args for c in cases) else None
    if camera is None and any("mask" in c.args for c in cases):
        res.notes.append(f"no {CAMERA_INFO} within 10 s: masks built for 640 x 480")
    pids0 = ctx.stack.node_pids()
    table = res.table("Cases and answers", ["service", "case", "success", "answer s", "message (first 100 chars)",
                                            "message chars", "violations"])
    failed: dict[str, list[str]] = {s: [] for s in SERVICES}
    ran: dict[str, int] = {s: 0 for s in SERVICES}
    dirty = True
    try:
        for case in cases:
            if ctx.over_budget():
                res.notes.append(f"stopped at '{case.service}: {case.name}': probe budget spent")
                break
            if case.service == "action" and not action_ok:
                continue
            if dirty and case.service != "reset_scene":
                svc.reset_scene(opts.answer_wait, BASELINE)
                dirty = False
            before = watch.settle()
            state0 = fresh_scene_state(10.0) if case.service == "reset_scene" else None
            out, state = _call(case, svc, action, opts.answer_wait, camera)
            if not out.answered:
                svc.wait_idle(opts.answer_wait)
            moved = watch.settle() - before
            kept = None
            if state0 is not None:
                kept = same_scene(state0, fresh_scene_state(10.0))
            dirty = dirty or moved > 0 or bool(out.get("decisions")) or out.success
            bad = violations(case, out, state, moved, kept, opts.refusal_bound, opts.max_message)
            ran[case.service] += 1
            if bad:
                failed[case.service].append(f"{case.name} ({', '.join(bad)})")
            msg = out.message
            table.rows.append([case.service, case.name, out.success, round(out.seconds, 3),
                               msg[:100] + ("..." if len(msg) > 100 else ""), len(msg), "; ".join(bad) or "-"])
    finally:
        watch.stop()
        action.close()
    svc.reset_scene(opts.answer_wait, BASELINE)
    pids = ctx.stack.node_pids()
    gone = [n for n, pid in pids0.items() if pids.get(n) != pid]
    res.figures.update({"cases": sum(ran.values()), "cases breaking the contract": sum(map(len, failed.values()))})
    res.figures.update({f"{s} cases (broken)": f"{ran[s]} ({len(failed[s])})" for s in SERVICES})
    res.check("the action server answered", action_ok, "" if action_ok else "no status from /pg/grasp_target_action")
    for s in SERVICES:
        if ran[s]:
            res.check(f"{s}: every bad request refused within {opts.refusal_bound:.0f} s with a short message, "
                      "nothing moved or changed", not failed[s],
                      f"{len(failed[s])} of {ran[s]}: " + "; ".join(failed[s][:6]) if failed[s] else f"{ran[s]} cases")
    res.check("no node died", not gone, f"died: {gone}" if gone else "")
