"""pg_learning: how the pushgrasp policy is trained and evaluated in the PyBullet simulator (pg_sim): the simulated
environment, training, evaluation, the Ray cluster helpers and the `pushgrasp` subcommands that need them. The
deployable runtime is pg_policy, which never imports this package."""
