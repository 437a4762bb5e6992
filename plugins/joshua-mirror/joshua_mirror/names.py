"""ROS names of a MIRROR config and of the command line, checked by rclpy's own validators before any work.

rclpy refuses a bad topic or node name only when the subscription, publisher or node is made, with a
message of several lines; checked here, the name is one line naming its field (exit 2), for the mirror,
`mirror-replay` and `deploy` alike, whichever of its names a command uses.
"""

from __future__ import annotations

from collections.abc import Callable

from joshua_core.errors import UsageError
from joshua_mirror.options_pb2 import MirrorOptions
from joshua_mirror.ros import import_rclpy

EXPANDED_AS = "joshua_mirror"  # the node name a relative ('~/x') topic is expanded with, to validate it


def check_topic(topic: str, field: str) -> str:
    """`topic` when rclpy takes it as a topic name (after expansion); else a UsageError naming `field`."""
    import_rclpy()
    from rclpy.exceptions import NameValidationException
    from rclpy.expand_topic_name import expand_topic_name
    from rclpy.validate_full_topic_name import validate_full_topic_name

    try:
        validate_full_topic_name(expand_topic_name(topic, EXPANDED_AS, "/"))
    except (NameValidationException, ValueError) as error:
        raise UsageError(f"{field}: {topic!r} is not a ROS topic name: {_reason(error)}") from None
    return topic


def check_node_name(name: str, field: str) -> str:
    """`name` when rclpy takes it as a node name; else a UsageError naming `field`."""
    import_rclpy()
    from rclpy.exceptions import NameValidationException
    from rclpy.validate_node_name import validate_node_name

    try:
        validate_node_name(name)
    except NameValidationException as error:
        raise UsageError(f"{field}: {name!r} is not a ROS node name: {_reason(error)}") from None
    return name


def topic_argument(option: str) -> Callable[[str], str]:
    """An argparse `type=` for a command-line option naming a topic: a bad name is one line before any work."""
    return lambda text: check_topic(text, option)


def check_config_names(options: MirrorOptions, topics: dict[str, str]) -> None:
    """The node name and the topics set in a MIRROR config; `topics`: each topic the mappings name, by field."""
    if options.node_name:
        check_node_name(options.node_name, "simulation.mirror.node_name")
    if options.message_type == MirrorOptions.JOINT_STATE and options.joint_state_topic:
        check_topic(options.joint_state_topic, "simulation.mirror.joint_state_topic")
    for field, topic in topics.items():
        check_topic(topic, field)


def _reason(error: Exception) -> str:
    """rclpy's explanation alone: its first line without the 'Invalid ...: ' head, the C source or the caret."""
    line = str(error).splitlines()[0].rstrip(":")
    line = line.split(" is invalid: ", 1)[-1] if " is invalid: " in line else line.split(": ", 1)[-1]
    return line.split(", at /", 1)[0]
