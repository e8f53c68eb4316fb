"""pushgrasp compare: results.json files of several policies -> tables per family, paper lines, target check."""

import json

import pytest

from pg_learning.evaluation.compare import family_of, load_policy, markdown
from pg_policy.cli.main import main


def _trial(scene, seed, completed, grasps, target_grasps, pushes):
    return {"scene": scene, "seed": seed, "completed": completed,
            "termination": "completed" if completed else "failed_grasps", "grasps": grasps,
            "target_grasps": target_grasps, "failed_grasps": grasps - target_grasps, "pushes": pushes,
            "refused": 0, "actions": []}


def _write(folder, trials):
    folder.mkdir(parents=True)
    (folder / "results.json").write_text(json.dumps({"trials": trials}))


@pytest.fixture
def two_policies(tmp_path):
    good = [_trial("packed/case01", 1000000 + i, True, 1, 1, 2) for i in range(4)]
    good += [_trial("random-10", 1000000 + i, True, 1, 1, 0) for i in range(4)]
    weak = [_trial("packed/case01", 1000000 + i, i < 2, 2, 1 if i < 2 else 0, 0) for i in range(4)]
    _write(tmp_path / "good" / "packed", good[:4])
    _write(tmp_path / "good" / "random", good[4:])
    _write(tmp_path / "weak" / "packed", weak)
    return tmp_path


def test_tables_pool_families_and_check_targets(two_policies):
    good, weak = load_policy("good", two_policies / "good"), load_policy("weak", two_policies / "weak")
    text = markdown([good, weak], check="weak")
    assert "| packed/case01 | 100.0 ± 0.0 | 100.0 ± 0.0 | 2.00 ± 0.00 | 50.0 ± 28.9 | 25.0 ± 14.4 |" in text
    assert "| random-10 | 100.0 ± 0.0 | 100.0 ± 0.0 | 0.00 ± 0.00 | n/a | n/a | n/a |" in text
    assert "paper (Xu et al.)" in text
    assert "0/1 scenes meet" in text and "packed/case01: C 50.0 % < 98 %; GS 25.0 % < 61.7 %" in text
    assert "packed: GS 25.0 % does not beat good's 100.0 %" in text


def test_cli_writes_markdown_and_png_and_rejects_bad_input(two_policies, tmp_path):
    out = tmp_path / "report" / "cmp.md"
    assert main(["compare", f"good={two_policies / 'good'}", f"weak={two_policies / 'weak'}", "--out", str(out)]) == 0
    assert out.exists() and out.with_suffix(".png").stat().st_size > 1000
    assert main(["compare", f"none={tmp_path / 'nothing'}", "--out", str(out)]) == 2  # no results.json
    assert main(["compare", f"good={two_policies / 'good'}", "--out", str(out), "--check", "other"]) == 2
    assert main(["compare", f"good={two_policies / 'good'}", "--out", str(tmp_path)]) == 2  # a folder, not a file
    with pytest.raises(ValueError, match="in none of the report's families"):
        family_of("kitchen/case1")


def test_check_adds_the_paired_comparison_on_common_trials(two_policies):
    good, weak = load_policy("good", two_policies / "good"), load_policy("weak", two_policies / "weak")
    text = markdown([good, weak], check="good")
    assert "`good` paired with each other policy" in text
    # 4 common packed trials: weak failed two that good completed; GS per trial 1 - 0.5 twice, 1 - 0 twice
    assert "| packed | weak | 4 | 2 | 0 | 0.5 | 75.0 ± 14.4 |" in text
    assert "| random | weak |" not in text  # no common random trials


def test_held_out_families_have_their_own_tables_targets_and_pairing(tmp_path):
    assert [family_of(s) for s in ("novel-packed-8", "novel-10", "mixed-15", "random-10")] == [
        "novel-packed", "novel", "mixed", "random"]
    # novel-10: 9 of 10 completed (C 90 % < 95 %); novel-packed-8: 10 of 10 (meets C >= 90 %); mixed-15: no target
    a = [_trial("novel-10", 1000000 + i, i > 0, 1, 1 if i > 0 else 0, 0) for i in range(10)]
    a += [_trial("novel-packed-8", 1000000 + i, True, 1, 1, 1) for i in range(10)]
    a += [_trial("mixed-15", 1000000 + i, i % 2 == 0, 1, int(i % 2 == 0), 0) for i in range(10)]
    b = [_trial("novel-10", 1000000 + i, i > 3, 1, int(i > 3), 0) for i in range(10)]
    _write(tmp_path / "a", a)
    _write(tmp_path / "b", b)
    text = markdown([load_policy("a", tmp_path / "a"), load_policy("b", tmp_path / "b")], check="a")
    assert "### novel" in text and "### novel-packed" in text and "### mixed" in text
    assert "1/2 scenes meet" in text and "- novel-10: C 90.0 % < 95 %; GS 90.0 % < 85.0 %" not in text
    assert "- novel-10: C 90.0 % < 95 %" in text and "novel-packed-8:" not in text.split("### Targets")[1]
    assert "| novel | b | 10 | 3 | 0 | 0.25 |" in text  # a completed trials 1-3 that b did not
    assert main(["compare", f"a={tmp_path / 'a'}", "--out", str(tmp_path / "r.md")]) == 0


def test_training_families_are_compared_without_targets(tmp_path):
    assert family_of("train-novel-packed-8") == family_of("train-novel-10") == "training"
    a = [_trial("train-novel-10", i, True, 1, 1, 0) for i in range(6)]
    b = [_trial("train-novel-10", i, i > 1, 1, int(i > 1), 0) for i in range(6)]
    _write(tmp_path / "a", a)
    _write(tmp_path / "b", b)
    text = markdown([load_policy("a", tmp_path / "a"), load_policy("b", tmp_path / "b")], check="a")
    assert "### training" in text and "train-novel-10" not in text.split("### Targets")[1]
    assert "| training | b | 6 | 2 | 0 |" in text


def test_links_are_followed_and_an_unfinished_run_reads_its_journal(two_policies, tmp_path):
    linked = tmp_path / "linked"
    linked.mkdir()
    (linked / "packed").symlink_to(two_policies / "good" / "packed")
    running = linked / "random"
    running.mkdir()
    lines = [{"run": {"policy": "x"}}] + [{"trial": _trial("random-10", 1000000 + i, True, 1, 1, 0)} for i in range(2)]
    (running / "trials.jsonl").write_text("".join(json.dumps(d) + "\n" for d in lines))
    policy = load_policy("linked", linked)
    assert sorted(policy.trials) == ["packed/case01", "random-10"]
    assert len(policy.trials["packed/case01"]) == 4 and len(policy.trials["random-10"]) == 2
    (linked / "again").symlink_to(two_policies / "good" / "packed")  # the same real folder again: read once
    assert len(load_policy("linked", linked).trials["packed/case01"]) == 4
    _write(linked / "copy", [_trial("packed/case01", 1000000, True, 1, 1, 2)])  # the scene in a second folder
    with pytest.raises(ValueError, match="scene packed/case01 appears in two output folders"):
        load_policy("linked", linked)


def test_runs_of_different_cpu_kernels_are_flagged(two_policies):
    for name, kernels in (("good", "pinned"), ("weak", "native")):
        for results in (two_policies / name).glob("*/results.json"):
            doc = json.loads(results.read_text())
            results.write_text(json.dumps({**doc, "config": {"cpu_kernels": kernels}}))
    good, weak = load_policy("good", two_policies / "good"), load_policy("weak", two_policies / "weak")
    assert good.kernels == {"pinned"} and weak.kernels == {"native"}
    assert "CPU kernels differ between the runs (good: pinned; weak: native)" in markdown([good, weak])
    assert "CPU kernels differ" not in markdown([good, good])
    results = two_policies / "weak" / "packed" / "results.json"  # one from before kernels were recorded
    results.write_text(json.dumps({"trials": json.loads(results.read_text())["trials"]}))
    old = load_policy("old", two_policies / "weak")
    assert old.kernels == {"not recorded"} and "CPU kernels differ" not in markdown([good, old])
