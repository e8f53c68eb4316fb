"""Runs the selected probes against one stack: starts it, checks its health before each probe (restarting it when a
probe left it broken), times each probe, turns a probe's exception into a failed result, and always stops
everything it started (the cleanup check: no marked process left)."""

from __future__ import annotations

import importlib
import os
import shutil
import signal
import sys
import tempfile
import time
import traceback
import uuid
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from random import Random

from . import procs, report
from .options import PROBES, Options
from .report import ProbeResult, Report
from .stack import Stack, StackConfig

REPO = Path(__file__).resolve().parents[2]


@dataclass
class Context:
    """What a probe gets: the options, the stack (started), the run's folder, its seeded randomness."""

    opts: Options
    stack: Stack
    workdir: Path
    probe: str = ""
    started: float = field(default_factory=time.monotonic)

    def rng(self, salt: str) -> Random:
        return Random(f"{self.opts.seed}:{salt}")

    def log(self, text: str) -> None:
        print(f"[reliability {time.strftime('%H:%M:%S')}] {self.probe}: {text}", file=sys.stderr, flush=True)

    def over_budget(self) -> bool:
        return time.monotonic() - self.started > self.opts.probe_budget

    @property
    def scene_dir(self) -> Path:
        return self.workdir / "scenes"


Probe = Callable[[Context, ProbeResult], None]
STACKLESS = {"models", "calibration"}  # probes that start what they need themselves


def _probe(name: str) -> tuple[str, Probe]:
    """(title, run function) of the probe module probe_<name>."""
    mod = importlib.import_module(f".probe_{name}", __package__)
    return mod.TITLE, mod.run


def _ensure_stack(ctx: Context, rep: Report) -> str | None:
    """Start or restart the stack when needed; None when it is healthy, else why not."""
    ok, why = ctx.stack.healthy()
    if ok:
        return None
    if ctx.stack.proc is not None:
        ctx.log(f"stack unhealthy ({why}): restarting it")
        rep.stack.setdefault("restarts", []).append(f"before {ctx.probe}: {why}")
        ctx.stack.stop()
    try:
        ctx.stack.start()
    except RuntimeError as exc:
        return f"stack did not start: {exc}"
    from . import client

    client.init()
    ok, why = ctx.stack.healthy()
    return None if ok else why


def run(opts: Options, command: str) -> Report:
    names = opts.selected(opts.probes, PROBES)
    rep = Report(command=command, options={k: str(v) for k, v in asdict(opts).items()},
                 machine=report.machine_info(REPO), started=report.now_iso())
    t_run = time.monotonic()
    workdir = Path(tempfile.mkdtemp(prefix="pg_reliability_"))
    marker = uuid.uuid4().hex
    (workdir / "scenes").mkdir()
    stack = Stack(StackConfig(REPO, workdir, marker, opts.policy, opts.scene, workdir / "scenes",
                              opts.startup_timeout))
    for k, v in stack.env().items():  # this process is a client of the private master
        if k.startswith("ROS_"):
            os.environ[k] = v
    rep.stack = {"master": stack.uri, "launch": " ".join(stack.launch_args()), "temp_folder": str(workdir)}
    try:
        for name in names:
            res = ProbeResult(name, name)
            ctx = Context(opts, stack, workdir, probe=name)
            ctx.log("start")
            t0 = time.monotonic()
            try:
                res.title, fn = _probe(name)
                why = None if name in STACKLESS else _ensure_stack(ctx, rep)
                if why:
                    res.error = why
                else:
                    fn(ctx, res)
            except KeyboardInterrupt:
                res.error = "interrupted"
                rep.interrupted = True
            except Exception as exc:  # noqa: BLE001 (one probe failing never stops the others)
                res.error = f"{type(exc).__name__}: {exc}"
                res.notes.append(traceback.format_exc(limit=6)[-1500:])
            res.duration_s = time.monotonic() - t0
            rep.probes.append(res)
            ctx.log(f"{'PASS' if res.passed else 'FAIL'} in {res.duration_s:.0f} s"
                    + "".join(f"\n    failed: {c.name}: {c.detail}" for c in res.checks if not c.passed)
                    + (f"\n    error: {res.error}" if res.error else ""))
            if rep.interrupted:
                break
    finally:
        try:  # a second Ctrl-C must not cut the cleanup short
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        except ValueError:  # not the main thread
            previous = None
        rep.stack["start_up_s"] = [round(s, 1) for s in stack.starts]
        rep.stack["launch_log_tail"] = stack.log_tail(600) if rep.probes and not all(p.passed for p in rep.probes) \
            else ""
        from . import client

        client.shutdown()
        stopped = stack.stop()
        left = procs.marked(marker)
        rep.cleanup = {**stopped, "left_running": [f"{p.pid} {p.cmdline[:100]}" for p in left],
                       "passed": not left,
                       "summary": f"{len(left)} process(es) of the run left running; "
                                  f"{len(stopped['terminated_after_launch_shutdown'])} needed a signal after the "
                                  "launch's own shutdown"}
        if opts.keep_temp:
            rep.cleanup["temp_folder"] = str(workdir)
        else:
            shutil.rmtree(workdir, ignore_errors=True)
        rep.machine["load_average_end"] = [round(v, 2) for v in os.getloadavg()]
        rep.wall_s = time.monotonic() - t_run
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    return rep
