"""Publishers of the mapped topics whose message type is not the one the mirror reads, seen in the ROS graph.

DDS never delivers a message of another type to a subscription, so without this check a robot publishing
std_msgs/Float32 on a topic mapped as Float64 looks like a silent robot. Publishers come and go, so the
graph is checked again at every status period.
"""

from __future__ import annotations

from typing import Any

UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"  # what the graph names a publisher whose node it has not learnt yet


class TypeChecker:
    """Watches the mapped topics (resolved names -> the expected type) for publishers of another type."""

    def __init__(self, node: Any, expected: dict[str, str], reader: str = "mirror") -> None:
        self.node = node
        self.expected = expected
        self.reader = reader  # who reads the topics, in the lines said: "mirror" or "deploy"
        self.seen: dict[str, dict[str, Any]] = {}  # every mismatch of the run, by topic
        self.current: dict[str, str] = {}  # topic -> the wrong types published now
        self.said: dict[str, str] = {}  # topic -> the last line said about it, while its mismatch lasts

    def poll(self) -> list[str]:
        """Check the graph now; one line per topic whose mismatch is new or changed (a new type or publisher name)."""
        graph = dict(self.node.get_topic_names_and_types())
        current: dict[str, str] = {}
        new = []
        for topic, expected in self.expected.items():
            if not set(graph.get(topic, [])) - {expected}:
                continue
            wrong = [info for info in self.node.get_publishers_info_by_topic(topic) if info.topic_type != expected]
            if not wrong:  # only a subscriber of another type, e.g. a tool echoing the topic
                continue
            entry = self.seen.setdefault(topic, {"expected": expected, "published_as": [], "publishers": []})
            for info in wrong:
                entry["published_as"] = sorted({*entry["published_as"], info.topic_type})
                if info.node_name != UNKNOWN_NODE:  # the endpoint was discovered before its node's name
                    name = f"{info.node_namespace.rstrip('/')}/{info.node_name}"
                    entry["publishers"] = sorted({*entry["publishers"], name})
            current[topic] = ", ".join(sorted({info.topic_type for info in wrong}))
            line = self.describe(topic)
            if self.said.get(topic) != line:
                new.append(line)
                self.said[topic] = line
        self.current = current
        self.said = {topic: line for topic, line in self.said.items() if topic in current}
        return new

    def describe(self, topic: str) -> str:
        entry = self.seen[topic]
        by = f" by {', '.join(entry['publishers'])}" if entry["publishers"] else ""
        return (
            f"{topic} is published as {' and '.join(entry['published_as'])}{by}, "
            f"but the {self.reader} reads {entry['expected']}: those messages never arrive"
        )

    def status(self) -> str:
        """The status line's part for the mismatches seen at the last check ('' when none)."""
        return "".join(f" | WRONG TYPE {topic}: {types}" for topic, types in sorted(self.current.items()))

    def error(self) -> str | None:
        """One line for every mismatch seen during the run, or None."""
        if not self.seen:
            return None
        return f"{self.reader}: wrong message type: " + "; ".join(self.describe(topic) for topic in sorted(self.seen))
