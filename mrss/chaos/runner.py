"""One campaign, end to end: start the system, drive it, break it, watch it settle, record.

1. `mrss supervise PROJECT` starts as its own process (`mrss.procedures.RunningProject`)
   in the run folder; the recorder listens from the start.
   With network faults in the plan, a relay is put in each simulated robot's link first
   (mrss.chaos.network): the system finds it where it would find the robot. A project on
   `[nodes]` runs each node in a network namespace of its own (mrss.chaos.netns): the
   RCL's node in the run folder, each peer in `nodes/<name>/` of it, started after it;
   with `node_delay` in the plan, relays between the nodes first (mrss.chaos.node_relays).
2. After `warmup` seconds the faults of the seeded plan are injected at their times
   while the project's operator traffic runs; timed faults are healed when they are over.
3. Once the last fault is over the traffic stops and the system is probed every second
   until it has converged and at least the checker's latch and cancel bounds have
   passed since the later of the last fault and the operator's last mode switch (so
   every rule can be judged), or until the convergence bound is exceeded.
4. The RCL journal and the run's log are recorded, the system is stopped (SIGINT), and
   the history file is closed. Checking it is the caller's business (`mrss chaos`).
"""

from __future__ import annotations

import dataclasses
import subprocess
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mrss.chaos.campaign import CampaignError, Range, plan
from mrss.chaos.checker import Bounds
from mrss.chaos.convergence import probe_problems
from mrss.chaos.faults import (
    ALL_KINDS,
    FRESH_TASK,
    IMPAIRMENTS,
    MID_TASK_WAIT,
    Fault,
    FaultKind,
    Heal,
    InjectionError,
    Injector,
    components_of,
    home_node,
    targets,
    unavailable,
    why_no_nodes,
)
from mrss.chaos.history import FILE_NAME, HistoryWriter, parse
from mrss.chaos.netns import NodeNetwork
from mrss.chaos.network import Relays
from mrss.chaos.recorder import Recorder
from mrss.chaos.task_bound import award_bound, robot_capabilities
from mrss.chaos.traffic import Intent, OperatorStep, Sent, Traffic, load_traffic, publish
from mrss.config.kinds import ComponentKind
from mrss.config.loader import load_project
from mrss.config.nodes import node_plan
from mrss.config.operator import SECTION, GoalState, read_operator
from mrss.config.project import ProjectConfig
from mrss.logs import STDERR_LOG_ENV, log_file
from mrss.procedures import RunningProject

Say = Callable[[str], None]
SUPERVISE_LOG = "supervise.log"  # the output of `mrss supervise` beside its log records
STARTUP = 60.0  # seconds the system may take to start: a loaded machine is no fault


@dataclass(frozen=True)
class Options:
    project: str
    run_dir: Path
    faults: int = 10
    seed: int = 1
    kinds: tuple[FaultKind, ...] = ALL_KINDS
    interval: Range = (3.0, 6.0)
    duration: Range = (2.0, 8.0)
    only: tuple[str, ...] = ()
    operator_every: float = 20.0
    answer_within: float = 5.0  # an operator step unanswered this long is sent again
    answer_patience: float = 30.0  # ... for at most this long
    warmup: float = 5.0
    bounds: Bounds = field(default_factory=Bounds)
    env: dict[str, str] = field(default_factory=dict)
    projects: Path | None = None  # the folder of projects/<name>/ (None: projects_dir())


def failed_goal_functors(config: ProjectConfig) -> list[str]:
    """The belief by which the project's agent tells the operator a goal failed (its
    `[operator.goals] failed` pattern, which the dashboard shows), if it declares one."""
    if SECTION not in config.sections:
        return []
    pattern = read_operator(config.sections[SECTION]).goals.get(GoalState.FAILED)
    return [pattern.functor] if pattern is not None else []


def run(options: Options, say: Say = print,
        settled: Callable[[], None] = lambda: None) -> Path:
    """Run the campaign; returns the history file (in the run folder). `settled` is
    called once the system has settled after the faults, before it is recorded and
    stopped (`mrss bench soak` stops sampling there)."""
    config = load_project(options.project, options.projects)
    traffic = load_traffic(config.directory)
    possible = targets(config, options.only)
    skipped = skipped_kinds(options.kinds, possible, unavailable(config),
                            explicit=set(options.kinds) != set(ALL_KINDS))
    faults = plan(options.seed, options.faults, options.kinds, possible, options.interval,
                  options.duration)
    reasoners = components_of(config, ComponentKind.REASONER)
    rcls = components_of(config, ComponentKind.RCL)
    options.run_dir.mkdir(parents=True, exist_ok=True)
    home = home_node(config)
    if home and why_no_nodes(config):
        raise CampaignError(f"{options.project} runs on [nodes]: a campaign runs each node "
                            f"in a network namespace of its own, which {why_no_nodes(config)}")
    path = options.run_dir / FILE_NAME
    writer = HistoryWriter(path)
    network = NodeNetwork(node_plan(config).nodes, home) if home else None
    system = _node_system(config.directory, options, network, home, options.run_dir)
    peers = [_node_system(config.directory, options, network, peer,
                          options.run_dir / "nodes" / peer)
             for peer in (network.peers if network is not None else ())]
    recorder: Recorder | None = None
    heals: list[tuple[float, Fault, int, Heal]] = []
    relays: Relays | None = None
    try:
        if network is not None:  # this thread (and those it starts) on the home node
            network.up().enter(home)
            if any(f.kind is FaultKind.NODE_DELAY for f in faults):
                network.relay(options.seed)  # in the nodes' path before they connect
        # relays in the robots' paths before anything resolves their addresses (detours)
        if any((f.kind.network and f.kind in IMPAIRMENTS) or f.kind.permanent
               for f in faults):
            relays = Relays(config, options.run_dir, options.seed).start()
        system.start(timeout=STARTUP)
        for peer in peers:  # the home node's proxy first, as an operator starts them
            peer.start(timeout=STARTUP)
        recorder = Recorder(options.run_dir, writer,
                            options.run_dir / f"{rcls[0] if rcls else 'rcl'}-journal.sqlite3",
                            traffic.reply_topics)
        writer.write("campaign", t=0.0, project=options.project, seed=options.seed,
                     wall=recorder.wall0, run_dir=str(options.run_dir),
                     options=_plain_options(options), reasoners=reasoners, rcls=rcls,
                     operator=traffic.source is not None,
                     pending_beliefs=list(traffic.pending_beliefs),
                     failed_beliefs=failed_goal_functors(config),
                     mode_beliefs=traffic.mode_beliefs,
                     planned=[dataclasses.asdict(f) for f in faults],
                     robots=robot_capabilities(config),
                     award_bound=award_bound(config).record(),
                     skipped={k.value: why for k, why in skipped.items()},
                     relayed=relays.links if relays is not None else {},
                     nodes={"home": home, "peers": [p.node for p in peers]} if home else {})
        system.wait_ready(tuple(reasoners + rcls) or ("rcl", "reasoner"), timeout=STARTUP)
        say(f"chaos: {options.project} up in {options.run_dir}; "
            f"{len(faults)} faults, seed {options.seed}")
        stop_traffic = threading.Event()
        switched: list[float] = []  # when the operator's accepted mode switches were sent
        operator = threading.Thread(target=_operate, args=(
            traffic, options, recorder, writer, stop_traffic, switched),
            name="chaos-operator", daemon=True)
        operator.start()
        _sleep_until(recorder, options.warmup, system)
        injector = Injector(_root_pid(system), recorder.pid_of, relays, network)
        start = recorder.now()
        for number, fault in enumerate(faults, 1):
            _sleep_until(recorder, start + fault.at, system, heals, writer)
            if not _running(system):
                say(f"chaos: mrss supervise exited ({_code(system)}); faults stop")
                break
            if fault.kind is not FaultKind.FORKSERVER:
                recorder.tree(timeout=2.0)  # fresh pids when the bus answers
            holding = _mid_task(fault, recorder, system, heals, writer)
            _inject(injector, fault, recorder, writer, heals, holding)
            say(f"chaos: fault {number}/{len(faults)} {fault.kind} {fault.target}"
                + (f" for {fault.duration:.1f}s" if fault.kind.timed else ""))
        while heals and _running(system):
            _sleep_until(recorder, min(h[0] for h in heals), system, heals, writer)
        _heal_all(heals, recorder, writer)
        faults_ended = recorder.now()
        stop_traffic.set()  # no new step; the one in hand is delivered (answered) first
        operator.join(timeout=options.answer_patience + 15)
        converged = _settle(system, recorder, options.bounds, faults_ended,
                            max([faults_ended, *switched]))
        say(f"chaos: faults over at {faults_ended:.1f}s; "
            + (f"converged {converged:.1f}s later" if converged is not None
               else "did not converge"))
        settled()
        recorder.record_journal()
        recorder.record_log(set(reasoners + rcls))
        code = _stop(system)
        for peer in peers:
            _stop(peer)
        writer.write("end", t=recorder.now(), faults_ended=faults_ended, exit_code=code,
                     relays={**(relays.counts() if relays is not None else {}),
                             **_node_relay_counts(network)})
    finally:
        if recorder is not None:
            _heal_all(heals, recorder, writer)
            recorder.close()
        system.close()
        for peer in peers:
            peer.close()
        if network is not None:
            network.close()
        if relays is not None:
            relays.close()
        writer.close()
    return path


def _node_relay_counts(network: NodeNetwork | None) -> dict[str, dict[str, int]]:
    """The relays between the nodes (node_delay), as "node <peer>" -> their counts."""
    if network is None or network.relays is None:
        return {}
    return {f"node {peer}": seen for peer, seen in network.relays.counts().items()}


def _node_system(project_dir: Path, options: Options, network: NodeNetwork | None,
                 node: str, run_dir: Path) -> RunningProject:
    """`mrss supervise` of the project (of one node's share, in its namespace)."""
    # Log records go to the run's rotating log only, not twice (the output keeps the rest)
    env = {**options.env, STDERR_LOG_ENV: str(log_file(run_dir))}
    system = RunningProject(project_dir, run_dir, env=env, node=node,
                            prefix=network.prefix(node) if network is not None else ())
    system.output = run_dir / SUPERVISE_LOG
    return system


def skipped_kinds(kinds: tuple[FaultKind, ...], possible: dict[FaultKind, list[str]],
                  why: dict[FaultKind, str], explicit: bool) -> dict[FaultKind, str]:
    """The kinds asked for that have no target here, and why. Asked for by name, such a
    kind is refused (CampaignError); drawn from all kinds, it is skipped and reported."""
    skipped = {k: why.get(k, "no target in this project") for k in kinds if not possible.get(k)}
    if explicit and skipped:
        raise CampaignError("; ".join(f"--kinds {k}: cannot be injected here: {reason}"
                                      for k, reason in skipped.items()))
    return skipped


def _plain_options(options: Options) -> dict[str, object]:
    out = dataclasses.asdict(options)
    out["run_dir"] = str(options.run_dir)
    out["projects"] = None if options.projects is None else str(options.projects)
    out["kinds"] = [k.value for k in options.kinds]
    return out


def _operate(traffic: Traffic, options: Options, recorder: Recorder, writer: HistoryWriter,
             stop: threading.Event, switched: list[float]) -> None:
    """The operator: publish the project's steps at their pace until told to stop; the
    time of each accepted mode switch goes to `switched` (the calm is counted from it)."""
    for n, step in enumerate(traffic.steps(options.seed, options.operator_every), 1):
        if stop.wait(step.after):
            return
        if "id" not in step.payload:  # every message of an operator's console has one
            step = dataclasses.replace(step, payload={**step.payload, "id": f"op-{n}"})
        t = recorder.now()
        sent, attempts = _deliver(step, options, recorder)
        writer.write("operator", t=t, intent=step.intent.value, topic=step.topic,
                     payload=step.payload, ok=sent.ok, goal=step.goal, robot=step.robot,
                     mode=step.mode, on=step.on, error=sent.error, attempts=attempts)
        if sent.ok and step.intent is Intent.MODE:
            switched.append(t)


def _deliver(step: OperatorStep, options: Options, recorder: Recorder) -> tuple[Sent, int]:
    """Publish a step until the system answers it, as an operator's console does: the
    broker's acknowledgement alone is not enough (a broker that dies after acknowledging
    loses the message). Sent again, with the same id, when no reply names its id within
    `answer_within` s, for at most `answer_patience` s; a project without reply topics
    is never answered, so its steps go once. A step in hand is delivered even when the
    campaign stops sending. Returns the last outcome and the attempts."""
    deadline = time.monotonic() + options.answer_patience
    event_id = str(step.payload["id"])
    attempts = 0
    while True:
        attempts += 1
        sent = publish(options.run_dir, step)
        if not sent.ok or not recorder.answers_expected:
            return sent, attempts
        if recorder.wait_answer(event_id, options.answer_within) \
                or time.monotonic() >= deadline:
            return sent, attempts


def _mid_task(fault: Fault, recorder: Recorder, system: RunningProject,
              heals: list[tuple[float, Fault, int, Heal]], writer: HistoryWriter
              ) -> list[str] | None:
    """For a robot_loss, wait (at most MID_TASK_WAIT s) until its robot has just begun a
    task addressed to a role (within FRESH_TASK s), so that it is lost with the task's
    work ahead of it: a loss is known only after the link's timeout, and a task struck
    near its end would be done by then. Past the wait, any task it runs will do. Those
    tasks (None: another kind)."""
    if fault.kind is not FaultKind.ROBOT_LOSS:
        return None
    deadline = recorder.now() + MID_TASK_WAIT
    while not recorder.tasks_running_on(fault.target, recorder.now() - FRESH_TASK) \
            and recorder.now() < deadline and _running(system):
        _sleep_until(recorder, min(deadline, recorder.now() + 0.1), system, heals, writer)
    return recorder.tasks_running_on(fault.target)


def _inject(injector: Injector, fault: Fault, recorder: Recorder, writer: HistoryWriter,
            heals: list[tuple[float, Fault, int, Heal]],
            holding: list[str] | None = None) -> None:
    t = recorder.now()
    held = {} if holding is None else {"holding": holding}  # the tasks a lost robot ran
    try:
        pid, heal = injector.inject(fault)
    except (InjectionError, OSError) as exc:
        writer.write("fault", t=t, kind=fault.kind.value, target=fault.target, pid=0,
                     duration=fault.duration, ok=False, error=str(exc), **held)
        return
    writer.write("fault", t=t, kind=fault.kind.value, target=fault.target, pid=pid,
                 duration=fault.duration, ok=True, **held)
    if heal is not None:
        heals.append((t + fault.duration, fault, pid, heal))


def _heal_due(heals: list[tuple[float, Fault, int, Heal]], recorder: Recorder,
              writer: HistoryWriter, everything: bool = False) -> None:
    now = recorder.now()
    for item in [h for h in heals if everything or h[0] <= now]:
        heals.remove(item)
        _, fault, pid, heal = item
        heal()
        writer.write("heal", t=recorder.now(), kind=fault.kind.value, target=fault.target,
                     pid=pid)


def _heal_all(heals: list[tuple[float, Fault, int, Heal]], recorder: Recorder,
              writer: HistoryWriter) -> None:
    _heal_due(heals, recorder, writer, everything=True)


def _sleep_until(recorder: Recorder, t: float, system: RunningProject,
                 heals: list[tuple[float, Fault, int, Heal]] | None = None,
                 writer: HistoryWriter | None = None) -> None:
    """Wait until campaign time `t`, healing timed faults when they are due."""
    while recorder.now() < t and _running(system):
        if heals and writer is not None:
            _heal_due(heals, recorder, writer)
        time.sleep(min(0.05, max(0.0, t - recorder.now())))
    if heals and writer is not None:
        _heal_due(heals, recorder, writer)


def _settle(system: RunningProject, recorder: Recorder, bounds: Bounds,
            faults_ended: float, calm_from: float) -> float | None:
    """Probe until converged and the latch/cancel bounds are over since `calm_from` (the
    later of the last fault and the last mode switch: mode-consistent is judged only
    after that much calm); the convergence time after the faults."""
    converged: float | None = None
    while True:
        record = recorder.probe(_running(system))
        now = recorder.now()
        if converged is None and not probe_problems(parse([{"type": "probe", **record}])
                                                    .probes[0]):
            converged = now - faults_ended
        if settled(now, converged is not None, faults_ended, calm_from, bounds) \
                or not _running(system):
            return converged
        time.sleep(1.0)


def settled(now: float, converged: bool, faults_ended: float, calm_from: float,
            bounds: Bounds) -> bool:
    """Whether probing may stop at campaign time `now`: converged, and the latch and
    cancel bounds over since `calm_from`, so every rule can be judged; or, converged
    or not, the convergence bound over since the faults and that calm too."""
    calm = calm_from + max(bounds.latch, bounds.cancel)
    return now >= calm and (converged or now >= faults_ended + bounds.converge)


def _stop(system: RunningProject) -> int | None:
    """Ctrl-C the system; its exit code (None if it did not stop by itself)."""
    if not _running(system):
        return _code(system)
    try:
        return system.interrupt(timeout=60)
    except (AssertionError, subprocess.TimeoutExpired):
        return _code(system)


def _running(system: RunningProject) -> bool:
    return system.process is not None and system.process.poll() is None


def _code(system: RunningProject) -> int | None:
    return None if system.process is None else system.process.poll()


def _root_pid(system: RunningProject) -> int:
    assert system.process is not None
    return system.process.pid
