"""Per-target-kind rows of the catalogue families in the evaluation results."""

from __future__ import annotations

import json

from pg_policy.evaluation.report import kind_lines, write_results
from pg_policy.evaluation.target_kinds import by_kind, load_trials, target_kind_of
from pg_policy.evaluation.trials import TrialRecord
from pg_sim.world.scene_families import sample_family, target_kind


def test_kind_is_the_generated_targets():
    for seed in range(1_000_000, 1_000_010):
        assert target_kind_of("novel-10", seed) == target_kind(sample_family("novel-10", seed).target_object.name)
    assert target_kind_of("random-10", 1_000_000) is None and target_kind_of("packed/case01", 1) is None


def test_rows_per_kind_in_the_written_results(tmp_path):
    trials = [TrialRecord(scene="novel-10", seed=s, completed=s % 2 == 0, grasps=1, target_grasps=int(s % 2 == 0),
                          termination="completed" if s % 2 == 0 else "max_actions")
              for s in range(1_000_000, 1_000_012)]
    trials.append(TrialRecord(scene="random-10", seed=1_000_000, completed=True, termination="completed"))
    table = by_kind(trials)
    assert sum(m["C"].n for m in table.values()) == 12 and all(scene == "novel-10" for scene, _ in table)
    write_results(tmp_path, trials, {"policy": "x", "seed": 1_000_000, "trials": 12})
    doc = json.loads((tmp_path / "results.json").read_text())
    assert {r["kind"] for r in doc["by_target_kind"]} == {k for _, k in table}
    assert "By kind of target" in (tmp_path / "results.md").read_text()
    assert len(load_trials(tmp_path / "results.json")) == 13
    assert kind_lines(trials[-1:]) == []


def test_a_run_folder_without_results_reads_its_journal(tmp_path, capsys):
    import pytest

    from pg_policy.evaluation.target_kinds import main

    trials = [TrialRecord(scene="novel-10", seed=s, completed=True, grasps=1, target_grasps=1, termination="completed")
              for s in range(1_000_000, 1_000_003)]
    lines = [json.dumps({"run": {"policy": "x"}})] + [json.dumps({"trial": t.to_dict()}) for t in trials]
    (tmp_path / "trials.jsonl").write_text("\n".join(lines) + "\n")
    assert [t.seed for t in load_trials(tmp_path)] == [1_000_000, 1_000_001, 1_000_002]
    assert main([str(tmp_path)]) == 0 and "(3 trials)" in capsys.readouterr().out
    (tmp_path / "empty").mkdir()
    assert main([str(tmp_path / "empty")]) == 2 and "no results.json or trials.jsonl" in capsys.readouterr().err
    assert main([str(tmp_path / "none")]) == 2 and "No such file" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--help"])
