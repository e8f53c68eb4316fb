"""Soak: N /pg/grasp_target calls, each on a freshly reset scene (shipped packed/household cases and random scenes
with evaluation seeds >= 1000000), recording every call's outcome and wall time and every node's resident memory.

Invariants: every call answers within its timeout; no node dies; after the warm-up no node's RSS grows by more than
--rss-slope-max MB per 100 calls (least-squares slope; judged with at least --slope-min-calls calls after the
warm-up); no "target lost" answer while the simulator has the target inside the workspace."""

from __future__ import annotations

import re
from collections import Counter

from tqdm import tqdm

from . import procs
from .client import Services, fresh_scene_state
from .report import ProbeResult
from .runner import Context

TITLE = "Soak"
SHIPPED = [f"packed/case{i:02d}" for i in range(1, 10)] + [f"household/case{i}" for i in range(11, 15)]
FALLBACK = "household/case11"  # the scene a call gets when its own reset failed


def slope_per_100(xs: list[float], ys: list[float]) -> float | None:
    """Least-squares slope of ys over xs, times 100 (MB per 100 calls); None with fewer than 2 points."""
    n = len(xs)
    if n < 2:
        return None
    mx, my = sum(xs) / n, sum(ys) / n
    den = sum((x - mx) ** 2 for x in xs)
    return None if den == 0 else 100.0 * sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / den


def message_kind(message: str) -> str:
    """A call's message with numbers and quoted names blanked, so that outcomes group ("target '*' grasped")."""
    text = re.sub(r"'[^']*'", "'*'", message.strip())
    return re.sub(r"\d+(\.\d+)?", "#", text)[:100] or "<empty>"


def scene_plan(ctx: Context, n: int) -> list[tuple[str, int, int]]:
    """(scene, num_objects, seed) of every call: shipped cases in turn, random scenes at --random-share."""
    rng = ctx.rng("soak")
    plan, shipped = [], 0
    for _ in range(n):
        if rng.random() < ctx.opts.random_share:
            plan.append(("random", rng.choice((8, 10, 12, 15)), 1_000_000 + rng.randrange(1_000_000)))
        else:
            plan.append((SHIPPED[shipped % len(SHIPPED)], 0, 0))
            shipped += 1
    return plan


def rss_all(pids: dict[str, int]) -> dict[str, float | None]:
    return {name: procs.rss_mb(pid) for name, pid in pids.items()}


def run(ctx: Context, res: ProbeResult) -> None:
    opts, svc = ctx.opts, Services()
    n = max(1, opts.soak_calls)
    warm = min(max(1, opts.warmup), n)
    pids0 = ctx.stack.node_pids()
    start_rss = rss_all(pids0)
    samples: dict[str, list[tuple[int, float]]] = {name: [] for name in pids0}
    warm_rss: dict[str, float | None] = {}
    outcomes: Counter[str] = Counter()
    lost_truth: Counter[str] = Counter()  # "target lost" answers by where the simulator has the target
    calls = successes = late = resets_failed = resets_unsettled = 0
    crashed: list[str] = []
    durations: list[float] = []
    per_call = res.table("Calls (first 40)", ["#", "scene", "success", "message", "grasps", "pushes", "wall s"])
    bar = tqdm(scene_plan(ctx, n), desc="soak", unit="call", disable=None, leave=False)
    for i, (scene, num, seed) in enumerate(bar, start=1):
        if ctx.over_budget():
            res.notes.append(f"stopped after {calls} calls: probe budget of {opts.probe_budget:.0f} s spent")
            break
        reset = svc.reset_scene(opts.answer_wait, scene, num, seed)
        if not reset.success:
            resets_failed += 0 if _not_at_rest(reset.message) else 1
            resets_unsettled += 1 if _not_at_rest(reset.message) else 0
            res.notes.append(f"reset {scene} {num} {seed}: {reset.message[:200]}")
            reset = svc.reset_scene(opts.answer_wait, FALLBACK)  # the call still gets a fresh scene
        target = reset.get("target") or "green"
        out = svc.grasp_target(opts.call_timeout + opts.answer_wait, target=target, timeout=opts.call_timeout)
        calls += 1
        successes += out.success
        late += not out.answered
        outcomes[message_kind(out.message)] += 1
        if out.message.startswith("target lost:"):  # the simulator's ground truth on the policy's verdict
            state = fresh_scene_state(opts.answer_wait)
            truth = "unknown" if state is None else "inside" if state.target_in_workspace else "outside"
            lost_truth[truth] += 1
            res.notes.append(f"call {i} ({scene} {num} {seed}): {out.message[:160]}; the simulator has the target "
                             f"{truth} the workspace")
        durations.append(out.seconds)
        name = reset.get("scene_name") or f"{scene} (reset failed)"
        if i <= 40:
            per_call.rows.append([i, name, out.success, out.message[:80], out.get("grasps"), out.get("pushes"),
                                  round(out.seconds, 1)])
        if not out.answered:
            svc.wait_idle(opts.answer_wait)
        pids = ctx.stack.node_pids()
        gone = [nm for nm, pid in pids0.items() if pids.get(nm) != pid]
        if gone:
            crashed = gone
            res.notes.append(f"call {i}: node(s) {gone} died or were restarted; soak stopped")
            break
        rss = rss_all(pids)
        for nm, mb in rss.items():
            if mb is not None and nm in samples:
                samples[nm].append((i, mb))
        if i == warm:
            warm_rss = rss
        if not bar.disable:
            bar.set_postfix(ok=successes)
        elif i % max(1, n // 10) == 0 or i == n:
            ctx.log(f"call {i}/{n}: {successes} successes so far")
    end_rss = rss_all(ctx.stack.node_pids())
    rss_table = res.table("Resident memory per node (MB) and growth after the warm-up",
                          ["node", "start", f"warm-up (call {warm})", "end", "slope MB/100 calls", "calls fitted"])
    slopes: dict[str, float | None] = {}
    for nm in sorted(samples):
        after = [(x, y) for x, y in samples[nm] if x >= warm]
        slope = slope_per_100([float(x) for x, _ in after], [y for _, y in after])
        slopes[nm] = slope
        rss_table.rows.append([nm, start_rss.get(nm), warm_rss.get(nm), end_rss.get(nm),
                               None if slope is None else round(slope, 2), len(after)])
    names = sorted(samples)
    every = max(1, calls // 20)
    series = res.table(f"Resident memory (MB) every {every} calls", ["call", *names])
    at = {nm: dict(samples[nm]) for nm in names}
    for i in sorted({x for nm in names for x, _ in samples[nm]}):
        if i % every == 0 or i == calls:
            series.rows.append([i, *(round(at[nm][i], 1) if i in at[nm] else None for nm in names)])
    by_msg = res.table("Outcomes by message", ["message", "calls"])
    by_msg.rows += [[k, v] for k, v in outcomes.most_common()]
    res.figures.update({"calls": calls, "successes": successes, "success rate": round(successes / calls, 3)
                        if calls else None, "crashes": len(crashed), "calls unanswered within the timeout": late,
                        "target lost answers with the target outside / inside the workspace (simulator)":
                            f"{lost_truth['outside']} / {lost_truth['inside']}"
                            + (f" ({lost_truth['unknown']} unknown)" if lost_truth["unknown"] else ""),
                        "resets refused or failed": resets_failed,
                        "resets refused: a scene that does not come to rest": resets_unsettled,
                        "median call wall time (s)": round(sorted(durations)[len(durations) // 2], 1)
                        if durations else None, "max call wall time (s)": round(max(durations), 1) if durations
                        else None})
    res.check("calls were made", calls > 0, f"{calls} of {n}")
    res.check("no node died", not crashed, f"died: {crashed}" if crashed else f"{len(pids0)} nodes alive")
    res.check("every call answered within its timeout", late == 0, f"{late} unanswered")
    res.check('no "target lost" answer with the target inside the workspace (simulator)', not lost_truth["inside"],
              f"{lost_truth['inside']} of {sum(lost_truth.values())}")
    first_reset = next((n for n in res.notes if n.startswith("reset ")), "")
    res.check("every reset of a valid scene succeeded (or was refused as not coming to rest, scene unchanged)",
              resets_failed == 0,
              f"{resets_failed} failed" + (f"; first: {first_reset[:200]}" if first_reset else ""))
    judged = {nm: s for nm, s in slopes.items() if s is not None and
              sum(1 for x, _ in samples[nm] if x >= warm) >= opts.slope_min_calls}
    if judged:
        over = {nm: s for nm, s in judged.items() if s is not None and s > opts.rss_slope_max}
        res.check(f"RSS slope after the warm-up <= {opts.rss_slope_max} MB/100 calls for every node", not over,
                  ", ".join(f"{nm} {s:.1f}" for nm, s in sorted(over.items(), key=lambda kv: -kv[1]))
                  + " MB/100 calls" if over else f"{len(judged)} nodes judged")
    else:
        res.notes.append(f"RSS slope not judged: fewer than {opts.slope_min_calls} calls after the warm-up")


def _not_at_rest(message: str) -> bool:
    """The sim's documented refusal of a scene whose objects do not come to rest (docs/RELIABILITY.md)."""
    return "come to rest" in message or "still moving" in message
