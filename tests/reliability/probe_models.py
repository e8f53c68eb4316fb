"""Corrupt models: the policy node (`rosrun pg_policy policy_node _policy:=FILE`) started on each case of
corrupt_models against a master of its own (so that it never takes over the stack's service names).

Invariants per case: the node exits non-zero within --model-exit-bound s, its output gives the reason, naming the
model file, without a Python traceback, it never serves /pg/infer, and a pickle's payload never runs."""

from __future__ import annotations

import subprocess
import time
import xmlrpc.client
from pathlib import Path

from .corrupt_models import CASES, build
from .report import ProbeResult
from .runner import Context
from .stack import CALLER, free_port, master_proxy

TITLE = "Corrupt models"


def _start_master(ctx: Context) -> tuple[subprocess.Popen, dict[str, str]]:
    port = free_port()
    env = ctx.stack.env()
    env["ROS_MASTER_URI"] = f"http://127.0.0.1:{port}"
    with open(ctx.workdir / "models_master.log", "ab") as log:  # the child keeps its own copy of the descriptor
        proc = ctx.stack.spawn(["rosmaster", "--core", "-p", str(port)], env=env, stdout=log,
                               stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        try:
            master_proxy(env["ROS_MASTER_URI"]).getSystemState(CALLER)
            return proc, env
        except (OSError, xmlrpc.client.Error):
            time.sleep(0.2)
    raise RuntimeError("the probe's own ROS master did not come up within 30 s")


def _serves_infer(env: dict[str, str]) -> bool:
    try:
        return master_proxy(env["ROS_MASTER_URI"]).lookupService(CALLER, "/pg/infer")[0] == 1
    except (OSError, xmlrpc.client.Error):
        return False


def _start_node(ctx: Context, env: dict[str, str], policy: Path, log: Path) -> tuple[int | None, float, bool, str]:
    """(exit status or None, wall s, served /pg/infer, output) of one start of the policy node."""
    with open(log, "wb") as out:
        proc = ctx.stack.spawn(["rosrun", "pg_policy", "policy_node", "__name:=pg_policy_model_probe",
                                f"_policy:={policy}"], env=env, stdout=out, stderr=subprocess.STDOUT)
    t0 = time.monotonic()
    served = False
    while time.monotonic() - t0 < ctx.opts.model_exit_bound:
        if proc.poll() is not None:
            break
        if _serves_infer(env):
            served = True
            break
        time.sleep(0.25)
    seconds = time.monotonic() - t0
    code = proc.poll()
    if code is None:
        proc.terminate()
        try:
            proc.wait(20.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5.0)
    return code, seconds, served, log.read_text(errors="replace")


def _reason(output: str) -> str:
    """The line of the output that explains the refusal ("" when none does)."""
    for line in output.splitlines():
        low = line.lower()
        if "cannot start" in low or "fatal" in low or "error" in low:
            return line.strip()
    return ""


def run(ctx: Context, res: ProbeResult) -> None:
    opts = ctx.opts
    names = opts.selected(opts.model_cases, CASES)
    folder = ctx.workdir / "models"
    master, env = _start_master(ctx)
    table = res.table("Policy node on corrupt models", ["case", "exit status", "wall s", "served /pg/infer",
                                                        "payload ran", "reason given"])
    try:
        for name in names:
            if ctx.over_budget():
                res.notes.append(f"stopped before {name}: probe budget spent")
                break
            case = build(name, folder, opts.seed)
            code, seconds, served, output = _start_node(ctx, env, case.path, folder / f"{name}.log")
            reason = _reason(output)
            names_file = case.path.name in reason
            ran = case.marker is not None and case.marker.exists()
            table.rows.append([name, "running" if code is None else code, round(seconds, 1), served, ran,
                               reason[:140] or output.strip()[-140:]])
            ctx.log(f"{name}: exit {code} in {seconds:.1f} s")
            why = [w for w, bad in (("never exited", code is None), ("exit status 0", code == 0),
                                    ("served /pg/infer", served), ("payload ran", ran), ("no reason", not reason),
                                    (f"the reason does not name {case.path.name}", reason and not names_file),
                                    ("traceback in the output", "Traceback" in output),
                                    ("past the bound", seconds > opts.model_exit_bound)) if bad]
            ok = not why
            res.check(f"{name}: refused at start-up with the reason", ok,
                      f"exit {code} in {seconds:.1f} s" + (f"; {', '.join(why)}" if why else f": {reason[:120]}"))
    finally:
        master.terminate()
        try:
            master.wait(15.0)
        except subprocess.TimeoutExpired:
            master.kill()
    res.figures["cases"] = len(table.rows)
    res.figures["refused as required"] = sum(c.passed for c in res.checks)
