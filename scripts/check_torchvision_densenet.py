#!/usr/bin/env python3
"""Where torchvision is installed (not on the project machine): our DenseNet-121 trunk loads torchvision's densenet121
state_dict (random init, nothing downloaded) through `load_pretrained` and computes
the same features."""
import torch
import torchvision

from pg_policy.models.nets.registry import get_backbone

torch.manual_seed(0)
tv = torchvision.models.densenet121(weights=None).eval()
torch.save(tv.state_dict(), "/tmp/tv_densenet121.pth")
bb = get_backbone("densenet121")
ours = bb.build().eval()
bb.load_pretrained(ours, "/tmp/tv_densenet121.pth")
x = torch.rand(2, 3, 224, 224)
with torch.no_grad():
    a = tv.features(x)
    b = ours(x)
print("torchvision", torchvision.__version__, "features", tuple(a.shape), "ours", tuple(b.shape))
if a.shape == b.shape:
    print("max abs diff", float((a - b).abs().max()))
else:
    import torch.nn.functional as F
    print("shapes differ (ours may end before norm5/relu): max abs diff vs relu(features)",
          float((F.relu(a) - b).abs().max()) if F.relu(a).shape == b.shape else "n/a")
