"""Hand-made campaign histories for the checker's tests: one healthy run, and edits to it.

`healthy()` is a short complete campaign in which every invariant holds and none is
vacuous: the operator sends goal
a1, the reasoner asks for cover(uav1,a1), the RCL runs it to success, the reasoner
releases its latch; a reasoner is killed and restarts; the operator switches the UGV to
teleop and back; after the faults a probe finds everything running and idle; the
journal and the run's log are read; cover's RUNNING status carries a progress bound of
6 s (`progress_bound`) and it is kept; uav1 is available before the fault and after;
the action's skill holds a critical section within its bound; once uav1 is free, the
reasoner asks for sweep(any([uav]),t1), a task addressed to a role, which the RCL awards
to uav1 at once and uav1 sweeps. Each test changes one thing and expects one invariant
to break.
"""

from __future__ import annotations

from typing import Any

U1 = "a" * 32
U2 = "b" * 32
U3 = "e" * 32  # the task addressed to a role
AWARD_BOUND = {"link_loss": 3.0, "allocation": 2.0, "restart": 15.0, "margin": 3.0,
               "stalls": ["rcl", "bus"]}  # base 8 s

Record = dict[str, Any]


def bus(t: float, kind: str, body: dict[str, Any], src: str = "rcl", inc: int = 1,
        topic: str = "") -> Record:
    return {"type": "bus", "t": t, "topic": topic or kind, "src": src, "inc": inc,
            "kind": kind, "body": body}


def status(t: float, uuid: str, state: str, inc: int = 1, reason: str = "",
           critical: str = "", bound: float = 0.0, deferring: bool = False,
           **extra: Any) -> Record:
    return bus(t, "action.status", {"uuid": uuid, "state": state, "reason": reason,
                                    "progress": {}, "robot": "uav1", "critical": critical,
                                    "critical_bound": bound, "deferring": deferring,
                                    **extra}, inc=inc)


def request(t: float, uuid: str, goal: str, name: str = "cover", inc: int = 1) -> Record:
    return bus(t, "action.request", {"uuid": uuid, "name": name, "args": ["uav1", goal],
                                     "robot": "uav1", "goal": goal, "priority": 1,
                                     "literal": f"{name}(uav1,{goal})"},
               src="reasoner", inc=inc)


def role_request(t: float, uuid: str, goal: str, caps: tuple[str, ...] = ("uav",),
                 inc: int = 1) -> Record:
    """sweep(any([caps]), goal): a task addressed to a role."""
    role = f"any([{', '.join(caps)}])"
    return bus(t, "action.request", {"uuid": uuid, "name": "sweep", "args": [role, goal],
                                     "robot": "", "goal": goal, "priority": 1,
                                     "literal": f"sweep({role},{goal})",
                                     "role": {"capabilities": list(caps)}},
               src="reasoner", inc=inc)


def allocation(t: float, uuid: str, state: str, robot: str = "", why: str = "",
               wait: str = "", inc: int = 1) -> Record:
    return bus(t, "action.allocation", {"uuid": uuid, "state": state, "robot": robot,
                                        "wait": wait, "why": why, "name": "sweep",
                                        "goal": ""}, inc=inc)


def log(t: float, component: str, message: str, pid: int = 100) -> Record:
    return {"type": "logline", "t": t, "component": component, "pid": pid, "level": "INFO",
            "message": message}


def action(uuid: str, goal: str, state: str, created: float, name: str = "cover",
           inc: int = 1) -> Record:
    return {"uuid": uuid, "name": name, "robot": "uav1", "goal": goal, "state": state,
            "reason": "", "requester": "reasoner", "requester_inc": inc, "created": created}


def transitions(uuid: str, *steps: tuple[str, float], first_seq: int = 1) -> list[Record]:
    return [{"seq": first_seq + i, "uuid": uuid, "state": s, "reason": "", "t": t}
            for i, (s, t) in enumerate(steps)]


def operator(t: float, intent: str, goal: str = "", ok: bool = True, **extra: Any) -> Record:
    return {"type": "operator", "t": t, "intent": intent, "topic": f"mrss/ui/{intent}",
            "payload": {}, "ok": ok, "goal": goal, **extra}


TREE = {"id": "root", "state": "running", "children": [
    {"id": "rcl", "state": "running", "children": []},
    {"id": "reasoner", "state": "running", "children": []},
    {"id": "datalayer", "state": "running", "restarts": 1, "children": []}]}


def probe(t: float, waiting: list[str] = (), open_actions: list[Record] = (),  # type: ignore[assignment]
          beliefs: list[str] = (), tree: Any = TREE) -> Record:  # type: ignore[assignment]
    intentions = [{"id": i + 1, "waiting_on": f"action '{u}'"} for i, u in enumerate(waiting)]
    return {"type": "probe", "t": t, "tree": tree, "system_running": True,
            "mind": {"agent": "reasoner", "beliefs": list(beliefs), "intentions": intentions,
                     "events": []},
            "open_actions": list(open_actions)}


def robot_state(t: float, robot: str, available: bool = True, link: str = "up") -> Record:
    return bus(t, "robot.state", {"robot": robot, "available": available, "link": link,
                                  "reason": "", "attributes": {}},
               topic=f"robot.{robot}.state")


def healthy() -> list[Record]:
    return [
        {"type": "campaign", "t": 0.0, "project": "test", "seed": 1, "planned": [{}],
         "reasoners": ["reasoner"], "rcls": ["rcl"],
         "pending_beliefs": ["queued", "waiting", "task"],
         "mode_beliefs": {"teleop": "paused({robot},teleop)"},
         "robots": {"uav1": ["uav", "camera"], "ugv1": ["ugv"]}, "award_bound": AWARD_BOUND},
        bus(0.5, "sup.heartbeat", {"component": "reasoner", "pid": 100}, src="reasoner"),
        robot_state(0.6, "uav1"),
        operator(1.0, "goal", "a1"),
        request(2.0, U1, "a1"),
        status(2.1, U1, "pending"),
        status(2.2, U1, "running", name="cover", progress_bound=6.0),
        status(2.3, U1, "running", critical="landing", bound=5.0, progress_bound=6.0),
        status(6.0, U1, "running", reason="critical section 'landing' ended",
               progress_bound=6.0),
        status(7.0, U1, "running"),  # a progress update (a repeat of the state)
        operator(3.0, "mode", robot="ugv1", mode="teleop", on=True),
        operator(4.0, "mode", robot="ugv1", mode="teleop", on=False),
        bus(4.5, "robot.data", {"robot": "ugv1", "data": {"type": "status", "teleop": False}}),
        {"type": "fault", "t": 5.0, "kind": "kill", "target": "datalayer", "pid": 7,
         "duration": 0.0, "ok": True},
        status(10.0, U1, "succeeded"),
        role_request(11.0, U3, "t1"),
        allocation(11.05, U3, "awarded", "uav1", "uav1: finish in 1 s"),
        status(11.1, U3, "running"),
        status(12.0, U3, "succeeded"),
        bus(12.05, "log.record", {"component": "reasoner", "level": "INFO",
                                  "message": f"action {U3} sweep(uav1,t1) succeeded"},
            src="reasoner"),
        bus(10.3, "sup.event", {"event": "restart", "child": "datalayer", "detail": {}},
            src="supervisor", inc=0),
        log(10.05, "reasoner", f"action {U1} cover(uav1,a1) succeeded"),
        probe(30.0),
        {"type": "journal", "t": 40.0,
         "actions": [action(U1, "a1", "succeeded", 2.1),
                     action(U3, "t1", "succeeded", 11.0, name="sweep")],
         # U1's last (tests edit its terminal transition as the last one)
         "transitions": transitions(U3, ("pending", 11.0), ("running", 11.1),
                                    ("succeeded", 12.0), first_seq=11)
         + transitions(U1, ("pending", 2.1), ("running", 2.2), ("succeeded", 10.0)),
         "teleop": {}},
        {"type": "log", "t": 40.5, "file": "run/mrss.log", "lines": 1},
        {"type": "end", "t": 41.0, "faults_ended": 5.0, "exit_code": 0},
    ]


def edit(records: list[Record], record_type: str) -> Record:
    """The (first) record of a type, to change in place."""
    return next(r for r in records if r["type"] == record_type)
