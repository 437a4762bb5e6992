"""Reading a JSON file that a user may have damaged: the object in it, or one error naming the file and what is
wrong, so that every reader of run configs, metrics, manifests and contracts reports a bad file the same way."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from joshua_core.errors import UsageError

_JSON_TYPES = {list: "array", str: "string", int: "number", float: "number", bool: "boolean", type(None): "null"}


def read_json_object(path: Path, what: str, error: type[Exception] = UsageError) -> dict[str, Any]:
    """The JSON object in `path`. A file that cannot be read, is not UTF-8 JSON, nests deeper than the parser
    goes or holds no object raises `error` (the caller's type, so its exit code stays) with the one-line message
    "PATH: cannot read WHAT: REASON"; `what` says what the file is for (e.g. "the run's config")."""
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except OSError as failure:
        reason = failure.strerror or str(failure)
    except UnicodeDecodeError as failure:
        reason = f"not UTF-8 text (byte {failure.start} is {failure.object[failure.start]:#04x})"
    except ValueError as failure:  # JSONDecodeError, and a number of more digits than int() takes
        reason = f"not valid JSON: {failure}"
    except RecursionError:  # json recurses once per level: deep nesting (100000 lists) exhausts Python's stack
        reason = "nested too deeply"
    else:
        if isinstance(document, dict):
            return document
        reason = f"it holds a JSON {_JSON_TYPES.get(type(document), type(document).__name__)}, not an object"
    raise error(f"{path}: cannot read {what}: {reason}")
