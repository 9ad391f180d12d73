// The reasoner's program (paper IV-D, V): standard Jason AgentSpeak.
// ADAPT: your beliefs, percept reactions and plans. Conventions MRSS relies on:
// - percepts from events.py, the data layer and the world model arrive with
//   [source(percept)]; `robot_unavailable(R)` comes from MRSS itself;
// - an environment action is `name(Robot, Goal, ...)`: the RCL runs it on Robot (rcl.py
//   refines it into skills) and the plan blocks until it succeeds or fails;
//   `[priority(P)]` on the action decides who wins a robot's resources. The rule:
//   A resource is held by one action at a time (its skills share it). A request
//   pre-empts the holder if its priority is strictly higher; otherwise it waits.
//   Whenever the resource is free it goes to the highest-priority candidate among the
//   actions waiting for it and those pre-empted from it, the oldest request first among
//   equals. (A pre-empted action is suspended, its progress kept, and resumed then.)
// - rcl_goal_management(cancel|suspend|resume|succeed|fail, Goal) manages running
//   actions (by goal id; or action(Uuid), robot(R));
// - query(Function, [Args], Result) calls a data layer function.
// Check it: `mrss agent projects/NAME/agent.asl` or `mrss check NAME`.

robot(robot1).
free(robot1).

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

// an operator sent a point to reach (events.py: goto_received(Goal, Lat, Lon))
+goto_received(G, Lat, Lon)[source(percept)] : robot(R)
   <- .print("goal ", G, ": ", R, " drives to ", Lat, ",", Lon);
      !reach(R, G, Lat, Lon).

// the dashboard's form ([operator.commands.goto] in project.toml)
+goto_point(G, [Lat, Lon])[source(percept)] : robot(R)
   <- !reach(R, G, Lat, Lon).

// the operator cancels a goal: dropping its intention cancels its action in the RCL
+goal_cancelled(G)[source(percept)] : busy(R, G)
   <- .drop_intention(drive(R, G, _, _));
      -busy(R, G);
      +free(R);
      .print("goal ", G, " cancelled");
      !forget(G).
+goal_cancelled(G)[source(percept)]          // not started yet (or unknown)
   <- .drop_intention(reach(_, G, _, _));
      !forget(G).

// one goal at a time per robot: the others wait until it is free. The claim is
// [atomic]: no other intention runs between its context (free(R)) and -free(R), so
// goals perceived together (or again, all at once, by a restarted reasoner) cannot both
// find the robot free.
@claim[atomic]
+!reach(R, G, Lat, Lon) : free(R)
   <- -free(R);
      +busy(R, G);
      !!drive(R, G, Lat, Lon).
+!reach(R, G, Lat, Lon)
   <- .wait(free(R));
      !reach(R, G, Lat, Lon).
+!drive(R, G, Lat, Lon)
   <- move(R, G, Lat, Lon);
      -busy(R, G);
      +free(R);
      .print("goal ", G, " reached");
      !forget(G).
// A failure for a retryable cause tries again a second later (the robot stays busy
// with the goal), a few times; any other failure (or one too many) ends the goal.
// Count with -tried(G, _); +tried(G, N + 1), not -+tried(G, N + 1): Jason's -+
// removes the first tried/2 of ANY goal.
-!drive(R, G, Lat, Lon)[error(E)]
      : busy(R, G) & retryable(E) & tries(G, N) & max_tries(M) & N < M
   <- .print("goal ", G, " failed (", E, "): retry ", N + 1, " of ", M);
      -tried(G, _); +tried(G, N + 1);
      .wait(1000);
      !drive(R, G, Lat, Lon).
// Given up, a goal is told to the operator (give_up: an alert with its reason and the
// last cause, on the dashboard).
-!drive(R, G, Lat, Lon)[error(E)] : busy(R, G) & retryable(E)
   <- -busy(R, G);
      +free(R);
      .print("goal ", G, " given up after its retries: ", E);
      give_up(G, budget_exhausted, E);
      !forget(G).
-!drive(R, G, Lat, Lon)[error(E)] : busy(R, G)
   <- -busy(R, G);
      +free(R);
      .print("goal ", G, " failed: ", E);
      give_up(G, plan_failed, E);
      !forget(G).

// percepts stay beliefs until removed: forget a goal's, so it may be sent again
+!forget(G)
   <- -goto_received(G, _, _)[source(percept)];
      -goal_cancelled(G)[source(percept)];
      -tried(G, _).

+robot_unavailable(R)[source(percept)] <- .print(R, " is unavailable").

// A goal addressed to a role, not a robot: "any ground robot, near there". The RCL
// gives it to the robot that finishes it first among those declaring the capability in
// project.toml (`capabilities = ["ground"]`); it waits while none is free. If that robot
// is lost on the way (its link, its failsafe, the operator decommissions it), the RCL
// hands the task to another capable robot, which goes on from the progress recorded,
// and the agent hears `reassigned(Task, From, To)`: the action does not fail
// (docs/agentspeak.md, "Tasks addressed to a role").
// ADAPT: the capabilities your tasks need, e.g. `any([uav, camera], at(Lat, Lon))`.
+inspect_received(G, Lat, Lon)[source(percept)]
   <- .print("goal ", G, ": any ground robot goes to ", Lat, ",", Lon);
      !inspect(G, Lat, Lon).
+inspect_point(G, [Lat, Lon])[source(percept)]      // the dashboard's form
   <- !inspect(G, Lat, Lon).
+!inspect(G, Lat, Lon)
   <- move(any([ground], at(Lat, Lon)), G, Lat, Lon);
      .print("goal ", G, " inspected");
      -inspect_received(G, Lat, Lon)[source(percept)].
-!inspect(G, Lat, Lon)[error(E)]              // never reassigned: it failed for good
   <- .print("goal ", G, " failed: ", E);
      give_up(G, plan_failed, E);
      -inspect_received(G, Lat, Lon)[source(percept)].
+reassigned(move(_, G, _, _), From, To)[source(percept)]
   <- -reassigned(move(_, G, _, _), From, To)[source(percept)];
      .print("goal ", G, " went from ", From, " to ", To).
