"""pushgrasp robustness (pg_learning.cli.robustness, pg_learning.evaluation.robustness): one command runs a policy
under each camera condition and writes the table paired with the perfect camera; bad conditions are refused."""

from __future__ import annotations

import pytest

from pg_learning.evaluation.robustness import CONDITIONS, PERFECT, check_conditions, family
from pg_policy.cli.main import main


def test_conditions_start_with_the_perfect_camera_and_unknown_ones_are_refused():
    assert check_conditions(["d435"]) == [PERFECT, "d435"]
    assert check_conditions(["d415", PERFECT, "d415"]) == [PERFECT, "d415"]
    assert CONDITIONS["calibrated-2cm-2deg"].eval_args() == ["--sensor", "pose-2cm-2deg", "--calibrate"]
    with pytest.raises(ValueError, match="unknown condition"):
        check_conditions(["d999"])
    assert family("packed/case01") == "packed" and family("random-15") == "random-15"


def test_one_command_runs_every_condition_and_writes_the_paired_table(tmp_path, capsys):
    argv = ["robustness", "--policies", "heuristic", "--scenes", "random-4", "--trials", "2",
            "--conditions", "calibrated-2cm-2deg", "--out", str(tmp_path), "--no-progress"]
    assert main(argv) == 0
    for name in (PERFECT, "calibrated-2cm-2deg"):
        assert (tmp_path / "heuristic" / name / "results.json").is_file()
    text = (tmp_path / "robustness.md").read_text()
    rows = [line for line in text.splitlines() if line.startswith("| random-4 |")]
    assert len(rows) == 2 and "| perfect |" in rows[0] and "| calibrated-2cm-2deg |" in rows[1]
    assert "(2)" in rows[1] and "(p " in rows[1]  # two trials, paired with the perfect camera's
    assert main(argv[:-1] + ["--table-only"]) == 0  # rebuilt from the runs, nothing re-run
    assert "robustness.md" in capsys.readouterr().out
