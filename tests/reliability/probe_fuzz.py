"""Fuzz: seeded /pg/execute_primitive and /pg_sim/reset_scene requests (fuzz_requests), one at a time, while the
arms' command topics are watched.

Invariants: out-of-bounds commands executed = 0 (a request whose position lies outside the workspace box is never
executed, nothing is sent to the arms for it and no arm is named); a refusal sends nothing to the arms; no request
the contract calls invalid (bad timeout, arm, yaw, primitive, frame) is executed; no internal errors; every answer
within its bound with a short message; a refused reset leaves the scene as it was, an accepted one answers with the
objects at rest (they move less than --settle-tolerance m in the next second); no node dies."""

from __future__ import annotations

import math
import time
from collections import Counter

from tqdm import tqdm

from pg_core.geometry import load as load_geometry

from .client import MotionWatch, Outcome, Services, fresh_scene_state, max_displacement, same_scene, scene_state
from .fuzz_requests import PrimitiveRequest, ResetRequest, primitive_request, reset_request
from .probe_soak import SHIPPED
from .report import ProbeResult
from .runner import Context

TITLE = "Fuzz"
MAX_OBJECTS = 40  # pg_sim.world.scene_families.MAX_OBJECTS (read at run time when importable)


def _max_objects() -> int:
    try:
        from pg_sim.world.scene_families import MAX_OBJECTS as limit

        return int(limit)
    except ImportError:
        return MAX_OBJECTS


def _settled(out: Outcome, before_stamp: float) -> float:
    """Largest object motion (m) over the second after an accepted reset's answer (inf: no snapshots)."""
    n = int(out.get("num_objects", 0) or 0)
    deadline = time.monotonic() + 5.0
    first = None
    while time.monotonic() < deadline:
        s = scene_state(2.0, newer_than=before_stamp)
        if s is not None and len(s.objects) == n:
            first = s
            break
        time.sleep(0.1)
    if first is None:
        return math.inf
    second = scene_state(5.0, newer_than=first.header.stamp.to_sec() + 0.99)
    return max_displacement(first, second)


def _primitive(ctx: Context, svc: Services, watch: MotionWatch, req: PrimitiveRequest, c: Counter[str],
               bad: list[str]) -> None:
    opts = ctx.opts
    before = watch.settle()
    out = svc.execute_primitive(opts.answer_wait, req.primitive, req.position, req.frame, req.yaw, req.arm,
                                req.timeout)
    moved = watch.settle() - before
    c["primitive requests"] += 1
    c["out-of-bounds requests"] += req.out_of_bounds
    what = (f"prim {req.primitive} pos {tuple(round(v, 3) for v in req.position)} frame {req.frame!r} "
            f"yaw {req.yaw:.3g} arm {req.arm!r} timeout {req.timeout:.3g}")
    if not out.answered or out.value is None:
        c["unanswered"] += 1
        bad.append(f"no answer: {what}: {out.message[:80]}")
        svc.wait_idle(opts.answer_wait)
        return
    arm = out.get("arm", "")
    if out.success:
        c["executed"] += 1
    elif arm:
        c["aborted (arm named)"] += 1
    else:
        c["refused"] += 1
    if req.out_of_bounds and (out.success or moved or arm):
        c["out-of-bounds executed"] += 1
        bad.append(f"out of bounds accepted ({out.message[:60]}): {what}")
    if not out.success and not arm and moved:
        c["refused but moved"] += 1
        bad.append(f"refused, {moved} command(s) sent: {what}")
    if not req.valid and out.success:
        c["invalid executed"] += 1
        bad.append(f"invalid executed: {what}")
    if "internal error" in out.message.lower():
        c["internal errors"] += 1
        bad.append(f"internal error '{out.message[:60]}': {what}")
    if not out.success and out.seconds > opts.refusal_bound and not arm:
        c["slow refusals"] += 1
        bad.append(f"refusal after {out.seconds:.1f} s: {what}")
    if len(out.message) > opts.max_message or not out.message:
        c["bad messages"] += 1
        bad.append(f"message of {len(out.message)} chars: {what}")


def _reset(ctx: Context, svc: Services, req: ResetRequest, c: Counter[str], bad: list[str]) -> None:
    opts = ctx.opts
    state0 = fresh_scene_state(10.0)
    out = svc.reset_scene(opts.answer_wait, req.scene, req.num_objects, req.seed)
    c["reset requests"] += 1
    what = f"reset {req.scene[:40]!r} n={req.num_objects} seed={req.seed}"
    if not out.answered or out.value is None:
        c["resets unanswered"] += 1
        bad.append(f"no answer: {what}")
        return
    if len(out.message) > opts.max_message or not out.message:
        c["bad messages"] += 1
        bad.append(f"message of {len(out.message)} chars: {what}")
    if out.success:
        c["resets accepted"] += 1
        if not req.valid:
            c["invalid resets accepted"] += 1
            bad.append(f"invalid accepted: {what}")
        motion = _settled(out, state0.header.stamp.to_sec() if state0 else 0.0)
        if motion > opts.settle_tolerance:
            c["resets answered before rest"] += 1
            bad.append(f"objects moved {motion * 1000:.1f} mm in the second after the answer: {what}")
    else:
        c["resets refused"] += 1
        if req.valid and "still moving" in out.message and "previous scene restored" in out.message:
            c["valid resets refused: not at rest"] += 1  # the reset contract for a scene that does not settle
        elif req.valid:
            c["valid resets refused"] += 1
            bad.append(f"valid refused ({out.message[:100]}): {what}")
        if state0 is not None and not same_scene(state0, fresh_scene_state(10.0)):
            c["refused resets that changed the scene"] += 1
            bad.append(f"refused but the scene changed: {what}")
        if out.seconds > opts.refusal_bound and not req.valid:
            c["slow refusals"] += 1
            bad.append(f"reset refusal after {out.seconds:.1f} s: {what}")


def run(ctx: Context, res: ProbeResult) -> None:
    opts, svc = ctx.opts, Services()
    geometry = load_geometry()
    rng = ctx.rng("fuzz")
    box = geometry.workspace.bounds.tolist()
    res.figures["workspace box (m)"] = f"x {box[0]} y {box[1]} z {box[2]} (from {geometry.path.name})"
    pids0 = ctx.stack.node_pids()
    c: Counter[str] = Counter()
    bad: list[str] = []
    max_objects = _max_objects()
    watch = MotionWatch().start()
    svc.reset_scene(opts.answer_wait, "household/case11")
    done = 0
    try:
        for i in tqdm(range(max(0, opts.fuzz)), desc="fuzz", unit="req", disable=None, leave=False):
            if ctx.over_budget():
                res.notes.append(f"stopped after {done} requests: probe budget spent")
                break
            if rng.random() < opts.fuzz_reset_share:
                _reset(ctx, svc, reset_request(rng, SHIPPED, max_objects), c, bad)
            else:
                _primitive(ctx, svc, watch, primitive_request(rng, geometry), c, bad)
            done += 1
            if (i + 1) % max(1, opts.fuzz // 10) == 0:
                ctx.log(f"{i + 1}/{opts.fuzz} requests, {c['executed']} executed, {len(bad)} violations")
    finally:
        watch.stop()
    pids = ctx.stack.node_pids()
    gone = [n for n, pid in pids0.items() if pids.get(n) != pid]
    keys = ("primitive requests", "executed", "refused", "aborted (arm named)", "out-of-bounds requests",
            "out-of-bounds executed", "refused but moved", "invalid executed", "internal errors", "slow refusals",
            "unanswered", "reset requests", "resets accepted", "resets refused", "invalid resets accepted",
            "valid resets refused", "refused resets that changed the scene", "resets answered before rest",
            "resets unanswered", "bad messages")
    res.figures.update({k: c[k] for k in keys})
    if bad:
        t = res.table("Violations (first 30)", ["#", "violation"])
        t.rows += [[i + 1, b[:200]] for i, b in enumerate(bad[:30])]

    def first(tag: str) -> str:
        return next((b[:160] for b in bad if tag in b), "")

    res.check("requests were made", done > 0, f"{done} of {opts.fuzz}")
    res.check("out-of-bounds commands executed = 0", c["out-of-bounds executed"] == 0,
              f"{c['out-of-bounds executed']} of {c['out-of-bounds requests']} out-of-bounds requests "
              + first("out of bounds"))
    res.check("nothing sent to the arms for a refusal", c["refused but moved"] == 0,
              f"{c['refused but moved']} " + first("refused,"))
    res.check("no invalid request executed (bad timeout, arm, yaw, primitive or frame)", c["invalid executed"] == 0,
              f"{c['invalid executed']} " + first("invalid executed"))
    res.check("no internal errors", c["internal errors"] == 0, f"{c['internal errors']} " + first("internal error"))
    res.check(f"every request answered, refusals within {opts.refusal_bound:.0f} s, messages short",
              c["unanswered"] + c["resets unanswered"] + c["slow refusals"] + c["bad messages"] == 0,
              f"unanswered {c['unanswered'] + c['resets unanswered']}, slow {c['slow refusals']}, "
              f"bad messages {c['bad messages']}")
    if c["reset requests"]:
        res.check("resets: invalid ones refused, refusals change nothing, valid ones accepted",
                  c["invalid resets accepted"] + c["refused resets that changed the scene"]
                  + c["valid resets refused"] == 0,
                  f"invalid accepted {c['invalid resets accepted']}, refused but changed "
                  f"{c['refused resets that changed the scene']}, valid refused {c['valid resets refused']} "
                  f"(and {c['valid resets refused: not at rest']} refused as not at rest, scene restored) "
                  + (first("invalid accepted") or first("refused but the scene") or first("valid refused")))
        res.check(f"accepted resets answer with objects at rest (< {opts.settle_tolerance * 1000:.0f} mm/s)",
                  c["resets answered before rest"] == 0,
                  f"{c['resets answered before rest']} of {c['resets accepted']} " + first("objects moved"))
    res.check("no node died", not gone, f"died: {gone}" if gone else "")
