"""The task layer: every built-in term gives the same values on numpy and inside jax.jit, and tasks
built from config report bad terms and parameters by name."""

from __future__ import annotations

import dataclasses
import zlib
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from google.protobuf import text_format

from joshua_core import hookimpl
from joshua_core.config_pb2 import TaskConfig
from joshua_core.errors import ConfigError
from joshua_core.plugins import PluginHost, PluginInfo, Registrar
from joshua_core.resources import resolve_data_path
from joshua_core.tasks import (
    BoundTerm,
    Task,
    TaskSpec,
    TermContext,
    TermKind,
    TermSpec,
    build_task,
    load_task_spec,
    parse_param,
)
from joshua_core.tasks.grasping import GRASP_TERMS
from joshua_core.tasks.handles import Actuators, Body, Joints, resolve_handle
from joshua_core.tasks.terms import BUILTIN_TERMS
from joshua_tasks import TASKS

NUM_ENVS = 4
# Built-in terms no built-in task uses, with parameters for the SO-ARM100 scene.
EXTRA_TERMS = TaskSpec(
    name="extra_terms",
    summary="terms the built-in tasks do not use",
    model_path="so_arm100/scene.xml",
    frame_skip=1,
    episode_length=10,
    observations=(TermSpec("site_pos", params={"site": "gripper"}),),
    rewards=(
        TermSpec("joint_vel_l2", -1.0),
        TermSpec("body_command_tanh", 1.0, {"body": "moving_jaw", "name": "spot", "std": 0.2}),
        TermSpec("carried_command_tanh", 1.0, {"body": "moving_jaw", "name": "spot", "height": 0.1, "std": 0.2}),
        TermSpec(
            "sensors_above", 1.0, {"first": "gripper_touch_fixed", "second": "gripper_touch_moving", "threshold": 0.1}
        ),
    ),
    commands={"spot": 3},
)
_ANT_JOINTS = {"joints": ("hip_1", "ankle_1", "hip_4", "ankle_4")}
EXTRA_ANT_TERMS = TaskSpec(
    name="extra_ant_terms",
    summary="terms of Isaac-style tasks, on the Ant",
    model_path="ant/ant.xml",
    frame_skip=1,
    episode_length=10,
    observations=(
        TermSpec("body_height", params={"body": "torso"}),
        TermSpec("body_contact_force", params={"body": "front_left_shin", "scale": 0.1}),
        TermSpec("joint_pos_normalized", params=_ANT_JOINTS),
    ),
    rewards=(
        TermSpec("alive", 0.5),
        TermSpec("body_upright_above", 0.1, {"body": "torso", "min_upright": 0.93}),
        TermSpec("joints_near_upper_limit", -0.1, {**_ANT_JOINTS, "threshold": 0.0}),
        TermSpec("free_body_command_progress", 1.0, {"joint": "root", "name": "spot"}),
    ),
    commands={"spot": 3},
)
CONSTANT_TERMS = {"alive"}  # the same on every state by design


@pytest.fixture(scope="module")
def plugins() -> PluginHost:
    return PluginHost.discover()


def compile_model(spec: TaskSpec) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(resolve_data_path(spec.model_path)))


def random_states(task: Task, model: mujoco.MjModel, seed: int) -> TermContext:
    """NUM_ENVS varied, physically reached states of the task's model, as a numpy TermContext."""
    rng = np.random.default_rng(seed)
    data = mujoco.MjData(model)
    fields: dict[str, list[np.ndarray]] = {name: [] for name in ("qpos", "qvel", "prev_qpos", "xpos", "xquat")}
    fields.update(site_xpos=[], sensordata=[], cfrc_ext=[], ctrl=[])
    for _ in range(NUM_ENVS):
        mujoco.mj_resetData(model, data)
        if task.keyframe_id >= 0:
            mujoco.mj_resetDataKeyframe(model, data, task.keyframe_id)
        data.qvel[:] = rng.normal(0.0, 0.3, model.nv)
        data.ctrl[:] = task.action_to_ctrl(np, rng.uniform(-1, 1, model.nu), ctrl=task.reset_ctrl(np, 1))[0]
        mujoco.mj_step(model, data, int(rng.integers(5, 150)))  # some in flight, most landed (a dropped Ant)
        fields["prev_qpos"].append(data.qpos.copy())
        mujoco.mj_step(model, data, task.frame_skip)
        mujoco.mj_rnePostConstraint(model, data)
        for name in fields:
            if name != "prev_qpos":
                fields[name].append(np.array(getattr(data, name)))
    arrays = {name: np.stack(values) for name, values in fields.items()}
    commands = {name: rng.uniform(-0.3, 0.3, (NUM_ENVS, size)) for name, size in task.commands.items()}
    # Push some environments over the thresholds, so that flags and terminations take both values:
    arrays["qpos"][0, 2] = 5.0  # a free joint's height far out of range
    arrays["xquat"][0, :] = [0.0, 1.0, 0.0, 0.0]  # bodies upside down
    arrays["xpos"][1, :, 2] = 0.1  # bodies lifted
    arrays["xpos"][2, :, 2] = -0.1  # bodies dropped
    arrays["sensordata"][1, :] = 1.0  # touch pads pressed
    # ... with the sites on alternate sides of the last body (the SO-ARM100's pads, sites 2 and 3: a grasp)
    arrays["site_xpos"][1, 0::2] = arrays["xpos"][1, -1] + [0.02, 0.0, 0.0]
    arrays["site_xpos"][1, 1::2] = arrays["xpos"][1, -1] - [0.02, 0.0, 0.0]
    arrays["site_xpos"][3] = arrays["xpos"][3, -1] + 0.01  # every site (the gripper's) at the last body
    for value in commands.values():
        value[1] = arrays["xpos"][1, -1, : value.shape[1]]  # the last body (the cube) at its goal, pinched
        value[3] = arrays["xpos"][3, -1, : value.shape[1]]  # ... and at its goal, the pads free (let go)
    return TermContext(
        xp=np,
        dt=task.dt,
        action=rng.uniform(-1, 1, (NUM_ENVS, model.nu)),
        prev_action=rng.uniform(-1, 1, (NUM_ENVS, model.nu)),
        episode_step=rng.integers(0, 100, NUM_ENVS),
        commands=commands,
        **arrays,
    )


class RecordingRandom:
    """A numpy random source that remembers its draws, so that a ReplayRandom can give JAX the same."""

    def __init__(self, seed: int) -> None:
        self.generator = np.random.default_rng(seed)
        self.draws: list[np.ndarray] = []

    def uniform(self, shape: tuple[int, ...], low: Any = 0.0, high: Any = 1.0) -> np.ndarray:
        self.draws.append(self.generator.uniform(low, high, size=shape))
        return self.draws[-1]

    def normal(self, shape: tuple[int, ...]) -> np.ndarray:
        self.draws.append(self.generator.standard_normal(shape))
        return self.draws[-1]


class ReplayRandom:
    def __init__(self, draws: list[np.ndarray]) -> None:
        self.draws = list(draws)

    def uniform(self, shape: tuple[int, ...], low: Any = 0.0, high: Any = 1.0) -> Any:
        return self._next(shape)

    def normal(self, shape: tuple[int, ...]) -> Any:
        return self._next(shape)

    def _next(self, shape: tuple[int, ...]) -> Any:
        draw = self.draws.pop(0)
        assert draw.shape == tuple(shape)
        return jnp.asarray(draw)


ARRAY_FIELDS = ("qpos", "qvel", "prev_qpos", "xpos", "xquat", "site_xpos", "sensordata", "cfrc_ext", "ctrl", "action")
ARRAY_FIELDS += ("prev_action", "episode_step")


def on_jax(term: BoundTerm, ctx: TermContext, random: ReplayRandom | None) -> Any:
    """The term evaluated inside jax.jit on the same state (float32, JAX's default)."""
    arrays = {name: jnp.asarray(getattr(ctx, name)) for name in ARRAY_FIELDS}
    commands = {name: jnp.asarray(value) for name, value in ctx.commands.items()}

    @jax.jit
    def evaluate(arrays: dict[str, Any], commands: dict[str, Any]) -> Any:
        result = term(TermContext(xp=jnp, dt=ctx.dt, commands=commands, random=random, **arrays))
        if isinstance(result, TermContext):
            return {"qpos": result.qpos, "qvel": result.qvel, **result.commands}
        return result

    return evaluate(arrays, commands)


def all_bound_terms(plugins: PluginHost) -> list[tuple[Task, mujoco.MjModel, BoundTerm]]:
    found = []
    for spec in (*TASKS.values(), EXTRA_TERMS, EXTRA_ANT_TERMS):
        model = compile_model(spec)
        task = build_task(spec, model, plugins)
        for kind in TermKind:
            terms = {
                TermKind.OBSERVATION: task.observation_terms,
                TermKind.REWARD: task.reward_terms,
                TermKind.TERMINATION: task.termination_terms,
                TermKind.RESET: task.reset_terms,
                TermKind.METRIC: task.metric_terms,
                TermKind.EVENT: (),  # tests/test_randomization.py
            }[kind]
            found += [(task, model, term) for term in terms]
    return found


def test_the_parity_cases_cover_every_builtin_term(plugins: PluginHost) -> None:
    used = {term.function.__name__ for _, _, term in all_bound_terms(plugins)}
    assert used == set(BUILTIN_TERMS) | set(GRASP_TERMS)


def test_every_builtin_term_gives_the_same_values_on_numpy_and_in_jax_jit(plugins: PluginHost) -> None:
    checked = 0
    for task, model, term in all_bound_terms(plugins):
        label = f"{task.name}/{term.kind.value}/{term.name}"
        seed = zlib.crc32(label.encode())  # each term's own states, whatever terms come before it
        ctx = random_states(task, model, seed=seed)
        if term.kind is TermKind.RESET:
            recording = RecordingRandom(seed=seed)
            expected_ctx = term(ctx.replace(random=recording))
            expected = {"qpos": expected_ctx.qpos, "qvel": expected_ctx.qvel, **expected_ctx.commands}
            actual = on_jax(term, ctx, ReplayRandom(recording.draws))
            assert recording.draws, label
            for name, value in expected.items():
                np.testing.assert_allclose(np.asarray(actual[name]), value, rtol=1e-5, atol=1e-5, err_msg=label)
        else:
            expected = np.asarray(term(ctx))
            actual = np.asarray(on_jax(term, ctx, None))
            assert actual.shape == expected.shape, label
            if expected.dtype == bool:
                assert expected.any() and not expected.all(), f"{label} takes one value on the test states"
                np.testing.assert_array_equal(actual, expected, err_msg=label)
            else:
                varied = np.ptp(expected) > 0 or term.function.__name__ in CONSTANT_TERMS
                assert varied, f"{label} is constant on the test states: they test too little"
                np.testing.assert_allclose(actual, expected, rtol=1e-5, atol=1e-5, err_msg=label)
        checked += 1
    assert checked >= len(BUILTIN_TERMS) + len(GRASP_TERMS)


def test_every_builtin_task_builds_and_reads_only_what_it_needs(plugins: PluginHost) -> None:
    sizes = {}
    for name, spec in TASKS.items():
        task = build_task(load_task_spec(name, plugins), compile_model(spec), plugins)
        sizes[name] = task.observation_size
        assert {"qpos", "action"} <= task.fields
    assert sizes["ant_locomotion"] == 105  # Gymnasium Ant-v5: 13 qpos + 14 qvel + 13 bodies x 6 forces
    ant = build_task(TASKS["ant_locomotion"], compile_model(TASKS["ant_locomotion"]), plugins)
    assert "cfrc_ext" in ant.fields and "site_xpos" not in ant.fields
    pick_place = build_task("so_arm100_pick_place", compile_model(TASKS["so_arm100_pick_place"]), plugins)
    layout = dict(pick_place.observation_layout)  # (name, width) of each observation term, in order
    assert [name for name, _ in pick_place.observation_layout] == [t.name for t in pick_place.observation_terms]
    assert layout["joint_vel"] == 6 and layout["touch_fixed"] == 1 and sum(layout.values()) == sizes[pick_place.name]


def task_config(text: str) -> TaskConfig:
    return text_format.Parse(text, TaskConfig())


def build_reach(plugins: PluginHost, config_text: str) -> Task:
    spec = TASKS["so_arm100_reach"]
    return build_task("so_arm100_reach", compile_model(spec), plugins, task_config(config_text))


def test_unknown_term_parameter_is_an_error_naming_the_term_and_its_parameters(plugins: PluginHost) -> None:
    with pytest.raises(ConfigError) as error:
        build_reach(plugins, 'terms { name: "near" params { key: "sigma" value: "0.1" } }')
    message = str(error.value)
    assert "term 'near'" in message and "'sigma'" in message and "site, name, std" in message


def test_parameter_of_the_wrong_type_is_an_error_naming_the_parameter(plugins: PluginHost) -> None:
    with pytest.raises(ConfigError, match=r"term 'near', parameter 'std': expected a number, got 'wide'"):
        build_reach(plugins, 'terms { name: "near" params { key: "std" value: "wide" } }')


def test_unknown_model_name_suggests_the_close_one(plugins: PluginHost) -> None:
    with pytest.raises(ConfigError) as error:
        build_reach(plugins, 'terms { name: "distance" params { key: "site" value: "griper" } }')
    assert "term 'distance', parameter 'site'" in str(error.value) and "Did you mean: gripper" in str(error.value)


def test_a_touch_parameter_naming_another_kind_of_sensor_is_an_error_naming_it(plugins: PluginHost) -> None:
    params = {"body": "moving_jaw", "first": "wrist_force", "second": "gripper_touch_moving", "threshold": "0.05"}
    text = " ".join(f'params {{ key: "{key}" value: "{value}" }}' for key, value in params.items())
    expected = r"term 'held', parameter 'first': sensor 'wrist_force' is not a touch sensor"
    with pytest.raises(ConfigError, match=expected):
        build_reach(plugins, f'terms {{ name: "held" term: "body_pinched" kind: REWARD {text} }}')


def test_handles_know_free_joints_limits_and_the_joints_actuators_drive() -> None:
    model = compile_model(EXTRA_ANT_TERMS)
    torso, thigh = resolve_handle(model, Body, "torso"), resolve_handle(model, Body, "back_thigh")
    assert (torso.free_qpos_adr, torso.free_dof_adr, thigh.free_qpos_adr) == (0, 0, -1)
    ankle = resolve_handle(model, Joints, ["ankle_1"])
    np.testing.assert_allclose((ankle.lower[0], ankle.upper[0]), np.radians([30, 70]))
    motors = resolve_handle(model, Actuators, [])  # ant.xml lists its motors from leg 4 on
    assert motors.names[:2] == ("hip_4", "ankle_4")
    assert motors.dof_index[:2] == (model.joint("hip_4").dofadr[0], model.joint("ankle_4").dofadr[0])
    with pytest.raises(ValueError, match="no actuator named 'hip_9'. Did you mean: hip_4"):
        resolve_handle(model, Actuators, ["hip_9"])
    with pytest.raises(ValueError, match="no body named 'head'. Its bodies: world, torso"):
        resolve_handle(model, Body, "head")


def test_unknown_term_and_unknown_override_are_errors(plugins: PluginHost) -> None:
    with pytest.raises(ConfigError, match=r"reward term 'speed'.*no term named 'forward_velocty'.*Did you mean"):
        build_reach(plugins, 'terms { name: "speed" term: "forward_velocty" kind: REWARD }')
    with pytest.raises(ConfigError, match=r"has no term 'nearr' \(its terms: .*near"):
        build_reach(plugins, 'terms { name: "nearr" weight: 2 }')


def test_config_changes_weights_and_params_adds_terms_and_zero_disables(plugins: PluginHost) -> None:
    task = build_reach(
        plugins,
        'episode_length: 7 terms { name: "near" weight: 0 } '
        'terms { name: "distance" weight: -2 params { key: "site" value: "wrist" } } '
        'terms { name: "slow" term: "joint_vel_l2" kind: REWARD weight: -0.1 }',
    )
    weights = {term.name: term.weight for term in task.reward_terms}
    assert weights == {"distance": -2.0, "action_rate": -0.005, "slow": -0.1}
    assert task.reward_terms[0].params["site"].name == "wrist" and task.episode_length == 7


def test_config_keyframe_sets_where_episodes_start_and_an_unknown_one_lists_the_models(plugins: PluginHost) -> None:
    model = mujoco.MjModel.from_xml_path(str(resolve_data_path("ant/ant_mjx.xml")))
    default = build_task("ant_locomotion", model, plugins, task_config(""))
    standing = build_task("ant_locomotion", model, plugins, task_config('keyframe: "standing"'))
    assert default.keyframe_id == -1 and default.initial_qpos[2] == pytest.approx(0.75)
    assert standing.keyframe_id == 0
    np.testing.assert_array_equal(standing.initial_qpos, model.key("standing").qpos)
    with pytest.raises(ConfigError, match=r"keyframe 'sitting'.*its keyframes: standing"):
        build_task("ant_locomotion", model, plugins, task_config('keyframe: "sitting"'))


def test_term_returning_the_wrong_shape_is_reported(plugins: PluginHost) -> None:
    spec = dataclasses.replace(
        TASKS["so_arm100_reach"], rewards=(TermSpec("site_pos", params={"site": "gripper"}, name="where"),)
    )
    with pytest.raises(ConfigError, match=r"reward term 'where' \(site_pos\) returned shape \(2, 3\); expected \(N,\)"):
        build_task(spec, compile_model(spec), plugins)


def test_plugins_add_terms_and_tasks_through_the_hooks() -> None:
    def height_bonus(ctx: TermContext, scale: float = 1.0) -> Any:
        """Torso height."""
        return scale * ctx.qpos[:, 2]

    class TallAntPlugin:
        @hookimpl
        def joshua_register_terms(self, registry: Registrar) -> None:
            registry.add("height_bonus", height_bonus, "torso height")

        @hookimpl
        def joshua_register_tasks(self, registry: Registrar) -> None:
            registry.add(
                "tall_ant",
                lambda: dataclasses.replace(
                    TASKS["ant_locomotion"],
                    name="tall_ant",
                    rewards=(TermSpec("height_bonus", 2.0, {"scale": 0.5}),),
                ),
                "test",
            )

    from joshua_core import builtin_plugin

    host = PluginHost(
        [
            (PluginInfo("core", "joshua-core", "0", "builtin"), builtin_plugin),
            (PluginInfo("tall", "joshua-tall", "0", "test"), TallAntPlugin()),
        ]
    )
    model = compile_model(TASKS["ant_locomotion"])
    task = build_task("tall_ant", model, host)
    ctx = TermContext(xp=np, dt=task.dt, qpos=np.array([[0.0, 0.0, 0.6] + [0.0] * (model.nq - 3)]))
    total, terms = task.rewards(ctx)
    assert terms == {"height_bonus": pytest.approx(np.array([0.6]))} and total == pytest.approx([0.6])


def test_every_training_preset_names_a_task_that_builds_on_its_model(plugins: PluginHost) -> None:
    from joshua_core.config import finalize, load_preset, preset_names
    from joshua_mujoco import compile_model as load_model  # reads the USD models of the Isaac presets too

    checked = []
    for name in preset_names():
        config = load_preset(name, plugins.options()).message
        if config.HasField("training"):
            training = finalize(load_preset(name, plugins.options())).training
            model = load_model(Path(training.model_path), plugins=plugins)
            task = build_task(training.task, model, plugins, training.task_config)
            checked.append(task.name)
    assert set(TASKS) <= set(checked)


def test_whole_tasks_run_inside_jax_jit_with_a_jax_random_key(plugins: PluginHost) -> None:
    from joshua_core.tasks import JaxRandom

    for spec in TASKS.values():
        model = compile_model(spec)
        task = build_task(spec, model, plugins)
        ctx = random_states(task, model, seed=5)
        arrays = {name: jnp.asarray(getattr(ctx, name)) for name in ARRAY_FIELDS}
        commands = {name: jnp.asarray(value) for name, value in ctx.commands.items()}

        @jax.jit
        def evaluate(arrays: dict[str, Any], commands: dict[str, Any], key: Any, task: Task = task) -> Any:
            state = TermContext(xp=jnp, dt=task.dt, commands=commands, **arrays)
            reset = task.reset(task.reset_context(jnp, NUM_ENVS, JaxRandom(key)))
            total, terms = task.rewards(state)
            ctrl = task.action_to_ctrl(jnp, state.action, ctrl=state.ctrl)
            return task.observe(state), total, task.terminated(state), task.metrics(state), reset.qpos, ctrl

        observation, total, terminated, metrics, qpos, ctrl = evaluate(arrays, commands, jax.random.PRNGKey(0))
        np.testing.assert_allclose(observation, task.observe(ctx), rtol=1e-5, atol=1e-5, err_msg=task.name)
        np.testing.assert_allclose(total, task.rewards(ctx)[0], rtol=1e-5, atol=1e-5, err_msg=task.name)
        np.testing.assert_array_equal(terminated, task.terminated(ctx))
        np.testing.assert_allclose(ctrl, task.action_to_ctrl(np, ctx.action, ctrl=ctx.ctrl), rtol=1e-5, atol=1e-6)
        for name, value in task.metrics(ctx).items():
            np.testing.assert_allclose(metrics[name], value, rtol=1e-5, atol=1e-5)
        # the reset differs per environment (independent draws) and stays near the initial state
        assert qpos.shape == (NUM_ENVS, model.nq) and not np.allclose(qpos[0], qpos[1])
        assert np.abs(np.asarray(qpos) - task.initial_qpos).max() < 0.5


def test_delta_actions_move_the_controls_in_force_and_start_from_the_keyframe(plugins: PluginHost) -> None:
    spec = TASKS["so_arm100_reach"]
    model = compile_model(spec)
    task = build_reach(plugins, 'action { mode: "delta" scale: 0.1 }')
    assert task.delta_actions and task.spec.action.scale == 0.1
    start = task.reset_ctrl(np, 2)
    np.testing.assert_array_equal(start, np.tile(model.key("home").ctrl, (2, 1)))
    action = np.array([[1.0, -1.0, 0.5, 0.0, 3.0, -0.2]] * 2)  # 3.0 is clipped to 1
    moved = task.action_to_ctrl(np, action, ctrl=start)
    np.testing.assert_allclose(moved - start, 0.1 * np.clip(action, -1, 1))
    high = np.tile(task.ctrl_high, (2, 1))
    np.testing.assert_array_equal(task.action_to_ctrl(np, np.ones((2, 6)), ctrl=high), high)  # held at ctrlrange
    with pytest.raises(ValueError, match="delta actions: action_to_ctrl needs the controls in force"):
        task.action_to_ctrl(np, action)
    # a randomized zero offset shifts where a delta episode starts, and the targets of an offset task at every step
    offsets = {"ctrl_offset": np.array([[0.1, 0, 0, 0, 0, 0], [0.0] * 6])}
    np.testing.assert_allclose(task.reset_ctrl(np, 2, offsets)[:, 0], model.key("home").ctrl[0] + [0.1, 0.0])
    absolute = build_reach(plugins, "")
    zero_action = absolute.action_to_ctrl(np, np.zeros((2, 6)), offsets)
    np.testing.assert_allclose(zero_action, absolute.reset_ctrl(np, 2, offsets))


def test_action_for_ctrl_inverts_action_to_ctrl_in_both_modes(plugins: PluginHost) -> None:
    offsets = {"ctrl_offset": np.array([[0.1, 0, 0, 0, 0, 0], [0.0] * 6])}
    for config in ('action { mode: "delta" scale: 0.1 }', ""):
        task = build_reach(plugins, config)
        ctrl = task.reset_ctrl(np, 2, offsets)
        near = ctrl + np.array([[0.05, -0.03, 0, 0, 0.02, 0]] * 2) * task.spec.action.scale  # one step's reach
        action = task.action_for_ctrl(np, near, offsets, ctrl)
        np.testing.assert_allclose(task.action_to_ctrl(np, action, offsets, ctrl), near, atol=1e-12)
        far = ctrl + 10.0  # beyond a step: full speed toward it
        assert np.all(task.action_for_ctrl(np, far, offsets, ctrl) == 1.0), config
    with pytest.raises(ValueError, match="delta actions: action_for_ctrl needs the controls in force"):
        build_reach(plugins, 'action { mode: "delta" }').action_for_ctrl(np, near)


def test_servo_error_is_each_target_minus_its_joint(plugins: PluginHost) -> None:
    task = build_reach(plugins, 'terms { name: "servo" term: "servo_error" kind: OBSERVATION }')
    ctx = task.reset_context(np, 2, None).replace(ctrl=task.reset_ctrl(np, 2) + 0.25)
    np.testing.assert_allclose(task.observation_terms[-1](ctx), np.full((2, 6), 0.25) + task.initial_ctrl - ctx.qpos)


def test_a_saturated_sensor_reads_about_its_reading_inside_the_range_and_never_beyond_it(plugins: PluginHost) -> None:
    config = 'terms {{ name: "touch" term: "sensor" kind: OBSERVATION {} }}'
    sensor = 'params { key: "sensor" value: "gripper_touch_fixed" }'
    task = build_reach(plugins, config.format(f'{sensor} params {{ key: "saturation" value: "100" }}'))
    adr = task.observation_terms[-1].params["sensor"].adr
    sensordata = np.zeros((4, adr + 1))
    sensordata[:, adr] = [0.0, 46.0, 1e4, 1e6]  # none, a grasp, pressing spikes
    touch = task.observation_terms[-1](task.reset_context(np, 4, None).replace(sensordata=sensordata))[:, 0]
    assert touch[0] == 0.0 and 42.0 < touch[1] < 46.0 and touch[1] < touch[2] <= touch[3] <= 100.0
    for bad, shown in (("0", "0"), ("-5", "-5"), ("1e999", "inf")):
        expected = f"term 'touch'.*saturation must be a positive finite number, got {shown}"
        with pytest.raises(ConfigError, match=expected):
            build_reach(plugins, config.format(f'{sensor} params {{ key: "saturation" value: "{bad}" }}'))


def test_a_bad_action_config_is_an_error_naming_the_task(plugins: PluginHost) -> None:
    unknown = r"task 'so_arm100_reach': unknown action mode 'relative' \(use ctrl_range, offset, delta\)"
    with pytest.raises(ConfigError, match=unknown):
        build_reach(plugins, 'action { mode: "relative" }')
    for scale in ("-1", "inf", "nan"):
        with pytest.raises(ConfigError, match="action scale must be a positive finite number"):
            build_reach(plugins, f"action {{ scale: {scale} }}")


def test_progress_is_the_speed_of_closing_on_the_command_and_a_round_trip_earns_nothing(plugins: PluginHost) -> None:
    model = compile_model(EXTRA_ANT_TERMS)
    task = build_task(EXTRA_ANT_TERMS, model, plugins)
    progress = next(term for term in task.reward_terms if term.function.__name__ == "free_body_command_progress")
    ctx = random_states(task, model, seed=0)
    goal = np.zeros((NUM_ENVS, 3))
    start = ctx.qpos.copy()
    start[:, :3] = [0.3, 0.0, 0.0]  # 0.3 m from the goal along x
    toward, sideways = start.copy(), start.copy()
    toward[:, 0] = 0.29
    sideways[:, 1] = 0.01
    ctx = ctx.replace(commands={"spot": goal})
    closing = progress(ctx.replace(prev_qpos=start, qpos=toward))
    np.testing.assert_allclose(closing, 0.01 / ctx.dt, rtol=1e-6)  # 1 cm closer over one step
    np.testing.assert_allclose(progress(ctx.replace(prev_qpos=toward, qpos=start)), -0.01 / ctx.dt, rtol=1e-6)
    # 1 cm sideways at 0.3 m: only the second-order lengthening of the distance, 60x less than 1 cm closer
    aside = progress(ctx.replace(prev_qpos=start, qpos=sideways))
    np.testing.assert_allclose(aside, (0.3 - np.hypot(0.3, 0.01)) / ctx.dt, rtol=1e-6)
    assert np.all(np.abs(aside) < closing / 50)


@pytest.mark.parametrize("text", ["[" * 100_000 + "]" * 100_000, "1" * 5000])
def test_a_term_parameter_json_cannot_hold_is_a_config_error(text: str) -> None:
    # json recurses once per nesting level and int() refuses 4300+ digits: both a one-line ConfigError (exit 2)
    with pytest.raises(ConfigError, match="term parameter"):
        parse_param(text)
    assert parse_param("[1, 2]") == (1, 2) and parse_param("cube") == "cube"
