"""Intention management as Jason 3.1 does it: `.suspend`, `.resume`, `.suspended`,
`.fail_goal`, `.succeed_goal`, `.drop_intention`, `.drop_all_*`, `.intend`, `.desire`.
Each program's expected lines are what Jason 3.1 (built from its source, run as a
one-agent MAS) printed for it, its logger's warnings left out. Each runs in-process and
through `mrss agent` (a real process). The rules are AGENTSPEAK.md's "Goals and failure";
where it is silent, Jason's source decides (named beside each program)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mrss.agentspeak.agent import Agent

PROGRAMS: dict[str, tuple[str, list[str]]] = {
    # AGENTSPEAK.md: ".fail_goal(G) posts -!G (no error annotation) and then the parent
    # continues"; ".succeed_goal(G) pops down to G as if it had finished". A -!g plan is
    # looked for at the nearest goal whose predicate has one (Intention.
    # findEventForFailure: PlanLibrary.hasCandidatePlan, functor and arity only): -!b(1)
    # is b(3)'s candidate, does not apply, and the intention ends there
    # (generateGoalDeletionFromEvent) -- a(3)'s -!a plan does not run.
    "fail_succeed_stack": ("""\
!start.
+!start <- !!a(1); !!a(2); !!a(3); .wait(ready(1) & ready(2) & ready(3));
   .fail_goal(b(1)); .wait(after(1));
   .succeed_goal(b(2)); .wait(after(2));
   .fail_goal(b(3)); .print(end).
+!a(N) <- !b(N); .print(a_after_b(N)); +after(N).
+!b(N) <- !c(N); .print(never(b,N)).
+!c(N) <- +ready(N); .wait({+never}); .print(never(c,N)).
-!b(1) <- .print(b_failed(1)).
-!a(N) <- .print(a_failed(N)).
""", ["b_failed(1)", "a_after_b(1)", "a_after_b(2)", "end"]),
    # A goal that is still an event (`!!e` inside an [atomic] plan): .fail_goal turns
    # it into -!e1 in its place in the queue (fail_goal.dropInEvent), .succeed_goal
    # removes it (succeed_goal.dropInEvent), .drop_intention leaves it (no intention
    # holds it yet).
    "goal_events": ("""\
!start.
@h[atomic]
+!start <- !!e1; !!e2; !!e3; .fail_goal(e1); .succeed_goal(e2); .drop_intention(e3);
   .print(held).
+!e1 <- .print(e1_runs).
-!e1 <- .print(e1_failed).
+!e2 <- .print(e2_runs).
+!e3 <- .print(e3_runs).
""", ["held", "e1_failed", "e3_runs"]),
    # A goal that is still an event, suspended and resumed: its goal states are
    # suspended (suspend_ia: Circumstance.addPendingEvent tells the goal listeners),
    # resumed (resume_ia) and pending again as the event is added back (resume.java);
    # a .fail_goal'ed event keeps its place though a goal-state meta-event goes first.
    "event_goal_states": ("""\
!start.
@s[atomic]
+!start <- !!go(1); .suspend(go(1)); .print(suspended_event);
   !!e1; !!e2; .fail_goal(e1); .print(held);
   .resume(go(1)); .print(resumed_event).
+!go(N) <- .print(go(N)).
+!e1 <- .print(e1_runs).
-!e1 <- .print(e1_failed).
+!e2 <- .print(e2_runs).
^!go(N)[state(S)[reason(R)]] <- .print(state(go(N), S, R)).
""", ["suspended_event", "held", "resumed_event", 'state(go(1),pending,"")',
      "state(go(1),suspended,suspend_ia)", "state(go(1),resumed,resume_ia)",
      'state(go(1),pending,"")', "e1_failed", "e2_runs", "go(1)",
      'state(go(1),executing,"")', 'state(go(1),achieved,"")', 'state(go(1),finished,"")']),
    # AGENTSPEAK.md: ".intend(G) holds for a goal anywhere in any intention's stack,
    # blocked ones included" -- but not one suspended by .suspend (intend.java passes
    # considerSuspended=false; desire.java true). .suspended(G, R) gives the reason of
    # the first intention with G that is not running (suspended.java: pending actions,
    # `act`, first; then the pending intentions, whose reason a .suspend does not
    # change: a .wait keeps wait(Id)[What], wait.java's pendingReason).
    "suspend_intend": ("""\
!start.
+!start <- !!s(1); .wait(waiting(s(1))); !!t; .wait(waiting(t));
   .suspend(s(1));
   .findall(R, .suspended(s(1), R), L1); .print(L1);
   .findall(R2, .suspended(t, R2), L2); .print(L2);
   .suspend(t); .findall(R3, .suspended(t, R3), L3); .print(L3);
   .findall(S, .intention(_, S), L4); .print(L4);
   if (.intend(s(1))) { .print(s_intended) } else { .print(s_not_intended) }
   if (.desire(s(1))) { .print(s_desired) } else { .print(s_not_desired) }
   .resume(t); if (.intend(t)) { .print(t_intended) }
   .resume(s(1)); +go; +go(t); .wait(done(1) & done(t)); .print(end).
+!s(N) <- .wait({+go}); +done(N).
+!t <- .wait({+go(t)}); +done(t).
^!s(N)[state(waiting)] <- +waiting(s(N)).
^!t[state(waiting)] <- +waiting(t).
""", ["[wait(2)[go]]", "[wait(4)[go(t)]]", "[wait(4)[go(t)]]",
      "[running,suspended,suspended]", "s_not_intended", "s_desired", "t_intended", "end"]),
    # `.suspend` with no argument suspends the running intention: suspend.java puts it
    # in the pending intentions with the reason suspend_ia; .intend leaves it out,
    # .desire does not; .resume lets it go on after the .suspend.
    "self_suspend": ("""\
!start.
+!start <- !!sleeper; .wait(asleep);
   .findall(R, .suspended(sleeper, R), L); .print(L);
   if (.intend(sleeper)) { .print(intended) } else { .print(not_intended) }
   if (.desire(sleeper)) { .print(desired) }
   .resume(sleeper); .wait(awake); .print(end).
+!sleeper <- .suspend; .print(woke); +awake.
^!sleeper[state(suspended)] <- +asleep.
""", ["[suspend_ia]", "not_intended", "desired", "woke", "end"]),
    # drop_all_intentions.java clears the running, pending and waiting intentions, and
    # drop_all_desires.java the events too; the intention that runs the action is in
    # none of these sets then, so it goes on.
    "drop_all": ("""\
!start.
+!start <- !!w(1); .wait(ready(1)); .print(dropping); .drop_all_intentions; .print(goes_on);
   .findall(N, .intend(w(N)), L); .print(L);
   !!w(2); .wait(ready(2)); !!x; .drop_all_desires; .print(still_goes_on);
   .findall(G, .desire(G), L2); .print(L2).
+!w(N) <- +ready(N); .wait({+never}); .print(never(N)).
+!x <- .print(never_x).
""", ["dropping", "goes_on", "[]", "still_goes_on", "[start[source(self)]]"]),
}


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_intention_management_prints_what_jason_printed(name: str) -> None:
    source, expected = PROGRAMS[name]
    out: list[str] = []
    Agent(source, file=f"{name}.asl", out=out.append).run_until_idle()
    assert out == expected


@pytest.mark.parametrize("name", ["fail_succeed_stack", "suspend_intend"])
def test_mrss_agent_manages_intentions_as_jason(name: str, tmp_path: Path) -> None:
    source, expected = PROGRAMS[name]
    (tmp_path / f"{name}.asl").write_text(source, encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent", f"{name}.asl",
                           "--max-time", "20"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines() == expected
