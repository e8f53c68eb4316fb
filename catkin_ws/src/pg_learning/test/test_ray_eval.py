"""`pushgrasp eval` on Ray and its trial journal: results equal the serial run trial by trial on a two-node cluster,
a stopped run resumes, a journal of other settings is refused, a bad address fails fast."""

from __future__ import annotations

import json
import time

import pytest

from pg_learning.evaluation.journal import JournalMismatch, TrialJournal
from pg_policy.cli.main import main
from pg_policy.target_loop.records import TrialRecord

ARGS = ["eval", "--policy", "lite", "--scenes", "packed/case01", "random-4", "--trials", "2", "--max-actions", "2",
        "--no-progress"]
VOLATILE = ("wall_s", "think_s")  # timings: the only entries that differ between runs


def _outcomes(out):
    """Every trial of results.json without its timings."""

    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k not in VOLATILE}
        if isinstance(x, list):
            return [strip(v) for v in x]
        return x

    return [strip(t) for t in json.loads((out / "results.json").read_text())["trials"]]


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    assert main([*ARGS, "--out", str(out)]) == 0
    return out


def test_ray_cluster_of_two_nodes_gives_the_serial_results_trial_by_trial(serial, ray_two_nodes, tmp_path, capsys):
    out = tmp_path / "ray"
    assert main([*ARGS, "--out", str(out), "--ray-address", ray_two_nodes]) == 0
    printed = capsys.readouterr().out
    assert "Ray: 2 workers on" in printed and "(2 nodes, 2 CPUs)" in printed
    ray_trials, serial_trials = _outcomes(out), _outcomes(serial)
    assert [(t["scene"], t["seed"]) for t in ray_trials] == [(t["scene"], t["seed"]) for t in serial_trials]
    assert ray_trials == serial_trials
    assert json.loads((out / "results.json").read_text())["config"]["ray"] == ray_two_nodes


def test_an_interrupted_run_keeps_its_trials_and_the_same_command_resumes(serial, tmp_path, monkeypatch, capsys):
    import pg_learning.evaluation.runner as runner

    real, calls = runner.run_fresh, []

    def interrupted_at_third(*a, **kw):
        calls.append(a[2:4])
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*a, **kw)

    out = tmp_path / "resumed"
    monkeypatch.setattr(runner, "run_fresh", interrupted_at_third)
    assert main([*ARGS, "--out", str(out)]) == 130
    assert "interrupted: 2 of 4 trials are kept" in capsys.readouterr().out
    assert not (out / "results.json").exists() and len((out / "trials.jsonl").read_text().splitlines()) == 3
    monkeypatch.setattr(runner, "run_fresh", real)
    assert main([*ARGS, "--out", str(out)]) == 0
    assert "resuming: 2 of 4 trials" in capsys.readouterr().out
    assert _outcomes(out) == _outcomes(serial)
    assert json.loads((out / "results.json").read_text())["config"]["resumed_trials"] == 2
    t0 = time.perf_counter()  # a finished run re-run: nothing left to simulate
    assert main([*ARGS, "--out", str(out)]) == 0 and time.perf_counter() - t0 < 20
    assert _outcomes(out) == _outcomes(serial)


def test_a_journal_of_other_settings_is_refused_and_fresh_discards_it(serial, tmp_path, capsys):
    out = tmp_path / "j"
    out.mkdir()
    (out / "trials.jsonl").write_text((serial / "trials.jsonl").read_text())
    assert main([*ARGS[:-2], "3", "--no-progress", "--out", str(out)]) == 2  # --max-actions 3
    err = capsys.readouterr().err
    assert "holds trials of a run with other settings (max_actions differ)" in err and "--fresh" in err
    assert (out / "trials.jsonl").read_text() == (serial / "trials.jsonl").read_text()  # nothing changed


def test_journal_ignores_a_torn_last_line_and_rejects_a_corrupt_one(tmp_path):
    key = {"policy": "x", "seed": 1}
    j = TrialJournal(tmp_path, key)
    j.add(TrialRecord("s", 1, True, "completed"))
    j.add(TrialRecord("s", 2))
    text = (tmp_path / "trials.jsonl").read_text()
    (tmp_path / "trials.jsonl").write_text(text + '{"trial": {"scene": "s", "se')
    again = TrialJournal(tmp_path, key)
    assert again.pending([("s", 1), ("s", 2), ("s", 3)]) == [2]
    assert again.records([("s", 2), ("s", 1)])[1].completed
    lines = text.splitlines()
    (tmp_path / "trials.jsonl").write_text("\n".join([lines[0], "{oops", lines[1]]) + "\n")
    with pytest.raises(ValueError, match="line 2 is not JSON"):
        TrialJournal(tmp_path, key)
    with pytest.raises(JournalMismatch, match=r"\(seed differ\)"):
        (tmp_path / "trials.jsonl").write_text(text)
        TrialJournal(tmp_path, {"policy": "x", "seed": 2})
    assert TrialJournal(tmp_path, {"policy": "x", "seed": 2}, fresh=True).pending([("s", 1)]) == [0]


@pytest.mark.parametrize(("address", "message"), [
    ("127.0.0.1:1", "no Ray head answers at 127.0.0.1:1"),
    ("nonsense", "is not HOST:PORT"),
])
def test_a_bad_ray_address_fails_fast_with_a_clear_error(tmp_path, capsys, address, message):
    t0 = time.perf_counter()
    assert main([*ARGS, "--out", str(tmp_path / "x"), "--ray-address", address]) == 2
    assert message in capsys.readouterr().err and time.perf_counter() - t0 < 30
    assert not (tmp_path / "x").exists()


def test_workers_must_be_positive_without_a_cluster(tmp_path, capsys):
    assert main([*ARGS, "--out", str(tmp_path / "x"), "--workers", "0"]) == 2
    assert "--workers must be >= 1" in capsys.readouterr().err


def test_model_files_travel_to_nodes_that_lack_them(tmp_path):
    from pg_learning.evaluation.trial_workers import local_models, model_blobs
    from pg_policy.policies.policy import PolicyOptions

    (tmp_path / "grasp.pt").write_bytes(b"g" * 10)
    (tmp_path / "push.pt").write_bytes(b"p" * 5)
    opts = PolicyOptions(models=(tmp_path / "grasp.pt", tmp_path / "push.pt"))
    blobs = model_blobs(opts.models)
    assert local_models(opts, blobs) is opts  # here the files exist
    missing = PolicyOptions(models=(tmp_path / "gone" / "grasp.pt", tmp_path / "gone" / "push.pt"))
    there = local_models(missing, blobs)
    assert [p.name for p in there.models] == ["grasp.pt", "push.pt"]
    assert [p.read_bytes() for p in there.models] == [b"g" * 10, b"p" * 5]


# -- a node lost in the middle of a run: module functions, so that Ray's workers import them by name --------------
def _slow_trial(index, name, seed, plan):
    time.sleep(1.0)
    return index, TrialRecord(name, seed, True, "completed", 1, 1, 0, 0, 0, [{"seed": seed}])


def _no_init():
    pass


def test_a_lost_node_costs_no_trial_and_the_run_goes_on(importable_here, own_two_nodes, capsys):
    """A two-node cluster loses its worker node after the first trial: the actor there dies, its trial (if any) runs
    again on the head's actor, the replacement cannot start (no CPU left) and is given up; every trial completes."""
    from pg_learning.evaluation.ray_trials import run_on_ray

    with own_two_nodes(100 * 2**20) as (cluster, node):
        seen = []

        def on_trial(rec):
            seen.append(rec.seed)
            if len(seen) == 1:
                cluster.remove_node(node, allow_graceful=False)

        jobs = [("a", s) for s in range(12)]
        recs = run_on_ray(jobs, None, 2, _slow_trial, _no_init, (), on_trial, address=cluster.address,
                          start_timeout_s=5)
    assert [r.seed for r in recs] == list(range(12)) and sorted(seen) == list(range(12))
    assert all(r.termination == "completed" for r in recs)
    assert "a replacement Ray worker did not start within 5 s" in capsys.readouterr().out
