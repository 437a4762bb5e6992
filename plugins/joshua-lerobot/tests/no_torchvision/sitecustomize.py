"""torchvision's place in the tests' lerobot subprocesses (tests/lerobot_harness.py puts this folder on their
PYTHONPATH, so Python runs it at start-up): its PyPI wheels for torch 2.13 are CUDA builds that do not load beside
the CPU torch (tests/lerobot-requirements.txt).

lerobot 0.4.4 imports torchvision on every path the tests take: `lerobot.datasets` (PIL-image features, the pyav
decoder), `lerobot.processor` (`torchvision.transforms.functional`, for crops of human-in-the-loop training) and
`lerobot.policies.pretrained` (through `lerobot.datasets.transforms`, which subclasses
`torchvision.transforms.v2.Transform` at import). So placeholder modules stand in whose every attribute raises, and
whose `Transform` cannot be instantiated: a test fails loudly should lerobot *use* torchvision on a path tested
(reading video datasets through torchcodec, and running a policy that has no torchvision backbone, do not).
"""

from __future__ import annotations

import importlib.machinery
import sys
import types
from typing import Any

MODULES = (
    "torchvision",
    "torchvision.transforms",
    "torchvision.transforms.functional",
    "torchvision.transforms.v2",
    "torchvision.transforms.v2.functional",
)


class _Unavailable(types.ModuleType):
    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        raise RuntimeError(f"lerobot used {self.__name__}.{name}, which this test environment does not have")


class Transform:
    """`torchvision.transforms.v2.Transform`, which lerobot subclasses at import; making one raises."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        raise RuntimeError("lerobot made a torchvision transform, which this test environment does not have")


for _name in MODULES:
    _module = _Unavailable(_name)
    _module.__spec__ = importlib.machinery.ModuleSpec(_name, None)
    sys.modules[_name] = _module
for _name in MODULES[1:]:
    _parent, _, _child = _name.rpartition(".")
    setattr(sys.modules[_parent], _child, sys.modules[_name])
sys.modules["torchvision.transforms.v2"].Transform = Transform  # type: ignore[attr-defined]
