"""torchvision's place in the tests' lerobot subprocesses (tests/lerobot_harness.py puts this folder on their
PYTHONPATH, so Python runs it at start-up): its PyPI wheels for torch 2.13 are CUDA builds that do not load beside
the CPU torch (tests/lerobot-requirements.txt). On Python 3.12 the site has the real torchvision (PyPI's torch is a
CUDA build there too, and lerobot 0.6 imports torchvision's models at `import lerobot.policies`): then this does
nothing.

lerobot 0.4.4 imports torchvision on every path the tests take: `lerobot.datasets` (PIL-image features, the pyav
decoder), `lerobot.processor` (`torchvision.transforms.functional`, for crops of human-in-the-loop training) and
`lerobot.policies.pretrained` (through `lerobot.datasets.transforms`, which subclasses
`torchvision.transforms.v2.Transform` at import). So placeholder modules stand in whose every attribute raises, and
whose `Transform` cannot be instantiated: a test fails loudly should lerobot *use* torchvision on a path tested
(reading video datasets through torchcodec, and running a policy that has no torchvision backbone, do not).
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
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


def _stand_in() -> None:
    for name in MODULES:
        module = _Unavailable(name)
        module.__spec__ = importlib.machinery.ModuleSpec(name, None)
        sys.modules[name] = module
    for name in MODULES[1:]:
        parent, _, child = name.rpartition(".")
        setattr(sys.modules[parent], child, sys.modules[name])
    sys.modules["torchvision.transforms.v2"].Transform = Transform  # type: ignore[attr-defined]


if importlib.util.find_spec("torchvision") is None:
    _stand_in()
