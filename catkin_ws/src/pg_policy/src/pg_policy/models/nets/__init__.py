"""Push/grasp Q networks: DenseNet-121 and lite trunks, the two-stream rotated QNet, the backbone registry."""

from pg_policy.models.nets.qnet import QNet, QNetConfig, build_qnet, canvas_size
from pg_policy.models.nets.registry import BACKBONES, get_backbone

__all__ = ["BACKBONES", "QNet", "QNetConfig", "build_qnet", "canvas_size", "get_backbone"]
