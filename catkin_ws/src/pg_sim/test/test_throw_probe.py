"""The throw probe (pg_sim.world.throw_probe): its table, its refusals and a small run in the simulator."""

import argparse

import pytest

from pg_sim.world.throw_probe import FAST_MPS, THROWN_M, Throw, execute, run, table


def _throw(category, offset, lifted, moved, peak):
    return Throw(category, f"{category}/0", offset, 0, lifted, moved, peak)


def test_table_counts_throws_and_fast_objects_among_failed_grasps_only():
    throws = [
        _throw("can", 0.4, True, 0.0, 2.0),                       # lifted: never a throw, however fast
        _throw("can", 0.4, False, THROWN_M + 0.01, FAST_MPS + 0.1),
        _throw("can", 0.7, False, THROWN_M - 0.01, FAST_MPS - 0.1),
        _throw("bottle", 0.7, False, 0.8, 1.5),
    ]
    rows = {tuple(line.split()[:2]): line.split() for line in table(throws).splitlines()[2:]}
    assert rows[("can", "0.40")][2:] == ["2", "1", "1", "1", "0.06"]
    assert rows[("can", "0.70")][2:] == ["1", "0", "0", "0", "0.04"]
    assert rows[("bottle", "0.70")][2:] == ["1", "0", "1", "1", "0.80"]
    assert table(throws).splitlines()[-1].split() == ["all", "4", "1", "2", "2", "0.80"]


@pytest.mark.parametrize("objects, offsets, guard", [(0, [0.4], None), (1, [1.0], None), (1, [0.4], -1.0)])
def test_bad_arguments_are_refused_before_anything_runs(objects, offsets, guard):
    args = argparse.Namespace(categories=["can"], objects=objects, first=0, offsets=offsets, guard=guard, seed=0,
                              sim_mode="fast")
    with pytest.raises(ValueError):
        execute(args)


def test_a_small_run_records_every_grasp():
    throws = run(["can"], objects=1, offsets=(0.4, 0.7))
    assert len(throws) == 8  # 4 tries x 2 offsets
    assert {t.offset for t in throws} == {0.4, 0.7}
    for t in throws:
        assert t.peak_speed >= 0.0 and t.moved >= 0.0
        assert not (t.lifted and t.moved)  # a lifted object is not moved on the table


def test_the_palm_rule_keeps_a_lying_bottle_grasped_off_its_crest_on_the_table():
    # 70 % of the half-width off the axis the cell lies 2-3 cm below the crest: the section 4 rule drives the palm
    # onto the crest, presses the bottle into the table and squeezes it out at ~1 m/s
    from dataclasses import replace

    from pg_core.geometry import load

    geo = load()
    assert geo.primitives.grasp_palm_clearance is not None
    without = replace(geo, primitives=replace(geo.primitives, grasp_palm_clearance=None))
    thrown = {name: sum(not t.lifted and t.moved > THROWN_M for t in run(["bottle"], objects=1, offsets=(0.7,),
                                                                        geometry=g))
              for name, g in (("palm rule", geo), ("without", without))}
    assert thrown["palm rule"] == 0 and thrown["without"] >= 3, thrown
