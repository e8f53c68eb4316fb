#!/usr/bin/env python3
"""Scale-out benchmark of `pushgrasp eval --workers N` and `pushgrasp train --collectors N`
(pg_learning.evaluation.cluster_bench, pg_learning.cli.cluster_bench; `--help` lists the options)."""

import sys

from pg_learning.cli.cluster_bench import main

if __name__ == "__main__":
    sys.exit(main())
