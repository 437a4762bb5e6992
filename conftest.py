"""Settings and fixtures for every test run, core and plugins alike: SIGINT for child processes, one JAX
compilation cache per run, XLA's CPU compiler set for short programs, a real X server (Xvfb) with screenshots
of it, for the tests of the viewers, and a headless chromium for the tests of the web display."""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import os
import queue
import re
import select
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray


def pytest_report_header(config: pytest.Config) -> list[str]:
    """Which real lerobot joshua-lerobot's tests run against: setup.sh installs 0.4.4 for Python 3.11 and 0.6 for
    3.12, each in a site of its own (plugins/joshua-lerobot/tests/lerobot_harness.py says where)."""
    harness = Path(__file__).parent / "plugins/joshua-lerobot/tests/lerobot_harness.py"
    spec = importlib.util.spec_from_file_location("_lerobot_harness_header", harness)
    if not harness.is_file() or spec is None or spec.loader is None:  # a checkout without that plugin's tests
        return []
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    site = Path(module.LEROBOT_SITE).relative_to(Path(__file__).parent)
    found = module.lerobot_version()
    return [f"lerobot (joshua-lerobot's tests): {found or 'not installed'} in {site}, Python {module.PYTHON_VERSION}"]


def pytest_configure(config: pytest.Config) -> None:
    """Let the `joshua` processes the tests start be stopped with Ctrl-C (SIGINT), as at a terminal.

    A job started in the background by a non-interactive shell (as CI runners do) inherits SIGINT ignored,
    and passes that on to every child; Python then installs no KeyboardInterrupt handler and the tests'
    SIGINT would be lost. Handling SIGINT here makes the children start with the default again.
    """
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    _share_compiled_programs(config)
    _compile_for_short_programs()


# XLA's CPU compiler set for short programs: the tests step a few small batches, so compiling is most of their
# time. The older LLVM fusion emitters and LLVM's optimization level 1 compile an MJX reset and step markedly sooner,
# and the step runs no slower.
TEST_XLA_FLAGS = ("--xla_cpu_use_fusion_emitters=false", "--xla_backend_optimization_level=1")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Run the test files that hold slow tests first, each file's tests together and in their order. xdist hands
    the tests out in this order and queues a few on each worker ahead: slow tests last in the order leave one
    worker running them while the other idles."""
    slow_files = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow_files)  # stable: the order within each group is kept


def pytest_runtest_setup(item: pytest.Item) -> None:
    """Skip a test marked `gpu` where JAX sees no CUDA GPU. Asked in the worker that runs the test, so that the
    collecting process never starts a GPU backend (which would claim GPU memory the workers need)."""
    if item.get_closest_marker("gpu") and not _jax_sees_a_gpu():
        pytest.skip("needs a CUDA GPU that JAX sees (jax[cuda13]): the GPU tier of docs/testing.md")


@functools.cache
def _jax_sees_a_gpu() -> bool:
    """Whether JAX is installed and its default backend is a GPU."""
    try:
        import jax
    except ImportError:
        return False
    return jax.default_backend() == "gpu"


def _compile_for_short_programs() -> None:
    """Add TEST_XLA_FLAGS to XLA_FLAGS for this process and the ones it starts (XLA reads it when JAX's backend
    starts, after this); a flag the environment sets already is kept as it is."""
    flags = os.environ.get("XLA_FLAGS", "")
    given = {flag.split("=")[0] for flag in flags.split()}
    added = [flag for flag in TEST_XLA_FLAGS if flag.split("=")[0] not in given]
    os.environ["XLA_FLAGS"] = " ".join([flags, *added]).strip()


def _share_compiled_programs(config: pytest.Config) -> None:
    """Let this run's tests and the processes they start reuse what JAX compiled for one another.

    Many tests compile the same program (an MJX scene's step, a training iteration of the same small config,
    each `joshua train` or `joshua eval` process anew); sharing it shortens the suite.
    The cache lives in a folder of this run's own, removed at its end, so every run starts cold, as CI does;
    a JAX_COMPILATION_CACHE_DIR already set is kept. Every program is kept, however fast it compiled: JAX's
    default keeps only those of a second or more, and a `joshua` process compiles dozens of smaller ones anew.
    """
    if "JAX_COMPILATION_CACHE_DIR" not in os.environ:
        folder = tempfile.mkdtemp(prefix="joshua-tests-jax-cache-")
        config.add_cleanup(lambda: shutil.rmtree(folder, ignore_errors=True))
        _set_jax_option("jax_compilation_cache_dir", folder)
    _set_jax_option("jax_persistent_cache_min_compile_time_secs", 0.0)


def _set_jax_option(name: str, value: str | float) -> None:
    """Set a JAX option for this process and the ones it starts (jax reads it from the environment at import),
    unless the environment sets it already."""
    if name.upper() in os.environ:
        return
    os.environ[name.upper()] = str(value)
    if "jax" in sys.modules:  # imported already (by a plugin of pytest's): tell it too
        sys.modules["jax"].config.update(name, value)


@pytest.fixture(scope="module")
def xvfb() -> Iterator[str]:
    """A running Xvfb (1024x768, 24 bit); yields its DISPLAY. setup.sh --dev installs it, so it must exist."""
    executable = shutil.which("Xvfb")
    assert executable, "Xvfb is not installed; ./setup.sh --dev installs it (Debian package xvfb)"
    read_end, write_end = os.pipe()
    server = subprocess.Popen(  # -displayfd: Xvfb takes the first free display (its lock files settle races
        # between runs and between pytest-xdist workers) and writes its number to write_end
        # and -noreset: a server that resets whenever its last client leaves (a screenshot) refuses a viewer that
        # connects meanwhile ("Failed to open display", seen once in CI while a test polled screenshots)
        [executable, "-displayfd", str(write_end), "-noreset", "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        pass_fds=(write_end,),
    )
    os.close(write_end)
    with os.fdopen(read_end) as announced:
        ready, _, _ = select.select([announced], [], [], 20)
        line = announced.readline() if ready else ""
    if not line.strip().isdigit():
        server.kill()
        reason = server.stderr.read().decode() if server.stderr else ""
        pytest.fail(f"Xvfb did not announce a display within 20 s: {reason.strip()}", pytrace=False)
    number = int(line)
    try:
        yield f":{number}"
    finally:
        server.terminate()
        server.wait(10)


@pytest.fixture(scope="session")
def screenshot() -> Callable[[str], NDArray[np.uint8]]:
    """`screenshot(display)`: the whole X screen as (H, W, 3) RGB, taken with xwd (Debian x11-apps)."""
    xwd = shutil.which("xwd")
    assert xwd, "xwd is not installed; ./setup.sh --dev installs it (Debian package x11-apps)"

    def take(display: str) -> NDArray[np.uint8]:
        dump = subprocess.run(
            [xwd, "-root", "-silent", "-display", display], capture_output=True, check=True, timeout=30
        ).stdout
        return _decode_xwd(dump)

    return take


def _decode_xwd(dump: bytes) -> NDArray[np.uint8]:
    """Decode an X window dump of a 24/32-bit TrueColor screen (the format Xvfb -screen ...x24 gives)."""
    header = struct.unpack(">25I", dump[:100])
    header_size, width, height, byte_order, bytes_per_line, ncolors = (
        header[0], header[4], header[5], header[7], header[12], header[19]
    )  # fmt: skip
    pixel_bytes = bytes_per_line // width
    assert pixel_bytes == 4, f"expected 32-bit pixels, got {pixel_bytes * 8}"
    start = header_size + 12 * ncolors
    pixels = np.frombuffer(dump[start : start + bytes_per_line * height], np.uint8)
    pixels = pixels.reshape(height, bytes_per_line)[:, : width * 4].reshape(height, width, 4)
    return pixels[..., [2, 1, 0]] if byte_order == 0 else pixels[..., [1, 2, 3]]


@pytest.fixture
def browser() -> Iterator[Any]:
    """Debian's chromium, headless (800x600, WebGL on the CPU through SwiftShader: no GPU on CI), driven by
    selenium; the test is skipped where selenium or chromedriver is missing."""
    pytest.importorskip("selenium", reason="the browser tests need selenium")
    from selenium import webdriver

    driver_path = shutil.which("chromedriver")
    if driver_path is None:
        pytest.skip("needs chromium and chromedriver (apt-get install chromium chromium-driver)")
    options = webdriver.ChromeOptions()
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=800,600"):
        options.add_argument(argument)
    options.add_argument("--enable-unsafe-swiftshader")
    driver = webdriver.Chrome(options=options, service=webdriver.ChromeService(executable_path=driver_path))
    try:
        yield driver
    finally:
        driver.quit()


WebRun = Callable[..., contextlib.AbstractContextManager[tuple[str, "subprocess.Popen[str]"]]]


@pytest.fixture
def web_run() -> WebRun:
    """Starts `joshua ... --web 127.0.0.1:PORT` (a free port appended to `command`) in `cwd` with `env`, as a
    context manager yielding (the URL it printed, the process) within `startup_s`; the process is killed after,
    if it still runs."""

    @contextlib.contextmanager
    def run(
        command: list[str], *, cwd: Path, env: dict[str, str], startup_s: float
    ) -> Iterator[tuple[str, subprocess.Popen[str]]]:
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
        process = subprocess.Popen(
            [*command, "--web", f"127.0.0.1:{port}"],
            cwd=cwd,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=lambda: [lines.put(line) for line in process.stdout], daemon=True).start()
        try:
            seen = []
            while not (
                match := re.match(
                    r"web display: (http://\S+) \(this machine only", line := lines.get(timeout=startup_s)
                )
            ):
                seen.append(line)
                assert process.poll() is None, "".join(seen)
            assert match[1] == f"http://127.0.0.1:{port}/"
            yield match[1], process
        finally:
            if process.poll() is None:
                process.kill()
            process.wait(timeout=30)

    return run
