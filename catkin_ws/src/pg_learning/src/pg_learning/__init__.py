"""pg_learning: how the pushgrasp policy is trained and evaluated in the PyBullet simulator (pg_sim): the simulated
environment, training, evaluation, the Ray cluster helpers and the `pushgrasp` subcommands that need them. The
deployable runtime is pg_policy, which never imports this package.

Importing the package pins the CPU kernels (pg_core.cpu_kernels) when numpy has not loaded yet, so that its
`python -m` tools play the trials the `pushgrasp` CLI plays."""

from pg_core.cpu_kernels import pin_cpu_kernels

pin_cpu_kernels(warn=False)
