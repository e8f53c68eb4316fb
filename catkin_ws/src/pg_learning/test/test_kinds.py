"""Per-target-kind rows of the catalogue families in the evaluation results (pg_learning.evaluation.kinds) and their
command line (`pushgrasp kinds`, pg_learning.cli.kinds)."""

from __future__ import annotations

import json

from pg_learning.evaluation.kinds import by_kind, kind_lines, target_kind_of
from pg_learning.evaluation.report import write_results
from pg_learning.evaluation.saved_runs import load_trials
from pg_policy.target_loop.records import TrialRecord
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

    from pg_learning.cli.kinds import main
    from pg_policy.cli.main import main as pushgrasp

    trials = [TrialRecord(scene="novel-10", seed=s, completed=True, grasps=1, target_grasps=1, termination="completed")
              for s in range(1_000_000, 1_000_003)]
    lines = [json.dumps({"run": {"policy": "x"}})] + [json.dumps({"trial": t.to_dict()}) for t in trials]
    (tmp_path / "trials.jsonl").write_text("\n".join(lines) + "\n")
    assert [t.seed for t in load_trials(tmp_path)] == [1_000_000, 1_000_001, 1_000_002]
    assert main([str(tmp_path)]) == 0 and "(3 trials)" in capsys.readouterr().out
    assert pushgrasp(["kinds", str(tmp_path)]) == 0 and "(3 trials)" in capsys.readouterr().out  # the same command
    (tmp_path / "empty").mkdir()
    assert main([str(tmp_path / "empty")]) == 2 and "no results.json or trials.jsonl" in capsys.readouterr().err
    assert main([str(tmp_path / "none")]) == 2 and "No such file" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["--help"])


def test_pooled_table_has_a_column_per_named_set_of_runs(tmp_path, capsys):
    from pg_learning.cli.kinds import main
    from pg_learning.evaluation.kinds import pooled_by_kind, pooled_lines
    from pg_learning.evaluation.report import write_results
    from pg_learning.evaluation.saved_runs import load_tree

    def trials(scene, ok):
        return [TrialRecord(scene=scene, seed=s, completed=ok, grasps=1, target_grasps=int(ok),
                            termination="completed" if ok else "max_actions") for s in range(1_000_000, 1_000_006)]

    for policy, ok in (("a", True), ("b", False)):
        for scene in ("novel-10", "novel-15"):
            write_results(tmp_path / policy / scene, trials(scene, ok), {"policy": policy, "seed": 1_000_000,
                                                                        "trials": 6})
    pooled = pooled_by_kind(load_tree(tmp_path / "a"))
    assert sum(m["C"].n for m in pooled.values()) == 12 and all(m["C"].mean == 1.0 for m in pooled.values())
    lines = pooled_lines([("a", load_tree(tmp_path / "a")), ("b", load_tree(tmp_path / "b" / "novel-10"))])
    assert lines[0] == "| target kind | a: n, C / GS (%) | b: n, C / GS (%) |" and len(lines) == 3 + len(pooled)
    assert any("0.0 ± 0.0" in line for line in lines[2:])
    assert pooled_lines([("c", trials("random-10", True))]) == []
    b = tmp_path / "b"
    assert main(["--pooled", f"a={tmp_path / 'a'}", f"b={b / 'novel-10'},{b / 'novel-15'}"]) == 0
    assert "| a: n, C / GS (%) | b: n, C / GS (%) |" in capsys.readouterr().out
    (tmp_path / "empty").mkdir()
    assert main(["--pooled", f"e={tmp_path / 'empty'}"]) == 2 and "no `pushgrasp eval` output folder" in \
        capsys.readouterr().err
    assert main(["--pooled", "x="]) == 2 and "expected NAME=RUN" in capsys.readouterr().err


def test_rows_per_arrangement_of_the_hard_household_family():
    from pg_learning.evaluation.kinds import arrangement_of_trial, pooled_lines
    from pg_sim.world.arrangements import ARRANGEMENT_NAMES

    assert arrangement_of_trial("household-10", 1_000_000) is None
    assert arrangement_of_trial("random-10", 1_000_000) is None
    seeds = range(1_000_000, 1_000_012)
    assert sorted({arrangement_of_trial("household-hard-8", s) for s in seeds}) == sorted(ARRANGEMENT_NAMES)
    assert {arrangement_of_trial("train-household-hard-inside-8", s) for s in seeds} == {"inside"}  # one for all
    trials = [TrialRecord(scene="household-hard-8", seed=s, completed=s % 2 == 0, grasps=1,
                          target_grasps=int(s % 2 == 0)) for s in seeds]
    trials.append(TrialRecord(scene="household-10", seed=1_000_000, completed=True, grasps=1, target_grasps=1))
    lines = pooled_lines([("lite", trials)], by="arrangement")
    assert lines[0].startswith("| arrangement | lite")
    rows = {ln.split(" | ")[0].strip("| "): ln for ln in lines[2:] if ln}
    assert sorted(rows) == sorted(ARRANGEMENT_NAMES)  # the household-10 trial is in no row
    assert all(" 2, " in row for row in rows.values())
