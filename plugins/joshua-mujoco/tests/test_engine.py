"""MuJoCoEngine against real MuJoCo: the `Engine` API, input checks, keyframes, rendering, loading."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from joshua_core import hookimpl
from joshua_core.errors import ModelError, PluginNotFoundError
from joshua_core.interfaces import ModelReader
from joshua_core.plugins import PluginHost, PluginInfo
from joshua_core.resources import models_dir
from joshua_mujoco import MuJoCoEngine, compile_model

SCENE = "models/so_arm100/scene.xml"


@pytest.fixture
def engine() -> MuJoCoEngine:
    with MuJoCoEngine(model_path=SCENE, render_width=160, render_height=120) as engine:
        yield engine


def test_seed_snippet_runs_as_written(engine: MuJoCoEngine) -> None:
    assert isinstance(engine.model, mujoco.MjModel) and isinstance(engine.data, mujoco.MjData)
    engine.reset()
    for _ in range(1000):
        engine.set_ctrl([0.0, -0.5, 0.3, 0.0, 0.2, 0.0])
        engine.step()
        qpos = engine.get_qpos()
        sensor = engine.get_sensor("wrist_force")
    assert engine.time == pytest.approx(1000 * engine.timestep)
    assert qpos.shape == (engine.model.nq,) and np.all(np.isfinite(qpos))
    assert sensor.shape == (3,) and np.all(np.isfinite(sensor))
    # The position actuators pull the joints toward their targets.
    arm = [engine.model.joint(f"joint_{i}").qposadr[0] for i in range(1, 6)]
    np.testing.assert_allclose(qpos[arm], [0.0, -0.5, 0.3, 0.0, 0.2], atol=0.05)


def test_model_path_resolves_from_any_working_directory(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    for path in (SCENE, "so_arm100/scene.xml", models_dir() / "so_arm100" / "scene.xml"):
        assert MuJoCoEngine(model_path=path).model.nu == 6


def test_qpos_is_a_copy(engine: MuJoCoEngine) -> None:
    qpos = engine.get_qpos()
    qpos[:] = 99.0
    assert not np.any(engine.data.qpos == 99.0)


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ([0.0] * 5, "expects 6 values"),
        ([[0.0] * 6], "expects 6 values"),
        ([0, 0, np.nan, 0, 0, 0], "joint_3_position=nan"),
    ],
)
def test_bad_controls_raise_and_change_nothing(engine: MuJoCoEngine, values, message: str) -> None:
    engine.set_ctrl([0.1] * 6)
    with pytest.raises(ValueError, match=message):
        engine.set_ctrl(values)
    np.testing.assert_array_equal(engine.data.ctrl, [0.1] * 6)


def test_infinite_control_is_rejected(engine: MuJoCoEngine) -> None:
    with pytest.raises(ValueError, match="non-finite"):
        engine.set_ctrl([0, 0, 0, 0, 0, np.inf])


def test_unknown_sensor_lists_the_models_sensors(engine: MuJoCoEngine) -> None:
    with pytest.raises(KeyError, match="wrist_force.*wrist_torque"):
        engine.get_sensor("elbow_force")


def test_reset_to_keyframe_and_back_to_defaults(engine: MuJoCoEngine) -> None:
    home = engine.model.key("home")
    engine.reset("home")
    np.testing.assert_array_equal(engine.get_qpos(), home.qpos)
    np.testing.assert_array_equal(engine.data.ctrl, home.ctrl)
    engine.step(10)
    engine.reset()
    np.testing.assert_array_equal(engine.get_qpos(), engine.model.qpos0)
    assert engine.time == 0.0
    with pytest.raises(KeyError, match="keyframes: home"):
        engine.reset("away")


def test_step_n_equals_n_single_steps() -> None:
    batched, single = MuJoCoEngine(model_path=SCENE), MuJoCoEngine(model_path=SCENE)
    for engine in (batched, single):
        engine.reset("home")
        engine.set_ctrl([0.3, -0.2, 0.1, 0.4, -0.3, 0.2])
    batched.step(50)
    for _ in range(50):
        single.step()
    np.testing.assert_array_equal(batched.get_qpos(), single.get_qpos())


def test_a_negative_step_count_and_complex_ctrl_are_refused() -> None:
    engine = MuJoCoEngine(model_path=SCENE)
    engine.reset("home")
    with pytest.raises(ValueError, match="step expects a number of steps >= 0, got -1"):
        engine.step(-1)
    with pytest.raises(ValueError, match="set_ctrl expects real numbers"):
        engine.set_ctrl(np.full(engine.model.nu, 0.1 + 1j))
    np.testing.assert_array_equal(engine.data.ctrl, engine.model.key("home").ctrl)  # the refused call changed nothing


def test_render_returns_a_non_blank_rgb_image(engine: MuJoCoEngine) -> None:
    engine.reset("home")
    image = engine.render()
    assert image.shape == (120, 160, 3) and image.dtype == np.uint8
    assert image.std() > 10, "rendered image is blank"
    side = engine.render(camera="side")
    assert side.shape == image.shape and not np.array_equal(side, image)


def test_render_larger_than_the_models_offscreen_buffer() -> None:
    with MuJoCoEngine(model_path=SCENE, render_width=1920, render_height=1080) as engine:
        assert engine.render().shape == (1080, 1920, 3)


def test_model_from_xml_string_with_mesh_assets() -> None:
    mesh = (models_dir() / "so_arm100" / "assets").glob("*.stl")
    stl = next(mesh)
    xml = f"""
    <mujoco>
      <asset><mesh name="part" file="{stl.name}"/></asset>
      <worldbody>
        <light pos="0 0 2"/>
        <body pos="0 0 0.5"><freejoint/><geom type="mesh" mesh="part"/></body>
        <geom type="plane" size="1 1 0.1"/>
      </worldbody>
    </mujoco>"""
    engine = MuJoCoEngine(xml=xml, assets={stl.name: stl.read_bytes()})
    assert engine.model.nmesh == 1 and engine.model.nu == 0
    engine.step(100)
    assert engine.get_qpos()[2] < 0.5  # it fell


def test_missing_and_broken_models_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="searched"):
        MuJoCoEngine(model_path=tmp_path / "absent.xml")
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body><geom type='sphere'/></body></worldbody>")
    with pytest.raises(ModelError, match=f"{broken}: model does not compile"):
        MuJoCoEngine(model_path=broken)
    with pytest.raises(ModelError, match="<xml string>"):
        MuJoCoEngine(xml="<mujoco><nonsense/></mujoco>")
    with pytest.raises(TypeError, match="exactly one"):
        MuJoCoEngine()


def test_mujoco_warnings_go_to_stderr_once_and_leave_no_log_file(tmp_path: Path) -> None:
    """MuJoCo's own warning handler appends to MUJOCO_LOG.TXT in the working directory; ours only prints."""
    unstable = """if True:
        import numpy as np
        from joshua_mujoco import MuJoCoEngine
        engine = MuJoCoEngine(xml='<mujoco><worldbody><body><freejoint/><geom size="0.1"/></body></worldbody></mujoco>')
        for _ in range(3):
            engine.data.qvel[:] = np.nan
            engine.step()
        print(engine.instability())
    """
    result = subprocess.run([sys.executable, "-c", unstable], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "non-finite state (mjWARN_BADQVEL" in result.stdout  # MuJoCo warned three times (it resets after each)
    assert result.stderr.count("mujoco: warning: Nan, Inf or huge value in QVEL at DOF 0") == 1, result.stderr
    assert list(tmp_path.iterdir()) == []


class ToyReader(ModelReader):
    """Reads `.toy` files: one line, the radius of a free sphere."""

    def read(self, path: Path) -> mujoco.MjSpec:
        spec = mujoco.MjSpec()
        body = spec.worldbody.add_body(name="ball")
        body.add_freejoint()
        body.add_geom(size=[float(path.read_text())])
        return spec


class ToyPlugin:
    @hookimpl
    def joshua_register_readers(self, registry):  # type: ignore[no-untyped-def]
        registry.add(".toy", ToyReader, "toy models")


def test_a_registered_reader_makes_its_suffix_a_model_file(tmp_path: Path) -> None:
    model = tmp_path / "ball.TOY"
    model.write_text("0.25")
    host = PluginHost([(PluginInfo("toy", "joshua-toy", "0.1", "test"), ToyPlugin())])
    compiled = compile_model(model, plugins=host)
    assert compiled.nq == 7 and compiled.geom_size[0][0] == 0.25
    with pytest.raises(PluginNotFoundError, match=r"no reader named '\.toy' is installed\. .*Installed readers: none"):
        compile_model(model, plugins=PluginHost([]))
    with pytest.raises(PluginNotFoundError, match=r"reader named '\.usd'.*pip install joshua-usd"):
        compile_model(tmp_path / "robot.usd", plugins=PluginHost([]))
