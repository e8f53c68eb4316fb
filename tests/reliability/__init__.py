"""pushgrasp's fault suite: probes that start their own ROS stack (sim.launch on a private master) and check what the
stack promises under load, concurrency, bad input, a target pushed out, fuzzing, sensor faults, corrupt models,
malformed scenes and a calibration that cannot see its board.

`scripts/reliability.py` is the long form (a report in Markdown and JSON); `tests/test_reliability.py` runs the same
probes with small counts in `make test`. One probe per module (`probe_*.py`); `runner.run` runs the selected ones,
each bounded in count and time, and a probe that fails or raises never stops the others.
"""
