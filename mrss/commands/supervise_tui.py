"""`mrss supervise PROJECT` in a terminal: the system in a child process, the dashboard here.

The root supervisor runs exactly as with `--no-tui`, in a child process (its own process
group, stdin from /dev/null), with stdout and stderr a pipe that this process copies
into `<run_dir>/mrss.log` (`mrss.logfile.LogPump`, rotating it like every writer):
its components inherit them, so every line of the run lands in the log file and none
on the screen (their log records they write to the file themselves: `$MRSS_STDERR_LOG`
tells them where their stderr goes). This process owns the terminal and runs the
dashboard (`MrssApp`) on the system's bus. A crash of either side cannot take the
other down.

- `q` (or Ctrl-Q) asks first, naming what stops; on yes the dashboard closes, then the
  system is stopped with SIGINT, the same path as Ctrl-C without the dashboard; its
  exit code is ours. On no everything keeps running. `X` stops the system too (after
  the same question) but keeps the dashboard open on the stopping system.
- Ctrl-C (the dashboard lets the terminal send signals) and SIGTERM/SIGHUP to this
  process are passed on to the system, so a first one stops it in order and a second
  kills what is left; the dashboard shows the stopping and closes when the system ends.
- A closed terminal (SIGHUP: its window closed, the ssh session dropped) stops the
  system the same way, and this process ends when the system has, even if the
  dashboard cannot close on a terminal that is gone (Textual can block writing to it).
- If the system ends by itself (the root gave up), the dashboard stays open on the
  final picture with the reason in its red banner until the operator closes it (`q`,
  no question then); the last words are printed too. If this process is killed, the
  system gets SIGTERM (PDEATHSIG).

A temporary run dir is kept (emptied but for the log and its rotated files) so the log
outlives the run.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import logging
import os
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path
from types import FrameType
from typing import Any, ClassVar

from textual.binding import Binding, BindingType

from mrss import logfile, logs
from mrss.bus import BusEndpoints
from mrss.bus.settings import endpoints_from_config
from mrss.commands.supervise import log_rotation, run_dir_for
from mrss.config.alerts import project_alert_rules
from mrss.config.map import MapConfig
from mrss.config.project import ProjectConfig
from mrss.errors import ConfigError
from mrss.interpreter import python_module
from mrss.tui.app import MrssApp
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.mission import project_map, project_mission
from mrss.tui.vocabulary import Vocabulary, project_agent_files

EXIT_CONFIG = 2
WATCH_EVERY = 0.2  # seconds between two looks whether the system is still running
_PR_SET_PDEATHSIG = 1

log = logging.getLogger("mrss.supervise")


class SupervisedApp(MrssApp):
    """The dashboard of a system this process started (see the module docstring)."""

    BINDINGS: ClassVar[list[BindingType]] = [Binding("q", "close", "Quit (asks)")]

    def __init__(self, endpoints: BusEndpoints, system: subprocess.Popen[bytes],
                 log_path: Path | None = None, **options: Any) -> None:
        super().__init__(endpoints, **options)
        self.system = system
        self.log_path = log_path
        self.stop_requested = False  # by the operator: close once the system has ended

    def on_mount(self) -> None:  # runs after MrssApp.on_mount (Textual calls each class's)
        self.set_interval(WATCH_EVERY, self._watch_system)

    def _watch_system(self) -> None:
        code = self.system.poll()
        if code is None or self.liveness.ended.startswith("system stopped"):
            return
        if self.stop_requested:
            self.exit()
            return
        last = _last_words(self.log_path) if self.log_path is not None else ""
        was_ended = bool(self.liveness.ended)
        self.liveness.ended = f"system stopped (exit {code})" + (f": {last}" if last else "")
        if not was_ended:
            self._system_ended()  # robots unknown, components stopped: not as last heard
        self.picture.show()

    def stop_system(self) -> None:
        """Stop the system in order (SIGINT, as Ctrl-C); the dashboard closes when it ends."""
        self.stop_requested = True
        with contextlib.suppress(ProcessLookupError):
            self.system.send_signal(signal.SIGINT)

    def action_stop_system(self) -> None:
        if self.readonly:
            super().action_stop_system()  # refused, with the notice
            return
        if self.system.poll() is not None:
            self.say(f"{self.project} is not running", error=True)
            return
        self.push_screen(ConfirmScreen(f"Stop the whole system {self.project}?",
                                       self.steering.stop_details()), self._stop_answer)

    def _stop_answer(self, yes: bool | None) -> None:
        if yes:
            self.say(f"stopping {self.project} ...")
            self.stop_system()
        else:
            self.say(f"{self.project} keeps running")

    def action_close(self) -> None:
        """`q`: this dashboard owns the system, so closing it stops the system: ask."""
        if self.system.poll() is not None:
            self.exit()
            return
        self.push_screen(ConfirmScreen(
            f"Close the dashboard and stop {self.project}?",
            [*self.steering.stop_details(), "(`mrss supervise --no-tui` and `mrss tui` keep the "
             "system running without this dashboard)"], yes="yes, stop everything"),
            self._close_answer)

    def _close_answer(self, yes: bool | None) -> None:
        if yes:
            self.stop_requested = True
            self.exit()  # then run() stops the system with SIGINT
        else:
            self.say(f"{self.project} keeps running")


# After the system ended on a closed terminal, how long the dashboard may take to close.
HANGUP_GRACE = 3.0
# After the system ended, how long its last output may take to reach the log.
PUMP_DRAIN = 5.0


def run_with_dashboard(args: argparse.Namespace, config: ProjectConfig) -> int:
    """Run the project's system in a child process and the dashboard in this one."""
    run_dir = run_dir_for(config, args.run_dir)
    temporary = args.run_dir is None and not config.supervisor.run_dir
    log_path = logs.log_file(run_dir)
    try:
        endpoints = endpoints_from_config(config.sections.get("bus", {}), run_dir,
                                          file=str(config.file),
                                          nodes=bool(getattr(args, "node", None)))
        map_config = project_map(config.file, config.sections)
        rotation = log_rotation(config)
    except ConfigError as exc:
        print(f"mrss supervise: {exc}", file=sys.stderr)
        if temporary:
            shutil.rmtree(run_dir, ignore_errors=True)
        return EXIT_CONFIG
    os.environ[logfile.ENV] = rotation.to_env()  # this process, and the system's tree
    logs.configure("tui", level=logging.DEBUG if args.verbose else logging.INFO,
                   console=False, file=log_path)
    try:
        code = _run(args, config, run_dir, endpoints, log_path, map_config, temporary)
    finally:
        if temporary:
            _keep_only(run_dir, log_path)
    if code != 0 and (last := _last_words(log_path)):
        print(last, file=sys.stderr)  # e.g. "mrss supervise: NAME: gave up: ..."
    print(f"mrss supervise: {config.name} stopped (exit {code}); the log is {log_path}",
          file=sys.stderr)
    return code


def _run(args: argparse.Namespace, config: ProjectConfig, run_dir: Path,
         endpoints: BusEndpoints, log_path: Path, map_config: MapConfig,
         temporary: bool) -> int:
    system, pump = _start_system(args, run_dir, log_path)
    log.info("system of %s started (pid %d), run dir %s", config.name, system.pid, run_dir)

    mission = project_mission(config.directory, config.file, config.sections, run_dir)
    vocabulary = Vocabulary.of_files(project_agent_files(config.components, config.directory))
    rules = project_alert_rules(config.sections, str(config.file))  # `mrss check` passed
    app = SupervisedApp(endpoints, system, log_path, project=config.name, mission=mission,
                        restart_budget=(config.supervisor.spec.intensity,
                                        config.supervisor.spec.period),
                        vocabulary=vocabulary, alert_rules=rules, map_config=map_config)

    closed = threading.Event()  # app.run() returned
    hung_up = threading.Event()  # the terminal closed (SIGHUP)

    def forward(signum: int, frame: FrameType | None) -> None:
        app.stop_requested = True  # asked for: the dashboard closes when it is done
        if signum == signal.SIGHUP and not hung_up.is_set():
            hung_up.set()
            threading.Thread(target=_end_after_hangup, args=(system, pump, closed,
                                                             config.name, run_dir, log_path,
                                                             temporary),
                             name="mrss-hangup", daemon=True).start()
        with contextlib.suppress(ProcessLookupError):
            system.send_signal(signal.SIGINT if signum == signal.SIGINT else signal.SIGTERM)

    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, forward)
    os.environ["TEXTUAL_ALLOW_SIGNALS"] = "1"  # Ctrl-C stops the system, as without us
    try:
        app.run()
    except Exception:
        log.exception("the dashboard failed")
        print("mrss supervise: the dashboard failed; stopping the system", file=sys.stderr)
    closed.set()
    if system.poll() is None:
        log.info("dashboard closed: stopping %s", config.name)
        print(f"mrss supervise: stopping {config.name} ...", file=sys.stderr, flush=True)
        forward(signal.SIGINT, None)
    code = system.wait()
    pump.join(PUMP_DRAIN)
    log.info("system of %s ended with exit code %d", config.name, code)
    return code


def _end_after_hangup(system: subprocess.Popen[bytes], pump: logfile.LogPump,
                      closed: threading.Event, name: str, run_dir: Path, log_path: Path,
                      temporary: bool) -> None:
    """The terminal is gone: once the system has stopped, end this process.

    The dashboard normally closes by itself when the system ends; on a terminal that is
    gone Textual may block for ever writing its last escape codes, and nobody is left
    to see them. So after the system's end the dashboard gets `HANGUP_GRACE` seconds.
    """
    code = system.wait()
    pump.join(PUMP_DRAIN)
    log.info("terminal closed: the system of %s ended with exit code %d", name, code)
    if closed.wait(HANGUP_GRACE):
        return
    log.warning("the dashboard did not close on its closed terminal: exiting")
    if temporary:
        _keep_only(run_dir, log_path)
    logging.shutdown()
    os._exit(code)


def _start_system(args: argparse.Namespace, run_dir: Path, log_path: Path
                  ) -> tuple[subprocess.Popen[bytes], logfile.LogPump]:
    """The system, its stdout and stderr piped through a `LogPump` into the log."""
    argv = python_module("mrss", "supervise", args.project, "--no-tui", "--run-dir", str(run_dir))
    if args.launcher:
        argv += ["--launcher", args.launcher]
    if getattr(args, "node", None):
        argv += ["--node", args.node]
    if args.verbose:
        argv.append("-v")
    read_end, out = os.pipe2(os.O_CLOEXEC)
    env = {**os.environ, logs.STDERR_LOG_ENV: str(log_path)}
    try:
        system = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=out, stderr=out,
                                  env=env, process_group=0,
                                  preexec_fn=_dies_with(os.getpid()))
    except BaseException:
        os.close(read_end)
        raise
    finally:
        os.close(out)
    return system, logfile.LogPump(read_end, logfile.LogFile(log_path,
                                                             logfile.Rotation.from_env()))


def _dies_with(parent: int) -> Any:
    """A preexec_fn: the child gets SIGTERM when this process dies, however it dies."""
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None

    def arm() -> None:
        prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
        if os.getppid() != parent:  # it died before the line above
            os.kill(os.getpid(), signal.SIGTERM)

    return arm


def _keep_only(run_dir: Path, keep: Path) -> None:
    """Empty a temporary run dir but for the log file and its rotated files."""
    kept = set(logfile.history_files(keep))
    for entry in run_dir.iterdir():
        if entry in kept:
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                entry.unlink()


def _last_words(log_path: Path, tail: int = 65536) -> str:
    """The root's final message (`mrss supervise: ...`) from the end of the log."""
    lines = logfile.read_tail(log_path, tail).splitlines()
    return next((line for line in reversed(lines) if line.startswith("mrss supervise: ")), "")
