"""Ray for pushgrasp: one local Ray or a connection to a cluster (docs/CLUSTER.md)."""
