"""Malformed scenes: the files of malformed_scenes, placed in the run's scene folder (a folder the simulator serves
scenes from: sim.launch's scene-folder argument and PG_SCENE_PATH), given to /pg_sim/reset_scene by path and to
`pushgrasp scene render FILE`.

Invariants per case: reset_scene refuses it within --refusal-bound s with a short message that names the file (and
not "not found": the file exists) and the scene stays as it was; the CLI exits non-zero within --render-bound s with an
error message naming the file and no traceback, writing no image. The valid control file is accepted by both (else
the refusals prove nothing)."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

from . import malformed_scenes
from .client import Services, fresh_scene_state, same_scene
from .report import ProbeResult
from .runner import REPO, Context

TITLE = "Malformed scenes"
BASELINE = "household/case11"


def _render(ctx: Context, path: Path, png: Path) -> tuple[int | None, float, str]:
    """(exit status or None when it ran past the bound, wall s, output) of `pushgrasp scene render`."""
    png.unlink(missing_ok=True)
    t0 = time.monotonic()
    proc = ctx.stack.spawn([str(REPO / ".venv" / "bin" / "pushgrasp"), "scene", "render", str(path), "--out", str(png)],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        out, _ = proc.communicate(timeout=ctx.opts.render_bound)
        return proc.returncode, time.monotonic() - t0, out
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate(timeout=10.0)
        return None, time.monotonic() - t0, out or ""


def _last_line(text: str) -> str:
    lines = [ln for ln in text.strip().splitlines() if ln.strip() and "pybullet build time" not in ln]
    return lines[-1].strip() if lines else ""


def run(ctx: Context, res: ProbeResult) -> None:
    opts, svc = ctx.opts, Services()
    known = tuple(malformed_scenes.CASES)
    names = [n for n in opts.selected(opts.scene_cases, known) if n != malformed_scenes.CONTROL]
    render = set(opts.selected(opts.render_cases, known))
    folder = ctx.scene_dir / "reliability"
    pngs = ctx.workdir / "renders"
    pngs.mkdir(exist_ok=True)
    resets = res.table("reset_scene", ["case", "success", "answer s", "scene kept", "message"])
    renders = res.table("pushgrasp scene render", ["case", "exit status", "wall s", "image written", "last line"])
    svc.reset_scene(opts.answer_wait, BASELINE)
    ctrl = malformed_scenes.write(malformed_scenes.CONTROL, folder, opts.seed)
    out = svc.reset_scene(opts.answer_wait, str(ctrl))
    resets.rows.append([malformed_scenes.CONTROL, out.success, round(out.seconds, 2), None, out.message[:120]])
    res.check("control: a valid file in the scene folder is accepted by reset_scene", out.success, out.message[:160])
    code, secs, text = _render(ctx, ctrl, pngs / "control.png")
    renders.rows.append([malformed_scenes.CONTROL, code, round(secs, 1), (pngs / "control.png").is_file(),
                         _last_line(text)[:120]])
    res.check("control: `pushgrasp scene render` draws the valid file", code == 0 and (pngs / "control.png").is_file(),
              f"exit {code}: {_last_line(text)[:120]}")
    svc.reset_scene(opts.answer_wait, BASELINE)
    bad_reset: list[str] = []
    bad_render: list[str] = []
    for name in names:
        if ctx.over_budget():
            res.notes.append(f"stopped before {name}: probe budget spent")
            break
        path = malformed_scenes.write(name, folder, opts.seed)
        before = fresh_scene_state(10.0)
        out = svc.reset_scene(opts.answer_wait, str(path))
        after = fresh_scene_state(10.0)
        kept = same_scene(before, after)
        resets.rows.append([name, out.success, round(out.seconds, 2), kept, out.message[:120]])
        why = [w for w, bad in (("no answer", not out.answered), ("accepted", out.success),
                                (f"answered after {out.seconds:.1f} s", out.seconds > opts.refusal_bound),
                                ("'not found' for an existing file", "not found" in out.message.lower()
                                 and "mesh" not in out.message.lower()),
                                (f"message of {len(out.message)} chars", len(out.message) > opts.max_message),
                                ("the message does not name the file", out.answered and not out.success
                                 and path.name not in out.message),
                                ("scene changed", not kept)) if bad]
        if why:
            bad_reset.append(f"{name} ({', '.join(why)})")
        if out.success:
            svc.reset_scene(opts.answer_wait, BASELINE)
        if name in render:
            png = pngs / f"{name}.png"
            code, secs, text = _render(ctx, path, png)
            renders.rows.append([name, code, round(secs, 1), png.is_file(), _last_line(text)[:120]])
            why = [w for w, bad in (("ran past the bound", code is None), ("exit status 0", code == 0),
                                    ("traceback", "Traceback" in text), ("no message", not _last_line(text)),
                                    ("the message does not name the file", path.name not in text),
                                    ("image written", png.is_file())) if bad]
            if why:
                bad_render.append(f"{name} ({', '.join(why)})")
        ctx.log(f"{name}: reset {'accepted' if out.success else 'refused'}")
    res.figures.update({"cases": len(names), "reset_scene: refused as required": len(names) - len(bad_reset),
                        "render cases": len(renders.rows) - 1,
                        "render: refused as required": len(renders.rows) - 1 - len(bad_render)})
    res.check(f"reset_scene refuses every malformed file within {opts.refusal_bound:.0f} s, naming it, scene unchanged",
              not bad_reset, "; ".join(bad_reset[:8]) or f"{len(names)} cases")
    res.check("`pushgrasp scene render` exits non-zero with an error naming the file, no traceback, no image",
              not bad_render,
              "; ".join(bad_render[:8]) or f"{len(renders.rows) - 1} cases")
