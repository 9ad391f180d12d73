"""The benchmarks' verdicts can fail: fair baselines, default configurations, late
samples counted, targets as data and the exit code they give (timings never asserted)."""

from __future__ import annotations

import itertools
import math
import tomllib
from pathlib import Path

import pytest

from mrss.bench import bus, fleet_project, fleet_table, journal, restart
from mrss.bench.bus_raw import RawLink
from mrss.bench.e2e import Step
from mrss.bench.fleet_project import Scheduling
from mrss.bench.fleet_table import Sample, Windows
from mrss.bench.report import BenchReport, Relation
from mrss.bench.restart import percentile
from mrss.bus.publisher import MAX_BATCH
from mrss.messages import (
    Command,
    DataReply,
    DataRequest,
    Envelope,
    MindSnapshot,
    RobotData,
    SupEvent,
    encode,
)


def test_a_full_size_run_exits_1_when_a_target_row_is_not_met() -> None:
    report = BenchReport("x", ["a"])
    report.target("fast", 4.0, Relation.AT_MOST, 5.0, "issue")
    assert report.exit_status() == 0
    missed = report.target("faster", 6.0, Relation.AT_MOST, 5.0, "issue")
    assert not missed.met
    assert report.exit_status() == 1
    assert "- [ ] faster: 6.00 <= 5.00; bound from issue" in report.to_text()
    row = report.as_dict()["targets"][1]
    assert row == {"target": "faster", "met": False, "figure": 6.0, "relation": "<=",
                   "bound": 5.0, "reference": "issue"}
    report.quick = True  # a smoke run at sizes too small for a verdict
    assert report.exit_status() == 0


@pytest.mark.parametrize("figure", [None, math.nan, math.inf])
def test_a_figure_not_measured_or_late_meets_no_target(figure: float | None) -> None:
    report = BenchReport("x", ["a"])
    assert not report.target("t", figure, Relation.AT_MOST, 5.0).met
    assert not report.target("t", figure, Relation.AT_LEAST, 5.0).met
    assert report.exit_status() == 1


def _result(rate: float, p50: float | None = None, p99: float | None = None) -> dict[str, object]:
    return {"messages": 10, "delivered": 1.0, "rate": rate, "p50": p50, "p99": p99}


def test_bus_ratios_and_targets_are_against_the_best_raw_row_of_the_rows_transport() -> None:
    results = {
        "bus ipc": _result(120_000, 200, 400), "bus tcp": _result(100_000, 250, 500),
        bus.DIRECT_IPC: _result(110_000, 150, 300), bus.DIRECT_TCP: _result(90_000, 160, 320),
        "bus reliable ipc": _result(160_000),
        "raw zmq ipc": _result(100_000, 100, 250),
        f"raw zmq ipc{bus.BATCHED}": _result(200_000, 110, 240),
        "raw zmq tcp": _result(90_000, 120, 300),
        f"raw zmq tcp{bus.BATCHED}": _result(150_000, 130, 280),
        "MQTT QoS 0": _result(30_000, 300, 600), "MQTT QoS 1": _result(9_000, 400, 900)}
    report = BenchReport("bus", ["transport", "messages", "delivered %", "msgs/s",
                                 "/ best raw", "/ QoS 0", "p50", "p99", "rtt / raw", "q",
                                 "per msg"])
    bus._fill(report, results, 100)
    ratio = {row[0]: row[4] for row in report.rows}
    assert ratio["bus ipc"] == pytest.approx(0.6)  # 120k / the batched raw ipc's 200k
    assert ratio["bus tcp"] == pytest.approx(100 / 150)
    assert ratio["MQTT QoS 0"] == pytest.approx(0.2)  # MQTT runs on TCP: / raw tcp's 150k
    assert ratio["raw zmq ipc"] == pytest.approx(0.5)
    rtt = {row[0]: row[8] for row in report.rows}
    assert rtt["bus ipc"] == "2.00, 1.67"  # the lowest raw ipc p50 (100) and p99 (240)
    bounds = {t.description: t.bound for t in report.targets}
    assert bounds["bus ipc: throughput >= 90% of the best raw's"] == pytest.approx(180_000)
    assert bounds["bus tcp: throughput >= 90% of the best raw's"] == pytest.approx(135_000)
    assert bounds["bus ipc: RTT p99 within 1.2x the best raw's"] == pytest.approx(288)
    assert not next(t for t in report.targets
                    if t.description == "bus ipc: RTT p50 within 1.2x the best raw's").met
    reliable = next(t for t in report.targets
                    if t.description == "bus reliable ipc: throughput >= 75% of the best raw's")
    assert reliable.bound == pytest.approx(150_000) and reliable.met


def test_raw_batched_link_sends_the_bus_batches_every_envelope_once_in_order(
        tmp_path: Path) -> None:
    sender = RawLink(f"ipc://{tmp_path}/a.sock", f"ipc://{tmp_path}/b.sock",
                     ["robot.pong.data"], "tx", batching=True)
    receiver = RawLink(f"ipc://{tmp_path}/b.sock", f"ipc://{tmp_path}/a.sock",
                       ["robot.bench.data"], "rx", batching=True)
    try:
        got: list[Envelope] = []
        for attempt in itertools.count():  # the slow joiner: until the receiver hears
            sender.publish(RobotData(robot="bench", data={"i": -1 - attempt}))
            sender.flush()
            if receiver.recv(0.05) is not None:
                break
            assert attempt < 200, "the receiver never joined"
        while receiver.recv(0.05) is not None:
            pass
        largest = 0
        for i in range(1000):
            sender.publish(RobotData(robot="bench", data={"i": i}))
        sender.flush()
        while len(got) < 1000:
            env = receiver.recv(10.0)
            assert env is not None, f"only {len(got)} of 1000 arrived"
            got.append(env)
            largest = max(largest, len(receiver._pending) + 1)
        assert [e.body.data["i"] for e in got] == list(range(1000))  # type: ignore[attr-defined]
        assert largest <= MAX_BATCH  # never more envelopes in one ZeroMQ message than ours
    finally:
        sender.close()
        receiver.close()


def test_a_late_sample_counts_as_late_in_the_percentile() -> None:
    # 2 of 100 late: the p99 (rank 99) is late; left out, it would read 1.0
    assert percentile([1.0] * 98, 99, late=2) == math.inf
    assert percentile([1.0] * 99, 99, late=1) == 1.0  # the rank falls on a sample
    assert Step(100.0, 10, latencies_ms=[1.0] * 9, missing=1).p99 == math.inf


def _window(e2e: list[float], lost: int = 0) -> Sample:
    return Sample(robots=100, window_s=10.0, e2e_ms=e2e, lag_ms=[5.0], assigned=len(e2e) + lost,
                  telemetry=1, written=1, cpu={"rcl": 10.0}, rss_mb={"rcl": 60.0})


def test_fleet_targets_are_on_the_worst_of_the_windows_with_late_starts_counted() -> None:
    tuned = Windows(100, Scheduling.TUNED,
                    [_window([2.0] * 100) for _ in range(4)] + [_window([2.0] * 98, lost=2)])
    shipped = Windows(100, Scheduling.DEFAULTS, [_window([2.0] * 100) for _ in range(5)])
    report = BenchReport("fleet", fleet_table.COLUMNS)
    for w in (shipped, tuned):
        fleet_table.add(report, w)
    fleet_table.targets(report, [shipped, tuned])
    assert [row[1] for row in report.rows] == ["shipped defaults", "tuned (opt-in)"]
    assert report.rows[1][5] == math.inf  # the worst window's p99 is the late start
    assert report.rows[1][6] == "4/5"  # windows meeting the e2e target
    assert report.rows[0][6] == "5/5"
    e2e = next(t for t in report.targets if "e2e p99" in t.description)
    assert "tuned" in e2e.description and not e2e.met
    assert report.exit_status() == 1


def test_fleet_project_at_the_shipped_defaults_sets_no_scheduling() -> None:
    def components(scheduling: Scheduling) -> dict[str, dict[str, object]]:
        text = fleet_project.toml(2, 2, "mqtt://127.0.0.1:1883", 5.0, scheduling)
        parsed: dict[str, dict[str, object]] = tomllib.loads(text)["components"]
        return parsed

    for table in components(Scheduling.DEFAULTS).values():
        assert not {"realtime", "nice"} & set(table)
    tuned = components(Scheduling.TUNED)
    assert tuned["reasoner"]["realtime"] == 10 and tuned["datalayer"]["nice"] == -10


def test_tui_bench_runs_the_dashboard_with_the_polls_mrss_tui_runs_by_default() -> None:
    import argparse

    from mrss.bench.tui import dashboard
    from mrss.bus import BusEndpoints
    from mrss.commands.tui import configure

    parser = argparse.ArgumentParser()
    configure(parser)
    defaults = parser.parse_args(["p"])
    app = dashboard(BusEndpoints.tcp_loopback())
    assert (app.picture.polls.mind_every, app.picture.polls.tree_every,
            app.picture.polls.world_every) == (
        defaults.mind_every, defaults.tree_every, defaults.world_every)
    polls = app.picture.polls
    assert min(polls.mind_every, polls.tree_every, polls.world_every) > 0  # all polls on
    assert app.auto_mind


def test_tui_bench_answers_every_poll_with_a_snapshot_of_the_stream() -> None:
    from mrss.bench.tui import RUNNING, stream
    from mrss.bench.tui_system import SystemSide

    side = SystemSide(6)
    messages = stream()
    for msg in itertools.islice(messages, 37 * 10):  # ten rounds of the stream
        side.observe(msg)

    def ask(body: Command | DataRequest) -> object:
        (reply, _), = side.answer(Envelope(topic="ctl", id="1", ts=0.0, src="tui", inc=0,
                                           body=body))
        encode(reply, src="bench", msg_id="1")  # it goes on the bus as it is
        return reply

    mind = ask(Command(command="mind"))
    assert isinstance(mind, MindSnapshot)
    assert len(mind.intentions) == RUNNING  # one waiting on each running action
    assert sum(b.startswith("position(") for b in mind.beliefs) == 6
    tree = ask(Command(command="tree"))
    assert isinstance(tree, SupEvent) and tree.event == "tree"
    assert len(tree.detail["tree"]["children"]) >= 6  # type: ignore[call-overload,index]
    world = ask(DataRequest(request_id="tui-wm-1", function="wm.list", args=[None]))
    assert isinstance(world, DataReply) and world.ok and isinstance(world.result, list)
    assert sum(obj["kind"] == "robot" for obj in world.result) == 6  # type: ignore[index]


def test_restart_table_opens_with_the_shipped_configuration_and_labels_the_best_case() -> None:
    best = {key: [0.01, 0.02] for key in ("bus fork", "bus exec", "control fork",
                                          "control exec", "actor")}
    report = restart.table(False, {"rcl": [0.3], "reasoner": [0.5]}, best)
    assert report.rows[0][0].startswith("shipped configuration")  # type: ignore[union-attr]
    labels = [str(row[0]) for row in report.rows[3:]]
    assert labels and all(label.startswith(restart.BEST_CASE) for label in labels)
    assert all("best case" in t.description for t in report.targets)


@pytest.mark.slow
def test_journal_soak_says_its_24_hours_are_a_simulated_clock() -> None:
    report = journal.run(quick=True)
    soak = [str(row[0]) for row in report.rows if "soak" in str(row[0])]
    assert soak and all(label.startswith(journal.SIMULATED) for label in soak)
    assert any("not 24 hours long" in note for note in report.notes)


def test_the_jason_rows_say_why_they_are_skipped(monkeypatch: pytest.MonkeyPatch,
                                                 tmp_path: Path) -> None:
    from mrss.bench import reasoner_jason

    monkeypatch.delenv(reasoner_jason.JAR_ENV, raising=False)
    java, cp, why = reasoner_jason.jason_classpath()
    assert (java, cp) == (None, None) and reasoner_jason.JAR_ENV in why
    monkeypatch.setenv(reasoner_jason.JAR_ENV, str(tmp_path / "absent.jar"))
    java, cp, why = reasoner_jason.jason_classpath()
    assert cp is None and "does not exist" in why


def test_a_classpath_without_jason_is_a_clear_error_not_a_hang(tmp_path: Path) -> None:
    import shutil

    from mrss.bench import reasoner_agent, reasoner_jason

    java = shutil.which("java")
    if java is None:
        pytest.skip("no java on this machine")
    with pytest.raises(RuntimeError, match="printed 0 of 2 rounds"):
        reasoner_jason.best_round_ms(reasoner_agent.COUNT, 10, 2, java, str(tmp_path),
                                     timeout=60)
