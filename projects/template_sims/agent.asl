// The reasoner's program: an operator sends a robot to a point (events.py).
// ADAPT: your beliefs, percept reactions and plans (the template's agent.asl explains
// the conventions). Environment actions are `name(Robot, Goal, ...)`: `fly` for the UAV,
// `drive` for the UGV (rcl.py refines them into skills.py's FlyTo and DriveTo).
// Check it: `mrss agent projects/NAME/agent.asl` or `mrss check NAME`.

uav(uav1).
ugv(ugv1).

// Failure causes worth another try (the RCL's FailureCause values): the robot or a
// component was away for a moment (a lost link, the robot's failsafe, a restarted RCL).
// ADAPT: which causes your goals retry, and how often.
retryable(transient).
retryable(link_down).
retryable(failsafe).
retryable(quarantined).        // its actor kept crashing: retried after its probation
max_tries(3).
tries(G, N) :- tried(G, N).
tries(G, 0) :- not tried(G, _).

+goto_received(G, R, Lat, Lon)[source(percept)]
   <- .print("goal ", G, ": ", R, " goes to ", Lat, ",", Lon);
      !reach(R, G, Lat, Lon).

+goal_cancelled(G)[source(percept)]
   <- .drop_intention(reach(_, G, _, _));
      .print("goal ", G, " cancelled");
      !forget(G).

// a new goal for a busy robot pre-empts nothing: the RCL queues it on the robot's
// "motion" resource until the running one ends
+!reach(R, G, Lat, Lon) : uav(R)
   <- fly(R, G, Lat, Lon);
      .print("goal ", G, " reached by ", R);
      !forget(G).
+!reach(R, G, Lat, Lon) : ugv(R)
   <- drive(R, G, Lat, Lon);
      .print("goal ", G, " reached by ", R);
      !forget(G).
+!reach(R, G, _, _)
   <- .print("goal ", G, ": no robot ", R);
      !forget(G).
// A failure for a retryable cause tries the goal again a second later, a few times;
// any other failure (or one too many) ends it. Count with -tried(G, _); +tried(G, N + 1),
// not -+tried(G, N + 1): Jason's -+ removes the first tried/2 of ANY goal.
-!reach(R, G, Lat, Lon)[error(E)] : retryable(E) & tries(G, N) & max_tries(M) & N < M
   <- .print("goal ", G, " failed (", E, "): retry ", N + 1, " of ", M);
      -tried(G, _); +tried(G, N + 1);
      .wait(1000);
      !reach(R, G, Lat, Lon).
// Given up, a goal is told to the operator (give_up: an alert with its reason and the
// last cause, on the dashboard).
-!reach(R, G, _, _)[error(E)] : retryable(E)
   <- .print("goal ", G, " given up after its retries: ", E);
      give_up(G, budget_exhausted, E);
      !forget(G).
-!reach(R, G, _, _)[error(E)]
   <- .print("goal ", G, " failed: ", E);
      give_up(G, plan_failed, E);
      !forget(G).

+!forget(G)
   <- -goto_received(G, _, _, _)[source(percept)];
      -goal_cancelled(G)[source(percept)];
      -tried(G, _).

+robot_unavailable(R)[source(percept)] <- .print(R, " is unavailable").

// A goal addressed to a role, not a robot: "any robot with a camera, near there". The
// RCL awards it to the robot that finishes it first, among those declaring both
// capabilities in project.toml (`capabilities = ["uav", "camera"]`); a goal waits
// while none is free. If that robot is lost on the way (its link, its failsafe, the
// operator decommissions it), the RCL hands the task to another capable robot, which
// goes on from the progress recorded, and the agent hears `reassigned(Task, From, To)`:
// the action does not fail (docs/agentspeak.md, "Tasks addressed to a role").
// ADAPT: the capabilities your tasks need; `any([uav])` for any UAV.
+survey_received(G, Lat, Lon)[source(percept)]
   <- .print("goal ", G, ": any robot with a camera goes to ", Lat, ",", Lon);
      !survey(G, Lat, Lon).
+!survey(G, Lat, Lon)
   <- fly(any([uav, camera], at(Lat, Lon)), G, Lat, Lon);
      .print("goal ", G, " surveyed");
      -survey_received(G, Lat, Lon)[source(percept)].
-!survey(G, Lat, Lon)[error(E)]               // never reassigned: it failed for good
   <- .print("goal ", G, " failed: ", E);
      give_up(G, plan_failed, E);
      -survey_received(G, Lat, Lon)[source(percept)].
+reassigned(fly(_, G, _, _), From, To)[source(percept)]
   <- -reassigned(fly(_, G, _, _), From, To)[source(percept)];
      .print("goal ", G, " went from ", From, " to ", To).
