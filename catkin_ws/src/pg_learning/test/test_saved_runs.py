"""Reading saved `pushgrasp eval` output folders: results.json before the journal, folders at any depth, links."""

import json

import pytest

from pg_learning.evaluation.report import write_results
from pg_learning.evaluation.saved_runs import load_run, load_tree, load_trials, run_folders
from pg_policy.target_loop.records import TrialRecord


def _trials(scene, seeds):
    return [TrialRecord(scene=scene, seed=s, completed=True, grasps=1, target_grasps=1, termination="completed")
            for s in seeds]


def _journal(folder, trials):
    folder.mkdir(parents=True)
    lines = [{"run": {"policy": "x"}}] + [{"trial": t.to_dict()} for t in trials]
    (folder / "trials.jsonl").write_text("".join(json.dumps(d) + "\n" for d in lines))


def test_results_json_wins_over_the_journal(tmp_path):
    _journal(tmp_path / "run", _trials("novel-10", range(3)))
    assert [t.seed for t in load_trials(tmp_path / "run")] == [0, 1, 2]
    write_results(tmp_path / "run", _trials("novel-10", range(5)), {"policy": "x", "seed": 0, "trials": 5})
    assert len(load_trials(tmp_path / "run")) == 5 and len(load_trials(tmp_path / "run" / "results.json")) == 5
    with pytest.raises(FileNotFoundError, match="not a `pushgrasp eval` output folder"):
        load_trials(tmp_path)


def test_the_run_settings_are_results_json_s_else_the_journal_s_key(tmp_path):
    _journal(tmp_path / "run", _trials("novel-10", range(3)))
    assert load_run(tmp_path / "run")[0] == {"policy": "x"}
    write_results(tmp_path / "run", _trials("novel-10", range(3)), {"policy": "y", "cpu_kernels": "pinned"})
    config, trials = load_run(tmp_path / "run")
    assert config == {"policy": "y", "cpu_kernels": "pinned"} and len(trials) == 3
    with pytest.raises(FileNotFoundError, match="not a `pushgrasp eval` output folder"):
        load_run(tmp_path)


def test_folders_at_any_depth_links_followed_each_once(tmp_path):
    store = tmp_path / "store"
    _journal(store / "a" / "novel-10", _trials("novel-10", range(2)))
    _journal(store / "b" / "deep" / "novel-15", _trials("novel-15", range(3)))
    _journal(store / "a" / "novel-10" / "inner", _trials("random-10", range(7)))  # below an output folder: skipped
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "x").symlink_to(store)
    (tree / "x-again").symlink_to(store / "a")  # the same real folder by a second link
    (store / "loop").symlink_to(store)
    found = run_folders(tree)
    assert [p.name for p in found] == ["novel-10", "novel-15"]
    assert sorted(t.scene for t in load_tree(tree)) == ["novel-10"] * 2 + ["novel-15"] * 3
    assert run_folders(store / "a" / "novel-10") == [store / "a" / "novel-10"]
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="no `pushgrasp eval` output folder"):
        load_tree(tmp_path / "empty")
    with pytest.raises(FileNotFoundError):
        load_tree(tmp_path / "missing")


def test_a_running_journal_with_a_half_written_last_line_is_read(tmp_path):
    _journal(tmp_path / "run", _trials("novel-10", range(2)))
    with (tmp_path / "run" / "trials.jsonl").open("a") as f:
        f.write('{"trial": {"scene": "novel-10", "se')  # the line `pushgrasp eval` is writing now
    assert [t.seed for t in load_trials(tmp_path / "run")] == [0, 1]
