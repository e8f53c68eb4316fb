"""Target lost: a grasp_target call whose first push carries the target out of the workspace answers "target lost:
..." within its budget and within two actions of the target leaving.

The stack's simulator and controller, a second policy node (pg_policy policy_node, `__name:=pg_policy_push_out`) on
the stack's master running push_out_policy.PushOutPolicy (registered through a generated entry point), its
grasp_target and infer remapped under PUSH_OUT_NS and its action topics likewise, so the stack's own policy node keeps
its names. The scene (push_out_policy.EDGE_SCENE) has the target cube 5 heightmap cells inside the +x border; the
node sees the simulator only through the heightmap, as on a real cell (the answer rests on the target memory's
evidence: last seen at the workspace edge, then hidden for two observations).

Invariants: the scene resets, the node serves within --startup-timeout s, the call answers within its budget plus
2 s with "target lost: ...", after at most 3 actions (the push that carried the target out and at most 2 more), the
simulator's ground truth has the target outside the workspace, no node of the stack died."""

from __future__ import annotations

import os
import signal
import subprocess
import time
import xmlrpc.client

from .client import Services, fresh_scene_state
from .push_out_policy import EDGE_SCENE, POLICY_NAME, write_plugin
from .report import ProbeResult
from .runner import REPO, Context
from .stack import CALLER, master_proxy

TITLE = "Target lost"
BASELINE = "household/case11"
PUSH_OUT_NS = "/pg_push_out"
NODE = "pg_policy_push_out"
CALL_TIMEOUT_S = 60.0  # the call's budget (wall s): three pushes take about 25 s on two busy cores
MAX_ACTIONS = 6        # the call's action limit: above the 3 the invariant allows, so the limit cannot end it first
ACTIONS_AFTER_LEAVING = 2
ACTION_TOPICS = ("goal", "cancel", "status", "result", "feedback")


def _node_args() -> list[str]:
    remaps = [f"/pg/grasp_target:={PUSH_OUT_NS}/grasp_target", f"/pg/infer:={PUSH_OUT_NS}/infer"]
    remaps += [f"/pg/grasp_target_action/{t}:={PUSH_OUT_NS}/grasp_target_action/{t}" for t in ACTION_TOPICS]
    remaps += [f"/pg/{t}:={PUSH_OUT_NS}/{t}" for t in ("decisions", "q_map", "markers")]
    return ["rosrun", "pg_policy", "policy_node", f"__name:={NODE}", f"_policy:={POLICY_NAME}", *remaps]


def _serving(uri: str) -> bool:
    try:
        return master_proxy(uri).lookupService(CALLER, f"{PUSH_OUT_NS}/grasp_target")[0] == 1
    except (OSError, xmlrpc.client.Error):
        return False


def _stop(proc: subprocess.Popen) -> None:
    """SIGINT to the node's own process group (spawned in its own session), then SIGKILL; bounded."""
    for sig, wait_s in ((signal.SIGINT, 20.0), (signal.SIGKILL, 5.0)):
        if proc.poll() is not None:
            return
        try:
            os.killpg(proc.pid, sig)
        except (ProcessLookupError, PermissionError):
            return
        try:
            proc.wait(wait_s)
        except subprocess.TimeoutExpired:
            pass


def run(ctx: Context, res: ProbeResult) -> None:
    opts, svc = ctx.opts, Services()
    folder = ctx.scene_dir / "reliability"
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / "target_edge.yaml"
    scene.write_text(EDGE_SCENE)
    plugin = write_plugin(ctx.workdir / "push_out_plugin")
    env = ctx.stack.env()
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(plugin), str(REPO / "tests"), env.get("PYTHONPATH")) if p)
    pids0 = ctx.stack.node_pids()
    log = ctx.workdir / "push_out_node.log"
    with open(log, "wb") as out:
        proc = ctx.stack.spawn(_node_args(), env=env, stdout=out, stderr=subprocess.STDOUT)
    try:
        t0 = time.monotonic()
        up = False
        while time.monotonic() - t0 < opts.startup_timeout and proc.poll() is None:
            if _serving(ctx.stack.uri):
                up = True
                break
            time.sleep(0.5)
        tail = log.read_text(errors="replace")[-600:]
        res.figures["push-out node start (s)"] = round(time.monotonic() - t0, 1)
        res.check("the push-out policy node serves grasp_target", up,
                  "" if up else f"exit {proc.poll()}; log: {tail}")
        if not up:
            return
        reset = svc.reset_scene(opts.answer_wait, str(scene))
        res.check("the edge scene resets", reset.success, reset.message[:200])
        if not reset.success:
            return
        state0 = fresh_scene_state(10.0)
        inside0 = bool(state0 is not None and state0.target_in_workspace)
        out = Services(PUSH_OUT_NS).grasp_target(CALL_TIMEOUT_S + opts.answer_wait, "green", MAX_ACTIONS, 0,
                                                 CALL_TIMEOUT_S)
        state = fresh_scene_state(10.0)
        left = bool(inside0 and state is not None and not state.target_in_workspace)
        actions = len(out.get("decisions", []) or [])
        message = out.message
        res.figures.update({"answer (s)": round(out.seconds, 1), "actions": actions, "message": message[:160]})
        res.table("The call", ["answered", "success", "answer s", "actions", "message"]).rows.append(
            [out.answered, out.success, round(out.seconds, 1), actions, message[:200]])
        res.check("the target starts inside and ends outside the workspace (simulator's ground truth)", left,
                  f"inside at the start: {inside0}; inside at the end: "
                  f"{None if state is None else state.target_in_workspace}")
        bound = CALL_TIMEOUT_S + 2.0
        ok = (out.answered and out.value is not None and not out.success and message.startswith("target lost:")
              and out.seconds <= bound and 1 <= actions <= 1 + ACTIONS_AFTER_LEAVING)
        res.check(f"answered \"target lost: ...\" within {bound:.0f} s and {ACTIONS_AFTER_LEAVING} actions of the "
                  "target leaving", ok, f"{actions} actions, {out.seconds:.1f} s: {message[:200]}")
    finally:
        _stop(proc)
        svc.reset_scene(opts.answer_wait, BASELINE)
    pids = ctx.stack.node_pids()
    gone = [n for n, pid in pids0.items() if pids.get(n) != pid]
    res.check("no node of the stack died", not gone, f"died: {gone}" if gone else "")
