#!/usr/bin/env python3
"""Scale-out benchmark of `pushgrasp eval --workers N` and `pushgrasp train --collectors N`
(pg_policy.evaluation.cluster_bench; `--help` lists the options)."""

import sys

from pg_policy.evaluation.cluster_bench import main

if __name__ == "__main__":
    sys.exit(main())
