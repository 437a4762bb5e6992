"""A LeRobot policy served over pipes, run as a script by the Python that has lerobot (the user's LeRobot
environment, which need not have JOSHUA):

    python policy_server.py POLICY_FOLDER DEVICE

It loads the pretrained policy with lerobot's own API (lerobot 0.4: `PreTrainedConfig.from_pretrained`, the
policy class's `from_pretrained`, and the saved pre/post-processor pipelines, which hold the normalisation) and
answers requests on stdin with replies on stdout until stdin closes; lerobot's own prints go to stderr.

A message (`send`, `receive`, also used by JOSHUA's side, `policy_process.py`) is a 4-byte little-endian
length, a JSON header, then the raw bytes of the arrays the header lists (name, dtype, shape): numbers travel as
plain numpy arrays, nothing is pickled. Requests: `{"op": "reset"}`; `{"op": "select_action", "task": [...]}`
with `observation.state` (B, state) float32 and each `observation.images.<camera>` as (B, H, W, 3) uint8 RGB,
made here what lerobot's `preprocess_observation` makes of an environment's frames (float CHW in [0, 1]);
the reply holds `action` (B, action) float32, in the units of the dataset the policy was trained on. The first
reply describes the policy (`{"policy": {type, input_features, output_features}}`), or `{"error": "..."}` when it
cannot be loaded; any failure later is an `{"error": ...}` reply too.

Only numpy is imported at the top, so that JOSHUA imports the message functions without torch or lerobot.
"""

from __future__ import annotations

import json
import math
import os
import struct
import sys
from pathlib import Path
from typing import IO, Any

if __name__ == "__main__" and sys.path[0] == os.path.dirname(os.path.abspath(__file__)):
    del sys.path[0]  # run as a script: this package's modules (video, stats ...) must not shadow lerobot's imports

import numpy as np  # noqa: E402

HEADER = struct.Struct("<I")
MAX_HEADER_BYTES = 1 << 20  # a header lists a few arrays; more is not a message
MAX_DIMENSIONS = 8
MAX_COUNT = 1 << 31  # per dimension; the total is bounded by receive's max_bytes
NUMBER_KINDS = "biuf"  # bool, signed, unsigned, float: nothing else travels
IMAGE_PREFIX = "observation.images."


def send(stream: IO[bytes], header: dict[str, Any], arrays: dict[str, np.ndarray] | None = None) -> None:
    """Write one message: `header` and `arrays` (listed in the header under "arrays")."""
    arrays = {name: np.ascontiguousarray(array) for name, array in (arrays or {}).items()}
    listed = [{"name": name, "dtype": array.dtype.str, "shape": list(array.shape)} for name, array in arrays.items()]
    text = json.dumps(header | {"arrays": listed}).encode()
    stream.write(HEADER.pack(len(text)) + text)
    for array in arrays.values():
        stream.write(array.tobytes())
    stream.flush()


def receive(stream: IO[bytes], max_bytes: int | None = None) -> tuple[dict[str, Any], dict[str, np.ndarray]] | None:
    """Read one message: its header and arrays; None when the stream ended before a message. A message that is
    not one (a header that is not JSON or lists arrays badly, arrays of other than numbers, more than `max_bytes`
    of arrays, a header over `MAX_HEADER_BYTES`) is a ValueError; one that ends early an EOFError."""
    size = stream.read(HEADER.size)
    if len(size) < HEADER.size:
        return None
    length = HEADER.unpack(size)[0]
    if length > MAX_HEADER_BYTES:
        raise ValueError(f"a header of {length} bytes (at most {MAX_HEADER_BYTES})")
    try:
        header = json.loads(_read_exactly(stream, length))
    except RecursionError:  # json recurses once per level; joshua_core, whose reader says so for files, is not here
        raise ValueError("a header nested too deeply") from None
    listed = header.pop("arrays", None) if isinstance(header, dict) else None
    if not isinstance(listed, list):
        raise ValueError("the header is not an object listing its arrays")
    layouts = [_layout(entry) for entry in listed]
    total = sum(math.prod(shape) * dtype.itemsize for _, dtype, shape in layouts)
    if max_bytes is not None and total > max_bytes:
        raise ValueError(f"arrays of {total} bytes (at most {max_bytes})")
    arrays = {}
    for name, dtype, shape in layouts:
        count = math.prod(shape)
        arrays[name] = np.frombuffer(_read_exactly(stream, count * dtype.itemsize), dtype).reshape(shape)
    return header, arrays


def _layout(entry: object) -> tuple[str, np.dtype, tuple[int, ...]]:
    """(name, dtype, shape) of one listed array: numbers only, a shape of at most `MAX_DIMENSIONS` counts."""
    if not isinstance(entry, dict) or not isinstance(entry.get("name"), str):
        raise ValueError(f"an array listed as {str(entry)[:80]}")
    name, shape = entry["name"], entry.get("shape")
    try:
        dtype = np.dtype(str(entry.get("dtype")))
    except TypeError:
        raise ValueError(f"array {name!r}: dtype {str(entry.get('dtype'))[:40]!r} is not one") from None
    if dtype.kind not in NUMBER_KINDS:
        raise ValueError(f"array {name!r}: dtype {dtype} is not a number")
    if not (isinstance(shape, list) and len(shape) <= MAX_DIMENSIONS and all(_count(n) for n in shape)):
        raise ValueError(f"array {name!r}: shape {str(shape)[:80]} is not a list of counts")
    return name, dtype, tuple(shape)


def _count(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= MAX_COUNT


def _read_exactly(stream: IO[bytes], size: int) -> bytes:
    data = stream.read(size)
    if len(data) != size:
        raise EOFError(f"the message ended after {len(data)} of {size} bytes")
    return data


def _features(features: dict[str, Any]) -> dict[str, Any]:
    return {key: {"type": feature.type.value, "shape": list(feature.shape)} for key, feature in features.items()}


def serve(folder: Path, device: str, requests: IO[bytes], replies: IO[bytes]) -> None:
    """Load the policy in `folder` onto `device` and answer `requests` until they end."""
    try:
        import torch
        from lerobot.configs.policies import PreTrainedConfig
        from lerobot.policies.factory import get_policy_class, make_pre_post_processors
    except ImportError as error:
        send(replies, {"error": f"lerobot cannot be imported by {sys.executable}: {error}"})
        return
    try:
        config = PreTrainedConfig.from_pretrained(folder)
        config.device = device
        policy = get_policy_class(config.type).from_pretrained(folder, config=config)
        policy.eval()
        overrides = {"device_processor": {"device": device}}
        preprocessor, postprocessor = make_pre_post_processors(
            config, pretrained_path=str(folder), preprocessor_overrides=overrides
        )
    except Exception as error:  # whatever lerobot raises on a folder it cannot load is the user's to read
        send(replies, {"error": f"{folder}: lerobot {_version()} cannot load the policy: {_one_line(error)}"})
        return
    described = {"type": config.type, "input_features": _features(config.input_features)}
    send(replies, {"policy": described | {"output_features": _features(config.output_features)}})
    while (message := receive(requests)) is not None:
        header, arrays = message
        try:
            if header["op"] == "reset":
                policy.reset()
                send(replies, {})
                continue
            batch: dict[str, Any] = {"task": header["task"]}
            for key, array in arrays.items():
                value = torch.from_numpy(array.copy())
                if key.startswith(IMAGE_PREFIX):  # as lerobot's preprocess_observation: HWC uint8 -> CHW in [0, 1]
                    value = value.permute(0, 3, 1, 2).contiguous().float() / 255.0
                batch[key] = value
            with torch.inference_mode():
                action = postprocessor(policy.select_action(preprocessor(batch)))
            send(replies, {}, {"action": action.detach().to("cpu", torch.float32).numpy()})
        except Exception as error:  # a failure of the policy on this batch goes back as one line
            send(replies, {"error": f"the policy failed on a batch: {_one_line(error)}"})
            return


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("lerobot")
    except PackageNotFoundError:
        return "(version unknown)"


def _one_line(error: BaseException) -> str:
    return " ".join(f"{type(error).__name__}: {error}".split())


def main() -> None:
    replies = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # lerobot's prints must not corrupt the replies
    serve(Path(sys.argv[1]), sys.argv[2], sys.stdin.buffer, replies)


if __name__ == "__main__":
    main()
