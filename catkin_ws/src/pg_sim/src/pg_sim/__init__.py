"""The package's import pins the CPU kernels (pg_core.cpu_kernels) when numpy has not loaded yet, so that its
`python -m` tools play the trials the `pushgrasp` CLI plays."""

from pg_core.cpu_kernels import pin_cpu_kernels

pin_cpu_kernels(warn=False)
