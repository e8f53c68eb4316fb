"""Dead and frozen sensors: a node of the stack is frozen (SIGSTOP, later SIGCONT) or killed (`rosnode kill` through
this run's own master, then started again), a /pg/grasp_target call is made meanwhile, and after the repair the time
until /pg/infer succeeds again is measured.

Faults: projector-frozen and projector-dead (no heightmaps), sim-frozen (camera, /joint_states and /clock stop; a
/pg/execute_primitive call is made too), controller-frozen (the primitive service does not answer).
Invariants per fault: the call answers within --error-bound s with success false and a message naming the cause; no
hang; the stack recovers within --recovery-bound s; the other nodes stay alive. controller-frozen also: the
grasp_target call (budget CONTROLLER_BUDGET_S) answers within its budget plus BUDGET_SLACK_S with "the controller did
not answer", and after SIGCONT the primitive request it abandoned does not run (no arm command, the controller logs
"abandoned by the caller")."""

from __future__ import annotations

import signal
import subprocess
import time

from . import procs
from .client import CENTRE_GRASP, MotionWatch, Outcome, Services
from .options import SENSOR_FAULTS
from .report import ProbeResult, Table
from .runner import REPO, Context

TITLE = "Dead and frozen sensors"
FAULTS = SENSOR_FAULTS
NODE = {"projector-frozen": "heightmap_projector", "projector-dead": "heightmap_projector", "sim-frozen": "pg_sim",
        "controller-frozen": "primitive_controller"}
CAUSE = {"projector-frozen": ("heightmap",), "projector-dead": ("heightmap",),
         "sim-frozen": ("heightmap", "joint_states", "clock", "camera"),
         "controller-frozen": ("controller", "execute_primitive", "primitive")}
BASELINE = "household/case11"
CONTROLLER_BUDGET_S = 10.0  # wall s: the `timeout` of the grasp_target call made while the controller is frozen
BUDGET_SLACK_S = 2.0  # wall s a call may answer after its budget
REFUSAL = "abandoned by the caller"  # the controller's refusal of a request whose deadline passed (its log line)


def _restart_projector(ctx: Context) -> subprocess.Popen:
    config = REPO / "catkin_ws" / "src" / "pg_description" / "config" / "workspace.yaml"
    with open(ctx.workdir / "projector_restart.log", "ab") as log:  # the child keeps its own copy of the descriptor
        return ctx.stack.spawn(["rosrun", "pg_policy", "heightmap_projector_node", "__name:=heightmap_projector",
                                "_input:=cloud", f"_workspace_config:={config}"], stdout=log,
                               stderr=subprocess.STDOUT)


def _wait_gone(pid: int, wait_s: float) -> bool:
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        if not procs.alive(pid):
            return True
        time.sleep(0.1)
    return False


def _logged(ctx: Context, text: str, wait_s: float = 5.0) -> bool:
    """Whether `text` appears in the launch log or rosout's log of this run within wait_s (rosout writes every node's
    log lines; the launch log holds the nodes' screen output)."""
    deadline = time.monotonic() + wait_s
    while True:
        paths = sorted((ctx.workdir / "ros_log").glob("**/rosout*.log"))
        if any(text in p.read_text(errors="replace") for p in paths) or text in ctx.stack.log_tail(10**7):
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.5)


def _recover(ctx: Context, svc: Services, fault: str) -> float | None:
    """Wall seconds until /pg/infer succeeds (and, for the controller, /pg/execute_primitive answers), or None."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < ctx.opts.recovery_bound:
        ok = svc.infer_(10.0).success
        if ok and fault == "controller-frozen":
            probe = svc.execute_primitive(5.0, 1, (1.0, 0.0, 0.02), "world")  # outside: refused at once, if alive
            ok = probe.answered and probe.value is not None
        if ok:
            return time.monotonic() - t0
        time.sleep(0.5)
    return None


def _inject(ctx: Context, fault: str, pid: int) -> str | None:
    """Apply the fault; None, or why it could not be applied."""
    if fault.endswith("-frozen"):
        return None if procs.send(pid, signal.SIGSTOP) else "process gone"
    if not ctx.stack.kill_node(NODE[fault]):
        return "rosnode kill failed"
    return None if _wait_gone(pid, 15.0) else "node did not exit within 15 s"


def _heal(ctx: Context, fault: str, pid: int) -> None:
    if fault.endswith("-frozen"):
        procs.send(pid, signal.SIGCONT)
    else:
        _restart_projector(ctx)


def run(ctx: Context, res: ProbeResult) -> None:
    opts, svc = ctx.opts, Services()
    faults = opts.selected(opts.sensor_faults, FAULTS)
    table = res.table("Faults: the call made during the fault, and the recovery",
                      ["fault", "call", "answered", "success", "answer s", "message", "recovery s"])
    recoveries: dict[str, float | None] = {}
    watch = MotionWatch().start()
    try:
        for fault in faults:
            _one(ctx, svc, watch, fault, res, table, recoveries)
    finally:
        watch.stop()
    res.figures.update({f"recovery after {f} (s)": None if r is None else round(r, 2) for f, r in recoveries.items()})


def _one(ctx: Context, svc: Services, watch: MotionWatch, fault: str, res: ProbeResult, table: Table,
         recoveries: dict[str, float | None]) -> None:
    """Inject one fault, make the calls, repair, measure the recovery."""
    opts = ctx.opts
    if ctx.over_budget():
        res.notes.append(f"stopped before {fault}: probe budget spent")
        return
    ok, why = ctx.stack.healthy()
    if not ok:
        ctx.log(f"restarting the stack before {fault}: {why}")
        ctx.stack.stop()
        ctx.stack.start()
    svc.reset_scene(opts.answer_wait, BASELINE)
    if _recover(ctx, svc, "") is None:
        res.check(f"{fault}: the stack serves before the fault", False, "/pg/infer never succeeded")
        return
    pids0 = ctx.stack.node_pids()
    pid = pids0.get(NODE[fault])
    if pid is None:
        res.check(f"{fault}: node {NODE[fault]} found", False, "no process")
        return
    ctx.log(f"{fault}: {NODE[fault]} (pid {pid})")
    problem = _inject(ctx, fault, pid)
    if problem:
        _heal(ctx, fault, pid)
        res.check(f"{fault}: fault injected", False, problem)
        return
    time.sleep(0.5)
    calls: list[tuple[str, Outcome]] = []
    try:
        timeout = CONTROLLER_BUDGET_S if fault == "controller-frozen" else 60.0
        calls.append(("grasp_target", svc.grasp_target(opts.error_bound + opts.answer_wait, "green",
                                                       timeout=timeout)))
        if fault == "sim-frozen":
            calls.append(("execute_primitive", svc.execute_primitive(opts.error_bound + opts.answer_wait, 1,
                                                                     CENTRE_GRASP, "world")))
    finally:
        commands = watch.total()
        _heal(ctx, fault, pid)
    recovery = _recover(ctx, svc, fault)
    recoveries[fault] = recovery
    if fault == "controller-frozen":  # what the controller still does once it runs again
        late = watch.settle(quiet_s=3.0, wait_s=opts.recovery_bound) - commands
        refused = _logged(ctx, REFUSAL)
        res.figures["arm commands sent after the controller resumed"] = late
        res.figures["controller-frozen: grasp_target answer (s)"] = round(calls[0][1].seconds, 2)
        res.check("controller-frozen: the abandoned primitive does not run after SIGCONT", late == 0 and refused,
                  f"{late} arm command(s) after SIGCONT; controller log {'has' if refused else 'lacks'} "
                  f"'{REFUSAL}'")
        out = calls[0][1]
        res.check(f"controller-frozen: grasp_target answers within its budget + {BUDGET_SLACK_S:.0f} s",
                  out.answered and out.seconds <= CONTROLLER_BUDGET_S + BUDGET_SLACK_S
                  and "did not answer" in out.message,
                  f"{'answered' if out.answered else 'NO ANSWER'} in {out.seconds:.1f} s (budget "
                  f"{CONTROLLER_BUDGET_S:.0f} s): {out.message[:120]}")
    for name, out in calls:
        table.rows.append([fault, name, out.answered, out.success, round(out.seconds, 2), out.message[:100],
                           None if recovery is None else round(recovery, 2)])
        clear = any(k in out.message.lower() for k in CAUSE[fault])
        res.check(f"{fault}: {name} answers within {opts.error_bound:.0f} s with a clear error",
                  out.answered and out.value is not None and not out.success and out.seconds <= opts.error_bound
                  and clear and len(out.message) <= opts.max_message,
                  f"{'answered' if out.answered else 'NO ANSWER'} in {out.seconds:.1f} s, success={out.success}:"
                  f" {out.message[:120]}")
        if not out.answered:
            svc.wait_idle(opts.answer_wait)
    res.check(f"{fault}: recovers within {opts.recovery_bound:.0f} s", recovery is not None,
              f"{recovery:.1f} s" if recovery is not None else "no successful /pg/infer")
    if not opts.quick and recovery is not None:
        svc.reset_scene(opts.answer_wait, BASELINE)
        after = svc.grasp_target(opts.call_timeout + opts.answer_wait, "green", timeout=opts.call_timeout)
        table.rows.append([fault, "grasp_target after recovery", after.answered, after.success,
                           round(after.seconds, 2), after.message[:100], None])
        res.check(f"{fault}: grasp_target succeeds after recovery", after.success, after.message[:120])
    pids = ctx.stack.node_pids()
    others = [n for n, p in pids0.items() if n != NODE[fault] and pids.get(n) != p]
    res.check(f"{fault}: the other nodes stay alive", not others, f"died: {others}" if others else "")
