"""The ONNX graph of an `MlpPolicy`, built node by node with `onnx.helper` and checked with `onnx.checker`.

Why onnx.helper rather than jax2onnx or torch.onnx: every trainer describes its policy as the same small
MLP (joshua_core.policy), so one builder of a dozen nodes serves Flax and torch weights alike, without
tracing either framework or adding its exporter as a dependency; the graph is exactly the documented
formula, normalisation included.

    observation (batch, obs) float32 -> Cast float64 -> Sub mean -> Div std -> Clip +-obs_clip -> Cast float32
      -> [MatMul W, Add b, activation] * hidden -> MatMul W, Add b -> (Tanh) -> Clip [-1, 1] -> action (batch, act)
"""

from __future__ import annotations

from typing import Any

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

from joshua_core.policy import MlpPolicy

INPUT_NAME = "observation"
OUTPUT_NAME = "action"
OPSET = 17  # onnxruntime runs it everywhere; everything used here exists since opset 13
IR_VERSION = 8  # the IR version of opset 17


class _Graph:
    """Nodes and initializers being collected, each output named after the node that makes it."""

    def __init__(self) -> None:
        self.nodes: list[onnx.NodeProto] = []
        self.initializers: list[onnx.TensorProto] = []

    def constant(self, name: str, value: np.ndarray) -> str:
        self.initializers.append(numpy_helper.from_array(value, name))
        return name

    def node(self, op: str, inputs: list[str], name: str, **attributes: Any) -> str:
        self.nodes.append(helper.make_node(op, inputs, [name], name=name, **attributes))
        return name


def _activation(graph: _Graph, kind: str, x: str, name: str) -> str:
    if kind == "relu":
        return graph.node("Relu", [x], name)
    if kind == "tanh":
        return graph.node("Tanh", [x], name)
    if kind == "elu":
        return graph.node("Elu", [x], name, alpha=1.0)
    return graph.node("Mul", [x, graph.node("Sigmoid", [x], f"{name}_sigmoid")], name)  # swish


def _normalized(graph: _Graph, policy: MlpPolicy) -> str:
    x = graph.node("Cast", [INPUT_NAME], "obs_f64", to=TensorProto.DOUBLE)
    x = graph.node("Sub", [x, graph.constant("obs_mean", policy.obs_mean.astype(np.float64))], "obs_centred")
    x = graph.node("Div", [x, graph.constant("obs_std", policy.obs_std.astype(np.float64))], "obs_scaled")
    if np.isfinite(policy.obs_clip):
        low = graph.constant("obs_clip_low", np.array(-policy.obs_clip, np.float64))
        high = graph.constant("obs_clip_high", np.array(policy.obs_clip, np.float64))
        x = graph.node("Clip", [x, low, high], "obs_clipped")
    return graph.node("Cast", [x], "obs_normalized", to=TensorProto.FLOAT)


def policy_graph(policy: MlpPolicy, *, name: str = "joshua_policy") -> onnx.ModelProto:
    """The checked ONNX model computing `policy`'s action from a batch of observations."""
    graph = _Graph()
    x = _normalized(graph, policy)
    last = len(policy.layers) - 1
    for index, layer in enumerate(policy.layers):
        x = graph.node("MatMul", [x, graph.constant(f"W{index}", layer.weight.astype(np.float32))], f"matmul{index}")
        x = graph.node("Add", [x, graph.constant(f"b{index}", layer.bias.astype(np.float32))], f"dense{index}")
        if index < last:
            x = _activation(graph, policy.activation, x, f"hidden{index}")
    if policy.output == "tanh":
        x = graph.node("Tanh", [x], "squashed")
    low = graph.constant("action_low", np.array(-1.0, np.float32))
    high = graph.constant("action_high", np.array(1.0, np.float32))
    graph.node("Clip", [x, low, high], OUTPUT_NAME)
    model = helper.make_model(
        helper.make_graph(
            graph.nodes,
            name,
            [helper.make_tensor_value_info(INPUT_NAME, TensorProto.FLOAT, ["batch", policy.observation_size])],
            [helper.make_tensor_value_info(OUTPUT_NAME, TensorProto.FLOAT, ["batch", policy.action_size])],
            graph.initializers,
        ),
        opset_imports=[helper.make_opsetid("", OPSET)],
        producer_name="joshua-export",
    )
    model.ir_version = IR_VERSION
    onnx.checker.check_model(model, full_check=True)
    return model
