"""Benchmarks behind `mrss bench NAME`: each module NAME has `run(quick) -> BenchReport`."""

from __future__ import annotations

BENCHES: dict[str, str] = {
    "bus": "bus message throughput and round-trip latency vs MQTT",
    "restart": "time from SIGKILL to a restarted component answering",
    "reasoner": "AgentSpeak interpreter throughput vs python-agentspeak",
    "e2e": "latency from percept to the first skill start",
    "fleet": "the whole system with 10..200 simulated robots at 5 Hz: latency, lag, CPU, loss",
    "edges": "data layer calls and MQTT -> percept latency through the edge components",
    "journal": "action journal actions/s with and without fsync; size over a 24 h soak",
    "security": "cost of MAVLink signing per message and of the world model's bearer token",
    "worldmodel": "world model store operations, embedded SQLite and PostGIS",
    "nodes": "crossing to another node (tcp, CurveZMQ) and how fast a lost node is seen",
    "tui": "the dashboard's CPU at 20 and 1,000 msgs/s, and its panel refresh times",
    "allocation": "tasks addressed to a role among 10..200 robots: goal -> award, re-award "
                  "after a robot is lost",
    "incident": "a dashboard attaching late to a 4-hour incident record",
    "record": "the MCAP recorder at 10,000 msgs/s: drops, CPU, bytes/msg; its top rate vs the "
              "mcap library's writer; seeking in a 1 GB recording; a 30-minute what-if",
    "replay": "the dashboard's replay of a 30-minute mission: load, index, seek",
    "memory": "the wildfire system's memory (PSS per process, the total) and its start to a "
              "running reasoner",
    "agents": "1..10,000 small agents in one process exchanging .send messages: cycles/s and "
              "memory per agent",
    "soak": "hours of simulated mission with operator traffic and faults: does anything grow",
}
