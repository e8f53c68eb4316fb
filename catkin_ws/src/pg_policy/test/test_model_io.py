"""TorchScript export/load: equality with the eager net, embedded metadata, clear errors, PolicyNets from files."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from pg_core.geometry import load
from pg_core.heightmap import Heightmap
from pg_policy.models.inference import PolicyNets, target_window
from pg_policy.models.model_io import METADATA_NAME, ModelLoadError, export_qnet, load_qnet
from pg_policy.models.nets import QNetConfig, build_qnet

torch.set_num_threads(2)


def _inputs(h: int, w: int, seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    return (torch.rand(1, 3, h, w, generator=g), torch.rand(1, 1, h, w, generator=g) * 0.08,
            (torch.rand(1, 1, h, w, generator=g) > 0.7).float())


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """{goal: (eager lite net, exported path)} for both goal variants."""
    out = {}
    for goal in ("none", "mask"):
        net = build_qnet(QNetConfig("lite", goal), seed=7)
        path = tmp_path_factory.mktemp("models") / f"grasp_{goal}.pt"
        export_qnet(net, path, {"role": "grasp", "stage": "alternate", "iteration": 1234})
        out[goal] = (net, path)
    return out


@pytest.mark.parametrize("goal", ["none", "mask"])
def test_export_matches_eager_lite(exported, goal):
    net, path = exported[goal]
    module, meta = load_qnet(path)
    color, depth, mask = _inputs(224, 224)
    with torch.no_grad():
        torch.testing.assert_close(module(color, depth, mask), net(color, depth, mask), atol=1e-5, rtol=0)
    assert meta["role"] == "grasp" and meta["backbone"] == "lite" and meta["goal"] == goal
    assert meta["rotations"] == 16 and meta["stage"] == "alternate" and meta["iteration"] == 1234
    geo = load()
    assert meta["heightmap"]["resolution"] == geo.heightmap.resolution
    assert meta["heightmap"]["rows"] == 224 and meta["heightmap"]["bounds"][0] == [-0.224, 0.224]
    assert meta["thresholds"]["grasp_q"] == 1.8 and meta["colors"]["green"] == [89, 161, 79]
    assert meta["created"].endswith("Z")


def test_export_matches_eager_densenet(tmp_path):
    net = build_qnet(QNetConfig("densenet121", "mask"), seed=3)
    path = export_qnet(net, tmp_path / "push.pt", {"role": "push"})
    module, meta = load_qnet(path)
    color, depth, mask = _inputs(32, 32)
    with torch.no_grad(), torch.jit.optimized_execution(False):
        torch.testing.assert_close(module(color, depth, mask, [6]), net(color, depth, mask, [6]), atol=1e-5, rtol=0)
    assert meta["backbone"] == "densenet121" and meta["role"] == "push"


def test_loading_needs_no_project_source(exported):
    _, path = exported["mask"]
    code = (
        "import sys; sys.modules['pg_policy'] = None; sys.modules['pg_sim'] = None\n"
        "import torch, json\n"
        f"extra = {{'{METADATA_NAME}': ''}}\n"
        f"m = torch.jit.load({str(path)!r}, _extra_files=extra)\n"
        "q = m(torch.zeros(1, 3, 40, 40), torch.zeros(1, 1, 40, 40), torch.zeros(1, 1, 40, 40), [0, 5])\n"
        "print(tuple(q.shape), json.loads(extra['" + METADATA_NAME + "'])['role'])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "(1, 2, 40, 40) grasp"


def test_load_errors(exported, tmp_path):
    _, good = exported["none"]
    with pytest.raises(ModelLoadError, match="not found"):
        load_qnet(tmp_path / "nope.pt")
    truncated = tmp_path / "truncated.pt"
    data = good.read_bytes()
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(ModelLoadError, match="not a readable TorchScript model"):
        load_qnet(truncated)
    state = tmp_path / "state.pt"
    torch.save(build_qnet(QNetConfig("lite")).state_dict(), state)
    with pytest.raises(ModelLoadError, match="not a readable TorchScript model"):
        load_qnet(state)
    bare = tmp_path / "bare.pt"
    torch.jit.save(torch.jit.script(build_qnet(QNetConfig("lite"))), str(bare))
    with pytest.raises(ModelLoadError, match="no pushgrasp.json metadata"):
        load_qnet(bare)
    assert issubclass(ModelLoadError, ValueError)


def test_geometry_mismatch(exported, tmp_path):
    net, _ = exported["none"]
    geo = load()
    other = dataclasses.replace(geo, heightmap=dataclasses.replace(geo.heightmap, resolution=0.003, rows=149,
                                                                    cols=149))
    path = export_qnet(net, tmp_path / "other.pt", {"role": "push"}, geometry=other)
    with pytest.raises(ModelLoadError, match=r"another heightmap geometry.*resolution: model 0.003 vs config 0.002"):
        load_qnet(path)
    module, meta = load_qnet(path, geometry=other)  # fine against its own geometry
    assert meta["heightmap"]["rows"] == 149
    assert load_qnet(path, check_geometry=False)[1]["role"] == "push"  # without the geometry check: loads anywhere


def test_export_metadata_errors(tmp_path):
    net = build_qnet(QNetConfig("lite", "mask"))
    with pytest.raises(ValueError, match="role"):
        export_qnet(net, tmp_path / "a.pt", {})
    with pytest.raises(ValueError, match="role must be"):
        export_qnet(net, tmp_path / "a.pt", {"role": "poke"})
    with pytest.raises(ValueError, match="contradicts"):
        export_qnet(net, tmp_path / "a.pt", {"role": "grasp", "goal": "none"})
    assert not (tmp_path / "a.pt").exists()


def test_policy_nets_from_files_match_eager(tmp_path):
    grasp = build_qnet(QNetConfig("lite", "mask"), seed=1)
    push = build_qnet(QNetConfig("lite", "mask"), seed=2)
    export_qnet(grasp, tmp_path / "g.pt", {"role": "grasp"})
    export_qnet(push, tmp_path / "p.pt", {"role": "push"})
    loaded = PolicyNets.from_files(tmp_path / "g.pt", tmp_path / "p.pt")
    eager = PolicyNets(grasp, push)
    rng = np.random.default_rng(0)
    geo = load()
    hm = Heightmap(rng.integers(0, 255, (224, 224, 3), dtype=np.uint8), rng.random((224, 224), np.float32) * 0.05,
                   np.ones((224, 224), bool), geo.heightmap.resolution, geo.workspace.bounds)
    mask = np.zeros((224, 224), bool)
    mask[100:120, 90:115] = True
    a = loaded.q_maps(hm, mask, rotations=[0, 7])
    b = eager.q_maps(hm, mask, rotations=[0, 7])
    assert set(a) == {"grasp", "push"} and a["grasp"].shape == (2, 224, 224) and a["grasp"].dtype == np.float32
    for role in a:
        np.testing.assert_allclose(a[role], b[role], atol=1e-5)
    with torch.no_grad():  # the shared rotated input gives the same maps as each net on its own
        c = torch.from_numpy(hm.color).permute(2, 0, 1)[None].float() / 255
        d = torch.from_numpy(hm.height)[None, None]
        np.testing.assert_allclose(b["push"], push(c, d, torch.from_numpy(mask)[None, None].float(), [0, 7])[0],
                                   atol=1e-5)
    win = target_window(mask, 25)
    w = loaded.q_maps(hm, mask, rotations=[0, 7], window=win)  # lite: exact margin -> equal to the full maps
    np.testing.assert_allclose(w["grasp"], a["grasp"][:, win[0]:win[1], win[2]:win[3]], atol=2e-5)
    with pytest.raises(ModelLoadError, match="expected 'grasp'"):
        PolicyNets.from_files(tmp_path / "p.pt", tmp_path / "g.pt")
    with pytest.raises(ValueError, match="window"):
        loaded.q_maps(hm, mask, window=(0, 300, 0, 10))
    with pytest.raises(ValueError, match="unknown nets"):
        loaded.q_maps(hm, mask, nets=("poke",))
    assert json.loads(str(loaded.nets["grasp"].config_json))["goal"] == "mask"
