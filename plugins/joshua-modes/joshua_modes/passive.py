"""PASSIVE mode: validate a trajectory CSV against the model, then replay it.

The replay is shown in the MuJoCo viewer when a display is usable (real time x `replay.speed`, or as
fast as possible, optionally looping), in a web page with `web` (the problems marked on its time slider
and listed with their times), and recorded headless to `passive_replay.mp4` otherwise. The
validation report is printed and written to `passive_report.json`; with `replay.strict` a trajectory
with problems is not replayed (exit status 2). A tracked replay adds the per-joint tracking error.
"""

from __future__ import annotations

import time
from pathlib import Path

from joshua_core.config_pb2 import SimulationConfig
from joshua_core.errors import ConfigError
from joshua_core.interfaces import Mode
from joshua_core.progress import progress_bar
from joshua_core.run_context import RunContext
from joshua_modes.offscreen import frame_times
from joshua_modes.options_pb2 import ReplayOptions, ViewerOptions
from joshua_modes.replay import Replayer
from joshua_modes.validation import ValidationReport, validated_replayer
from joshua_render import Display, RecordingDisplay, WebDisplay, open_display, open_web_display

REPORT_NAME = "passive_report.json"
VIDEO_NAME = "passive_replay"
DEFAULT_FPS = 30.0
WINDOW_PERIOD_S = 1.0 / 60.0  # how often the viewer is synced during a real-time replay
MAX_SHOWN_PROBLEMS = 50  # problems marked and listed on the web page; the report file holds them all
MARKDOWN_SPECIAL = "\\`*_{}[]<>#|"  # characters a message shows as they are, escaped in Markdown

VIEWER_CHOICE: dict[int, bool | None] = {
    ViewerOptions.AUTO: None,
    ViewerOptions.WINDOW: True,
    ViewerOptions.RECORD: False,
}  # WEB: the web page, or a recording when it cannot listen


class PassiveMode(Mode):
    """Validates and replays `trajectory_path` on the model."""

    def run(self, config: SimulationConfig, context: RunContext) -> None:
        if not config.trajectory_path:
            raise ConfigError(
                "PASSIVE mode replays a trajectory: set simulation.trajectory_path to a CSV file or a LeRobot dataset"
            )
        replay: ReplayOptions = context.settings("replay", config)
        viewer: ViewerOptions = context.settings("viewer", config)
        speed = replay.speed or 1.0
        fps = viewer.fps or DEFAULT_FPS
        with context.create_engine(config) as engine:
            report_path = context.output_dir / REPORT_NAME
            replayer, report = validated_replayer(
                config,
                engine,
                report_path,
                replay=replay,
                refusal="not replayed because simulation.replay.strict is set (--strict)",
                plugins=context.plugins,
            )
            display: Display | None = None
            if config.web or viewer.display == ViewerOptions.WEB:
                display = open_web_display(
                    engine.model,
                    engine.data,
                    config.web,
                    title="JOSHUA replay",
                    instead="recording the replay instead",
                    duration=replayer.duration,
                    marks=_problem_marks(report, replayer.start_time),
                )
            if display is None:
                display = open_display(
                    engine,
                    output_dir=context.output_dir,
                    name=VIDEO_NAME,
                    fps=fps,
                    camera=viewer.camera or None,
                    viewer=VIEWER_CHOICE.get(viewer.display, False),
                )
            with display:
                print(
                    f"replaying {replayer.duration:.3f} s ({'tracked' if replay.tracked else 'kinematic'}): "
                    f"{display.description}"
                )
                if isinstance(display, RecordingDisplay):
                    _record(replayer, display, speed, fps)
                elif isinstance(display, WebDisplay):
                    display.set_report(_problem_list(report, replayer.start_time, report_path.name))
                    _play(replayer, display, speed, loop=replay.loop)
                else:
                    _show(replayer, display, speed, loop=replay.loop, as_fast_as_possible=replay.as_fast_as_possible)
                video = display.close()
        if replay.tracked:
            _report_tracking(report, replayer, report_path)
        if video is not None:
            print(f"video: {video}")


def _problem_marks(report: ValidationReport, start_time: float) -> list[tuple[float, str]]:
    """A mark per problem on the web page's time slider, at its replay time, labelled with its number in the list
    (`#N`: apart from the slider's own time labels)."""
    shown = report.issues[:MAX_SHOWN_PROBLEMS]
    return [(issue.time - start_time, f"#{number}") for number, issue in enumerate(shown, start=1)]


def _problem_list(report: ValidationReport, start_time: float, report_name: str) -> str:
    """The problems as a Markdown list, each with its number on the slider and its replay time (as the page's time
    field counts it: seconds since the first replayed row)."""
    if report.ok:
        return ""
    lines = [f"**{len(report.issues)} problem(s)** (replay time, s):", ""]
    for number, issue in enumerate(report.issues[:MAX_SHOWN_PROBLEMS], start=1):
        lines.append(f"- #{number} at {issue.time - start_time:.3f} s: {_escape(issue.message)}")
    if len(report.issues) > MAX_SHOWN_PROBLEMS:
        lines += ["", f"and {len(report.issues) - MAX_SHOWN_PROBLEMS} more in {_escape(report_name)}"]
    return "\n".join(lines)


def _escape(text: str) -> str:
    """`text` as Markdown that shows it unchanged."""
    return "".join(f"\\{char}" if char in MARKDOWN_SPECIAL else char for char in text)


def _record(replayer: Replayer, display: RecordingDisplay, speed: float, fps: float) -> None:
    """Headless: one frame per 1/fps of video, covering `speed`/fps of trajectory time each."""
    times = frame_times(replayer.start_time, replayer.end_time, fps / speed)
    with progress_bar(len(times), description="passive", unit="frames") as bar:
        for t in times:
            replayer.show(t)
            display.update((t - replayer.start_time) / speed)
            bar.update(1)


def _show(replayer: Replayer, display: Display, speed: float, *, loop: bool, as_fast_as_possible: bool) -> None:
    """In the viewer: at real time x `speed` (or every row at once), until the end or the window closes."""
    while True:
        replayer.restart()
        if as_fast_as_possible:
            for t in replayer.times:
                replayer.show(float(t))
                if not display.update(float(t) - replayer.start_time):
                    return
        else:
            started = time.perf_counter()
            while True:
                elapsed = time.perf_counter() - started
                t = min(replayer.start_time + elapsed * speed, replayer.end_time)
                replayer.show(t)
                if not display.update(elapsed):
                    return
                if t >= replayer.end_time:
                    break
                time.sleep(WINDOW_PERIOD_S)
        if not loop:
            return


def _play(replayer: Replayer, display: WebDisplay, speed: float, *, loop: bool) -> None:
    """In the browser: real time x `speed`; time stands still while paused, and jumps where a browser scrubs to.

    Stepping while paused advances one frame period. A tracked replay runs physics only forward, so a
    scrub back restarts it from the first row and runs it up to the chosen time.
    """
    controls = display.controls
    position = 0.0  # trajectory seconds since the start
    last = time.perf_counter()
    while True:
        now = time.perf_counter()
        elapsed, last = now - last, now
        seek = controls.take_seek()
        if seek is not None:
            if seek < position:
                replayer.restart()
            position = seek
        elif not controls.paused:
            position += elapsed * speed
        else:
            position += controls.take_steps() * WINDOW_PERIOD_S * speed
        position = min(position, replayer.duration)
        replayer.show(replayer.start_time + position)
        display.update(position)
        if position >= replayer.duration and not controls.paused:
            if not loop:
                return
            replayer.restart()
            position = 0.0
        time.sleep(WINDOW_PERIOD_S)


def _report_tracking(report: ValidationReport, replayer: Replayer, report_path: Path) -> None:
    """Print the per-joint tracking error and add it to the JSON report."""
    report.tracking_error = replayer.tracking.summary()
    print("tracking error (simulated - commanded), RMS / max:")
    for joint, error in report.tracking_error.items():
        print(f"  {joint:<12} {error['rms']:.4f} / {error['max']:.4f}")
    report.write(report_path)
