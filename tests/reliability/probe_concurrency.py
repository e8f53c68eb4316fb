"""Concurrency: while one /pg/grasp_target call runs, a second grasp_target, /pg/infer, an action goal and
/pg_sim/reset_scene are refused "busy" (not queued), quickly; the running call ends normally; no node dies.

A round is exercised only when the first call was still running after the second calls were answered."""

from __future__ import annotations

import threading
import time

from pg_policy.target_loop.target_loop import RESET_MESSAGE

from .client import GraspAction, Outcome, Services
from .report import ProbeResult
from .runner import Context

TITLE = "Concurrency"
SCENES = ("packed/case02", "packed/case05", "packed/case07", "packed/case03", "packed/case09")


def _background(svc: Services, wait_s: float, timeout: float) -> tuple[threading.Thread, list[Outcome]]:
    box: list[Outcome] = []
    th = threading.Thread(target=lambda: box.append(svc.grasp_target(wait_s, "green", timeout=timeout)), daemon=True)
    th.start()
    return th, box


def _wait_running(th: threading.Thread, settle_s: float = 1.5) -> bool:
    """Give the first call time to take the node (polling /pg/infer could itself hold the node at that moment)."""
    time.sleep(settle_s)
    return th.is_alive()


def run(ctx: Context, res: ProbeResult) -> None:
    opts, svc = ctx.opts, Services()
    action = GraspAction()
    action_ok = action.ready()
    table = res.table("Second calls while grasp_target runs", ["round", "call", "success", "state", "message",
                                                               "latency s", "busy"])
    latencies: dict[str, list[float]] = {"grasp_target": [], "infer": [], "action": [], "reset_scene": []}
    bad: list[str] = []
    exercised = firsts_ok = 0
    pids0 = ctx.stack.node_pids()
    try:
        for r in range(max(1, opts.concurrency_rounds)):
            if ctx.over_budget():
                res.notes.append(f"stopped after {r} rounds: probe budget spent")
                break
            scene = SCENES[r % len(SCENES)]
            reset = svc.reset_scene(opts.answer_wait, scene)
            if not reset.success:
                res.notes.append(f"round {r}: reset {scene} failed: {reset.message[:200]}")
                continue
            th, box = _background(svc, opts.call_timeout + opts.answer_wait, opts.call_timeout)
            if not _wait_running(th):
                res.notes.append(f"round {r}: the first call ended within 1.5 s")
                th.join(opts.call_timeout + opts.answer_wait)
                continue
            seconds: list[tuple[str, Outcome, str]] = [
                ("grasp_target", svc.grasp_target(opts.answer_wait, "green", timeout=opts.call_timeout), "-"),
                ("infer", svc.infer_(opts.answer_wait), "-")]
            if action_ok:
                out, state = action.send(opts.answer_wait, "green", timeout=opts.call_timeout)
                seconds.append(("action", out, state))
            seconds.append(("reset_scene", svc.reset_scene(opts.answer_wait, "household/case11"), "-"))
            still_running = th.is_alive()
            reset_between: Outcome | None = None
            exercised += still_running
            for call, out, state in seconds:
                latencies[call].append(out.seconds)
                refused = out.answered and not out.success and (call == "reset_scene" or "busy" in out.message)
                if call == "action":
                    refused = refused and state in ("REJECTED", "ABORTED")
                quick = out.seconds <= opts.busy_latency_max
                table.rows.append([r, call, out.success, state, out.message[:90], round(out.seconds, 3),
                                   "busy" in out.message])
                if still_running and call == "reset_scene" and out.success and quick:
                    reset_between = out  # accepted between two primitives: the running call must end as reset
                elif still_running and not (refused and quick):
                    bad.append(f"round {r} {call}: success={out.success} state={state} in {out.seconds:.2f} s: "
                               f"{out.message[:120]}")
            th.join(opts.call_timeout + opts.answer_wait)
            first = box[0] if box else Outcome()
            if reset_between is not None and RESET_MESSAGE not in first.message:
                bad.append(f"round {r} reset_scene accepted between primitives, but the running call ended with "
                           f"{first.message[:120]!r}, not {RESET_MESSAGE!r}")
            table.rows.append([r, "first grasp_target", first.success, "-", first.message[:90],
                               round(first.seconds, 1), "busy" in first.message])
            firsts_ok += first.answered and first.value is not None and "busy" not in first.message
            if not first.answered:
                svc.wait_idle(opts.answer_wait)
    finally:
        action.close()
    pids = ctx.stack.node_pids()
    gone = [n for n, pid in pids0.items() if pids.get(n) != pid]
    for call, values in latencies.items():
        if values:
            res.figures[f"{call} refusal latency max (s)"] = round(max(values), 3)
    res.figures.update({"rounds exercised": exercised, "second calls not refused quickly": len(bad)})
    res.check("at least one round exercised (first call still running)", exercised > 0,
              f"{exercised} of {opts.concurrency_rounds}")
    res.check("the action server answered", action_ok, "" if action_ok else "no status from /pg/grasp_target_action")
    res.check(f"every second call refused within {opts.busy_latency_max} s (grasp_target, infer and the action: "
              "'busy'; reset_scene: refused, or accepted between two primitives and the running call ended as reset)",
              not bad, "; ".join(bad[:4]))
    res.check("every first call answered with its own outcome", firsts_ok == len([r for r in table.rows
                                                                                  if r[1] == "first grasp_target"]),
              f"{firsts_ok} answered")
    res.check("no node died", not gone, f"died: {gone}" if gone else "")
