"""Fixtures shared by the pg_policy tests."""

import pytest


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory):
    """A folder with untrained `lite` grasp.pt and push.pt (grasp threshold 1.8 in the metadata)."""
    from pg_policy.models.model_io import export_qnet
    from pg_policy.models.nets import QNetConfig, build_qnet

    out = tmp_path_factory.mktemp("models")
    for i, role in enumerate(("grasp", "push")):
        export_qnet(build_qnet(QNetConfig("lite", "none"), seed=i), out / f"{role}.pt",
                    {"role": role, "thresholds": {"grasp_q": 1.8}})
    return out
