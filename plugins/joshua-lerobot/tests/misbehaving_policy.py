"""A policy process that breaks the protocol in one way (`JOSHUA_TEST_ANSWER`), run as `--lerobot-python`'s
server in place of lerobot's: it describes a policy with 6 joint values in and out, then answers
`select_action` wrongly. What JOSHUA's side does with a peer that lies, hangs or dies is tested against it."""

from __future__ import annotations

import os
import struct
import sys
import threading

import numpy as np

from joshua_lerobot.policy_server import receive, send

JOINTS = 6
DESCRIPTION = {
    "policy": {
        "type": "fake",
        "input_features": {"observation.state": {"type": "STATE", "shape": [JOINTS]}},
        "output_features": {"action": {"type": "ACTION", "shape": [JOINTS]}},
    }
}


def raw(replies, header: bytes, payload: bytes = b"") -> None:
    replies.write(struct.pack("<I", len(header)) + header + payload)
    replies.flush()


def main() -> None:
    answer = os.environ["JOSHUA_TEST_ANSWER"]
    requests, replies = sys.stdin.buffer, sys.stdout.buffer
    if answer == "hang_loading":
        threading.Event().wait()  # never answers; JOSHUA's deadline stops it
    if answer == "partial_description":
        replies.write(struct.pack("<I", 100) + b'{"policy": {"type"')  # promises 100 bytes, sends 18, then waits
        replies.flush()
        threading.Event().wait()
    if answer == "no_description":
        send(replies, {"hello": 1})
    else:
        send(replies, DESCRIPTION)
    while (message := receive(requests)) is not None:
        header, arrays = message
        if header["op"] == "reset":
            send(replies, {})
            continue
        batch = len(arrays["observation.state"])
        action = np.zeros((batch, JOINTS), np.float32)
        if answer == "one_row":
            send(replies, {}, {"action": action[:1]})
        elif answer == "nan":
            action[-1, 2] = np.nan
            send(replies, {}, {"action": action})
        elif answer == "one_d":
            send(replies, {}, {"action": action[0]})
        elif answer == "too_wide":
            send(replies, {}, {"action": np.zeros((batch, JOINTS + 1), np.float32)})
        elif answer == "strings":
            send(replies, {}, {"action": np.array([["a"] * JOINTS] * batch)})
        elif answer == "not_json":
            raw(replies, b"{not json")
        elif answer == "deep_json":
            raw(replies, b"[" * 100_000 + b"]" * 100_000)
        elif answer == "huge_length":
            replies.write(struct.pack("<I", 2**32 - 1))
            replies.flush()
        elif answer == "huge_shape":
            raw(replies, b'{"arrays": [{"name": "action", "dtype": "<f4", "shape": [1099511627776, 1099511627776]}]}')
        elif answer == "huge_total":
            raw(replies, b'{"arrays": [{"name": "action", "dtype": "<f4", "shape": [1048576, 1048576]}]}')
        elif answer == "short_then_exit":
            raw(replies, b'{"arrays": [{"name": "action", "dtype": "<f4", "shape": [%d, 6]}]}' % batch, b"\0" * 8)
            return
        elif answer == "dies":
            sys.exit(3)
        else:
            raise SystemExit(f"unknown answer {answer}")


if __name__ == "__main__":
    main()
