"""Check a commit message's subject: at most 72 characters, so that `git log --oneline` and the hosts' lists show
it whole; the story goes in the body. The commit-msg hook of .pre-commit-config.yaml (exit 1 with one line).

    python tools/check_commit_msg.py MESSAGE_FILE
"""

from __future__ import annotations

import sys
from pathlib import Path

MAX_SUBJECT = 72


def subject(message: str) -> str:
    """The message's first line that is not a git comment (`#`) or blank: the subject git shows."""
    for line in message.splitlines():
        if line.strip() and not line.startswith("#"):
            return line.rstrip()
    return ""


def findings(message: str) -> list[str]:
    """What is wrong with the message's subject, one line each (none when it keeps to the rule)."""
    first = subject(message)
    if not first:
        return ["the commit message has no subject"]
    if len(first) > MAX_SUBJECT:
        return [f"the subject has {len(first)} characters, more than {MAX_SUBJECT}: say the why in the body"]
    return []


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: check_commit_msg.py MESSAGE_FILE", file=sys.stderr)
        return 2
    problems = findings(Path(argv[0]).read_text(encoding="utf-8"))
    for problem in problems:
        print(f"check_commit_msg: {problem}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
