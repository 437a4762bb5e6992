"""Entry point of joshua-mirror: registers the MIRROR mode, its options, `joshua mirror-replay`, `joshua deploy`
and `joshua checklist`.

Imports nothing heavy: the options module (options_pb2) imports only protobuf and the core schema. The options
register no settings function: each is its own settings, the message the MIRROR mode gets from
`RunContext.settings`.
"""

from __future__ import annotations

from joshua_core import hookimpl
from joshua_core.plugins import Registrar


@hookimpl
def joshua_register_modes(registry: Registrar) -> None:
    registry.add(
        "MIRROR",
        "joshua_mirror.mode:MirrorMode",
        "digital twin: mirrors encoder topics (Float64, JointState) or a LeRobot arm into the simulation in real time",
    )


@hookimpl
def joshua_register_options(registry: Registrar) -> None:
    registry.add("mirror", "joshua_mirror.options_pb2:mirror", "MIRROR: how encoder values reach the simulation")
    registry.add(
        "mirror_topic_mappings",
        "joshua_mirror.options_pb2:mirror_topic_mappings",
        "MIRROR, deploy: the encoder topic, actuator and offset of each joint",
    )


@hookimpl
def joshua_register_commands(registry: Registrar) -> None:
    registry.add(
        "mirror-replay",
        "joshua_mirror.replay:MirrorReplayCommand",
        "publish a trajectory CSV as the encoder topics of a MIRROR config, in real time",
    )
    registry.add(
        "deploy",
        "joshua_mirror.deploy:DeployCommand",
        "run an exported policy (joshua export) on a robot over ROS 2, through a MIRROR config's topics",
    )
    registry.add(
        "checklist",
        "joshua_mirror.checklist:ChecklistCommand",
        "print the arm-side checklist of a trained run: what JOSHUA checked, what to verify on the arm, how to deploy",
    )
