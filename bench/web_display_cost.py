"""What watching a training in the browser costs it: training env steps/s with and without two connected browsers.

One `joshua --preset PRESET --web 127.0.0.1:PORT` training (SB3 on the CPU by default), timed from its progress bar
in three windows of one run: no browser, two headless chromiums showing the page (selenium; the arms drawn before
the window opens), no browser again. The ratio is the browsers' window over the mean of the two others, so that a
drift of the machine's load over the run does not read as the browsers' cost. Env steps per CPU second of the
training process (its page threads included) is printed too: on a machine shared with other jobs it shows the
page's cost apart from the CPU time those jobs took from the training. The training runs on --training-cpus
and the browsers on the other CPUs, as they would on another machine: on a 2-core host two software-WebGL chromiums
sharing the training's cores would measure chromium, not the page. Chromium's software-WebGL worker threads (named
Thread<NN>) set their own affinity to CPU 0 whatever CPUs chromium was started on, so the script moves every thread
of the browsers back to their CPUs twice a second while they run.

    python bench/web_display_cost.py                      # so_arm100_reach_sb3, 3 windows of 30 s
    python bench/web_display_cost.py --window 60 --set training.num_envs=64
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from selenium import webdriver

JOSHUA = Path(sys.executable).parent / "joshua"
PROGRESS = re.compile(r"(\d+)/\d+ steps")
PAGE_TIMEOUT_S = 120.0


class Progress:
    """The training's step count over time, read from its progress bar (lines end in \\r or \\n)."""

    def __init__(self, stream: Any) -> None:
        self.samples: list[tuple[float, int]] = []
        self.url: str | None = None
        self.started = threading.Event()
        threading.Thread(target=self._read, args=(stream,), daemon=True).start()

    def _read(self, stream: Any) -> None:
        line = ""
        while character := stream.read(1):
            if character not in "\r\n":
                line += character
                continue
            if match := re.match(r"web display: (http://\S+)", line):
                self.url = match[1]
            if "training" in line and "Ctrl-C" in line:
                self.started.set()
            if match := PROGRESS.search(line):
                self.samples.append((time.monotonic(), int(match[1])))
            line = ""

    def rate(self, start: float, end: float) -> float:
        """Steps/s between the first and last progress samples inside [start, end]."""
        inside = [(t, steps) for t, steps in self.samples if start <= t <= end]
        (t0, s0), (t1, s1) = inside[0], inside[-1]
        return (s1 - s0) / (t1 - t0)


def browser() -> webdriver.Chrome:
    options = webdriver.ChromeOptions()
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=800,600"):
        options.add_argument(argument)
    options.add_argument("--enable-unsafe-swiftshader")
    return webdriver.Chrome(
        options=options, service=webdriver.ChromeService(executable_path=shutil.which("chromedriver"))
    )


def cpu_seconds(pid: int) -> float:
    """CPU time the process `pid` has used so far, all its threads."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def total_cpu_seconds(pids: set[int]) -> float:
    """CPU time the processes `pids` have used so far (those that ended since left out)."""
    total = 0.0
    for pid in pids:
        with contextlib.suppress(OSError):
            total += cpu_seconds(pid)
    return total


def descendants(pids: set[int]) -> set[int]:
    """`pids` and every process under them."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            parent = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        children.setdefault(parent, []).append(int(entry.name))
    found, todo = set(), list(pids)
    while todo:
        pid = todo.pop()
        found.add(pid)
        todo += children.get(pid, [])
    return found


def keep_on(drivers: list[webdriver.Chrome], cpus: set[int], stop: threading.Event) -> None:
    """Every thread of the browsers' processes on `cpus`, until `stop`."""
    while not stop.wait(0.5):
        for pid in descendants({driver.service.process.pid for driver in drivers}):
            for task in Path(f"/proc/{pid}/task").glob("*"):
                with contextlib.suppress(OSError):  # a thread or process that just ended
                    os.sched_setaffinity(int(task.name), cpus)


def page_loaded(driver: webdriver.Chrome) -> bool:
    """The page's panel shows a policy step (its websocket is up and poses arrive)."""
    fields = driver.find_elements("xpath", "//label[text()='policy after (steps)']/following::input[1]")
    return bool(fields) and fields[0].get_attribute("value") not in ("", None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--preset", default="so_arm100_reach_sb3")
    parser.add_argument("--window", type=float, default=30.0, help="seconds of each timed window")
    parser.add_argument("--warmup", type=float, default=10.0, help="seconds of training before the first window")
    parser.add_argument(
        "--training-cpus", default="0", help="comma-separated CPUs for the training ('all': share every CPU)"
    )
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE")
    args = parser.parse_args()
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    command = [str(JOSHUA), "--preset", args.preset, "--web", f"127.0.0.1:{port}"]
    command += ["--set", "training.total_timesteps=1000000000"]  # stopped by this script
    command += [argument for override in args.overrides for argument in ("--set", override)]
    env = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    work = Path(os.environ.get("TMPDIR", "/tmp")) / f"web_display_cost_{port}"
    work.mkdir(parents=True, exist_ok=True)
    cpus = os.sched_getaffinity(0)
    training_cpus = cpus if args.training_cpus == "all" else {int(cpu) for cpu in args.training_cpus.split(",")}
    browser_cpus = cpus - training_cpus or cpus
    os.sched_setaffinity(0, browser_cpus)  # this script and the browsers it starts
    process = subprocess.Popen(
        command,
        cwd=work,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        preexec_fn=lambda: os.sched_setaffinity(0, training_cpus),
    )
    progress = Progress(process.stdout)
    try:
        if not progress.started.wait(PAGE_TIMEOUT_S):
            sys.exit("the training did not start")
        time.sleep(args.warmup)
        windows: dict[str, tuple[float, float, float]] = {}  # name: start, end, the training's CPU seconds

        def timed(name: str) -> None:
            start, cpu = time.monotonic(), cpu_seconds(process.pid)
            time.sleep(args.window)
            windows[name] = (start, time.monotonic(), cpu_seconds(process.pid) - cpu)

        timed("no browser")
        drivers = [browser(), browser()]
        pinned = threading.Event()
        threading.Thread(target=keep_on, args=(drivers, browser_cpus, pinned), daemon=True).start()
        for driver in drivers:
            driver.get(progress.url)
        deadline = time.monotonic() + PAGE_TIMEOUT_S
        while not all(page_loaded(driver) for driver in drivers):
            if time.monotonic() > deadline:
                sys.exit("the pages did not load")
            time.sleep(0.5)
        browser_processes = descendants({driver.service.process.pid for driver in drivers})
        browser_cpu = total_cpu_seconds(browser_processes)
        timed("two browsers")
        browser_cpu = total_cpu_seconds(browser_processes) - browser_cpu
        pinned.set()
        for driver in drivers:
            driver.quit()
        timed("no browser again")
    finally:
        process.terminate()
        process.wait(timeout=60)
        shutil.rmtree(work, ignore_errors=True)
    rates, per_cpu = {}, {}
    for name, (start, end, cpu) in windows.items():
        rates[name] = progress.rate(start, end)
        per_cpu[name] = rates[name] * (end - start) / cpu
        share = cpu / (end - start)
        print(f"{name:>17}: {rates[name]:8.1f} training env steps/s (the training on {share:4.0%} of a CPU:"
              f" {per_cpu[name]:8.1f} per CPU second)")  # fmt: skip
    start, end, _ = windows["two browsers"]
    print(f"the browsers used {browser_cpu / (end - start):.0%} of a CPU in their window")
    for label, values in (("steps/s", rates), ("steps per CPU second", per_cpu)):
        without = (values["no browser"] + values["no browser again"]) / 2
        print(f"two browsers / without ({label}): {values['two browsers'] / without:.3f}")


if __name__ == "__main__":
    main()
