"""The `pushgrasp` subcommands of the learning package (train, infer, eval, bench, compare, kinds, offline), registered
into the one `pushgrasp` command by pg_policy.cli.main."""
