// The wildfire agent (KISecAssist, paper VI): three UAVs cover areas and find hotspots,
// two UGVs bring water to them. Listing 1's priorities, cancellation and priority
// changes, for a fleet:
//
// - a goal is a task addressed to a role, not to a robot: an area goal asks for
//   `any([uav, camera])`, a hotspot for `any([ugv, water], at(Lat, Lon))` (the
//   capabilities are declared in project.toml). The RCL gives each task to the robot
//   that finishes it first; a task of higher priority pre-empts lower-priority work
//   (suspended, its progress kept, resumed on that robot when it is the best again); a
//   task no capable robot can take now waits until one can (docs/rcl.md, "Allocation");
// - a robot lost mid-task (its link past its timeout, its failsafe, its battery
//   critical, decommissioned by the operator) hands the task to another capable robot,
//   which goes on from the progress recorded (the next lawnmower waypoint, the litres
//   still to pump): the action does not fail, the agent hears `reassigned(Task, From, To)`;
// - `paused(R, Why)` (battery, water, teleop, hold) holds one named robot: a service
//   action (recharge, refill) runs above every goal's priority and suspends the goal
//   on that robot through its motion resource, teleop and the operator's hold suspend
//   the robot's actions (`rcl_goal_management(suspend, robot(R))`) until it is released;
// - percepts come from events.py (operator), the data layer (battery_low, water_low),
//   the world model rules (hotspot_detected) and the reasoner (robot_unavailable).
//
// Actions are `name(Robot, Goal, ...)`, Robot a robot's id or a role: the RCL (rcl.py)
// refines them into skills.

/* ---------------------------------------------------------------- initial beliefs */
isuav(uav1).
isuav(uav2).
isuav(uav3).
isugv(ugv1).
isugv(ugv2).
// What each kind of goal asks of its robot: the RCL awards it among those with all these
// capabilities (a hotspot's place ranks the nearer UGVs first).
role(cover, any([uav, camera])).
role(supply(Lat, Lon), any([ugv, water], at(Lat, Lon))).
water_per_hotspot(60).      // litres a UGV pumps on one hotspot

/* ---------------------------------------------------------------- rules */
robot(R) :- isuav(R).
robot(R) :- isugv(R).
paused(R) :- paused(R, _).
// A goal is `task(Role, G, P)` from the moment it is asked of the RCL until it ends,
// `retrying(Role, G, P, Job)` for the second before a retry, `on_hold(G, P, Job)` while
// the operator holds every robot.
known_goal(G) :- task(_, G, _).
known_goal(G) :- retrying(_, G, _, _).
known_goal(G) :- on_hold(G, _, _).
// failure causes worth another try (the RCL's FailureCause values)
retryable(transient).
retryable(link_down).
retryable(failsafe).
retryable(quarantined).     // its actor kept crashing: retried after its probation
max_tries(3).
// Every retry loop has a budget: a teleop switch is tried at most max_switch_tries times
// (2 s apart), a recharge or refill max_service_tries times (1 s apart). One given up
// gets a new budget when its robot becomes available again (-robot_unavailable).
max_switch_tries(30).
max_service_tries(60).
tries(G, N) :- tried(G, N).
tries(G, 0) :- not tried(G, _).

/* ---------------------------------------------------------------- operator percepts */
+area_goal_received(G, P)[source(percept)] : not known_goal(G) & role(cover, Role)
   <- .print("area goal ", G, " with priority ", P, " for ", Role);
      !admit(G, P, cover).

// the operator's forms ([operator.commands] in project.toml)
// (a zone id already in use is refused, with why: the mission panel shows it)
+exclusion_zone(Z, _)[source(percept)] : excluded(Z)
   <- +refused(Z, already_excluded).
+exclusion_zone(Z, Shape)[source(percept)] : .length(Shape, N)
   <- .print("exclusion zone ", Z, " with ", N, " vertices: robots keep out");
      +excluded(Z).

// A cancel drops the goal's intention: the RCL cancels its action, wherever it is
// (running, suspended, or waiting for a robot).
+goal_cancelled(G)[source(percept)] : task(_, G, _)
   <- .print("cancelling goal ", G);
      +cancelled_goal(G);
      -task(_, G, _);
      .drop_intention(perform(G, _, _));
      !forget(G).
+goal_cancelled(G)[source(percept)] : retrying(_, G, _, _)
   <- .print("cancelling goal ", G, " before its retry");
      +cancelled_goal(G);
      -retrying(_, G, _, _);
      !forget(G).
+goal_cancelled(G)[source(percept)] : on_hold(G, _, _)
   <- .print("cancelling goal ", G, " held by the operator");
      +cancelled_goal(G);
      -on_hold(G, _, _);
      !forget(G).
+goal_cancelled(G)[source(percept)]
   <- .print("cancel of unknown goal ", G, " ignored");
      !forget(G).

// A new priority for an asked goal: its action is withdrawn and asked again at that
// priority, so the RCL awards it anew (a higher one may pre-empt lower-priority work, a
// lower one may yield its robot). A cover goes on from the last waypoint reached (rcl.py).
@reprioritise[atomic]
+prioritychange(G, P)[source(percept)] : task(Role, G, Q) & Q \== P & asked(G, Job)
   <- -prioritychange(G, P)[source(percept)];
      -task(Role, G, Q); +task(Role, G, P);
      .print("goal ", G, ": priority ", Q, " -> ", P);
      .drop_intention(perform(G, _, _));
      !!perform(G, P, Job).
+prioritychange(G, P)[source(percept)] : retrying(Role, G, Q, Job)
   <- -retrying(Role, G, Q, Job); +retrying(Role, G, P, Job);
      -prioritychange(G, P)[source(percept)].
+prioritychange(G, P)[source(percept)] : on_hold(G, Q, Job)
   <- -on_hold(G, Q, Job); +on_hold(G, P, Job);
      -prioritychange(G, P)[source(percept)].
+prioritychange(G, P)[source(percept)] : task(_, G, P)        // unchanged
   <- -prioritychange(G, P)[source(percept)].
+prioritychange(G, P)[source(percept)]
   <- .print("priority change of unknown goal ", G, " ignored");
      -prioritychange(G, P)[source(percept)].

/* ---------------------------------------------------------------- field percepts */
// a hotspot with no water source nearby (world model rule): the nearest free UGV brings water
+hotspot_detected(H, Lat, Lon)[source(percept)] : not known_goal(H) & not supplied(H)
   <- .print("hotspot ", H, " at ", Lat, ",", Lon, ": sending a UGV");
      !admit(H, 10, supply(Lat, Lon)).

// UAV battery low: fly home and recharge; its goal is suspended meanwhile (the recharge
// takes the UAV's motion resource) and goes on where it left off
+battery_low(R)[source(percept)] : isuav(R) & not paused(R, battery)
   <- .print(R, " battery low: returning home");
      !service(R, battery, recharge).

// UGV water low: refill at base, then go on
+water_low(R)[source(percept)] : isugv(R) & not paused(R, water)
   <- .print(R, " water low: refilling at base");
      !service(R, water, refill).

// Teleoperation (paper VI): the operator's wish is the percept teleop(R, on|off). On:
// suspend the robot's actions and switch it to direct control with a skill (a task
// awarded to it meanwhile waits in its skill until the robot is handed back,
// skills.py); off: switch it back, then resume them. Every change
// of the wish starts its own switch. One that fails for a cause worth a retry (the link
// is down, the RCL restarted) is tried again every 2 s, at most max_switch_tries times,
// for as long as the operator still wants that mode, and not once the wish has changed:
// "on" retried after the operator said "off" would leave the robot teleoperated while
// the agent believes it drives it (chaos seed 6). A refusal (`rejected`: the RCL has no
// such robot) is not tried again. A switch given up is tried again when its robot
// becomes available again.
+teleop(R, on)[source(percept)] : not paused(R, teleop)
   <- .print(R, " switched to teleoperation: its goals are suspended");
      +paused(R, teleop);
      !hold(R);
      !switch_mode(R, on, 1).
+teleop(R, on)[source(percept)]              // still paused: switching back was under way
   <- !switch_mode(R, on, 1).
+teleop(R, off)[source(percept)] : paused(R, teleop)
   <- !switch_mode(R, off, 1).
+!switch_mode(R, Mode, N)
   <- -switch_given_up(R, _);
      teleop_mode(R, Mode)[priority(1000)];
      !switched(R, Mode).
-!switch_mode(R, Mode, N)[error(E)]
      : teleop(R, Mode) & retryable(E) & max_switch_tries(M) & N < M
   <- .print("switching ", R, " to teleop ", Mode, " failed (", E, "): try ", N + 1,
             " of ", M, " in 2 s");
      .wait(2000);
      !retry_switch(R, Mode, N + 1).
-!switch_mode(R, Mode, N)[error(E)] : teleop(R, Mode) & retryable(E)
   <- .print("switching ", R, " to teleop ", Mode, " failed (", E, "): given up after ",
             N, " tries, until ", R, " is available again");
      +switch_given_up(R, Mode);
      give_up(switch_mode(R, Mode), budget_exhausted, E).
-!switch_mode(R, Mode, N)[error(E)] : teleop(R, Mode)
   <- .print("switching ", R, " to teleop ", Mode, " refused (", E, "): not tried again").
-!switch_mode(R, Mode, N)[error(E)]          // the wish changed: its own switch follows it
   <- .print("switching ", R, " to teleop ", Mode, " failed (", E, "): no longer wanted").
+!retry_switch(R, Mode, N) : teleop(R, Mode)
   <- !switch_mode(R, Mode, N).
+!retry_switch(R, Mode, N).
// Switched back to autonomy, and still wanted so: resume the robot's goals.
@switched_off[atomic]
+!switched(R, off) : teleop(R, off) & paused(R, teleop)
   <- -paused(R, teleop);
      .print(R, " back to autonomous control");
      !release(R).
+!switched(R, _).

// `held(R)`: the agent suspended R's actions; a robot no longer paused for any reason
// gets them back.
+!hold(R) <- +held(R); rcl_goal_management(suspend, robot(R)).
+!release(R) : held(R) & not paused(R) <- -held(R); rcl_goal_management(resume, robot(R)).
+!release(R).

// All robots hold (the operator's "all robots hold"): every robot's actions are
// suspended, new goals are held until the hold is lifted; then every robot resumes.
+hold_all[source(percept)]
   <- .print("operator: all robots hold");
      .findall(R, robot(R), Rs);
      !hold_each(Rs).
-hold_all[source(percept)]
   <- .print("operator: hold lifted");
      .findall(R, robot(R), Rs);
      !release_each(Rs);
      .findall(h(G, P, Job), on_hold(G, P, Job), Held);
      !ask_each(Held).
+!hold_each([]).
+!hold_each([R|Rs])
   <- +paused(R, hold); !hold(R); !hold_each(Rs).
+!release_each([]).
+!release_each([R|Rs]) <- -paused(R, hold); !release(R); !release_each(Rs).
+!ask_each([]).
+!ask_each([h(G, P, Job)|Hs]) <- -on_hold(G, P, Job); !admit(G, P, Job); !ask_each(Hs).

+robot_unavailable(R)[source(percept)]
   <- .print(R, " is unavailable: its tasks addressed to a role go to others").
-robot_unavailable(R)[source(percept)]
   <- .print(R, " is available again");
      !retry_given_up(R).
// What was given up for lack of the robot gets a new budget now that it is back.
+!retry_given_up(R) : switch_given_up(R, Mode) & teleop(R, Mode)
   <- -switch_given_up(R, Mode);
      !!switch_mode(R, Mode, 1).
+!retry_given_up(R) : service_given_up(R, Why, Action)
   <- -service_given_up(R, Why, Action);
      !!service(R, Why, Action).
+!retry_given_up(R).

// A lost robot's task went to another, which goes on from its progress: the intention
// keeps waiting on the same action.
+reassigned(Task, From, To)[source(percept)]
   <- -reassigned(Task, From, To)[source(percept)];
      .print(Task, " went from ", From, " (lost) to ", To).

/* ---------------------------------------------------------------- goals */
// The admission is [atomic]: goals that arrive together (a burst from the operator, or
// every durable goal perceived again at once by a restarted reasoner) are each asked
// once (`known_goal` is true from here on).
@admit_held[atomic]
+!admit(G, P, Job) : hold_all
   <- -done_goal(G); -cancelled_goal(G); -failed_goal(G);   // sent again: open again
      +on_hold(G, P, Job).
@admit[atomic]
+!admit(G, P, Job) : role(Job, Role)
   <- -done_goal(G); -cancelled_goal(G); -failed_goal(G);
      +task(Role, G, P);
      -asked(G, _); +asked(G, Job);
      !!perform(G, P, Job).

// One intention per goal; it blocks on the action until the RCL reports the end (a
// reassignment to another robot is not an end).
+!perform(G, P, cover) : role(cover, Role)
   <- .print("cover ", G, " asked of ", Role);
      cover(Role, G)[priority(P)];
      .print(G, " covered");
      +done_goal(G);                            // the dashboard shows how goals end
      !finished(G).
+!perform(G, P, supply(Lat, Lon)) : role(supply(Lat, Lon), Role) & water_per_hotspot(L)
   <- .print("water for ", G, " asked of ", Role);
      supply_water(Role, G, Lat, Lon, L)[priority(P)];
      .print(L, " l pumped on ", G);
      +supplied(G);
      +done_goal(G);
      -hotspot_detected(G, _, _)[source(percept)];   // dealt with: not re-derived
      !finished(G).
// A failure whose cause is transient (a restarted component, a robot named by the
// action gone) asks for the goal again a second later, a few times. Any other failure,
// or too many, ends the goal. For that second the goal is `retrying`: a cancel or a
// priority change meanwhile applies to it (a cancel is not one of an unknown goal).
-!perform(G, P, Job)[error(E)]
      : retryable(E) & tries(G, N) & max_tries(M) & N < M & role(Job, Role)
   <- .print("goal ", G, " failed (", E, "): retry ", N + 1, " of ", M);
      -task(_, G, _);
      -tried(G, _); +tried(G, N + 1);         // not -+tried: it replaces any goal's count
      +retrying(Role, G, P, Job);
      .wait(1000);
      !requeue(G).
// Given up, the goal is told to the operator (give_up: an alert with its reason and
// the last cause): its retries used up, or a failure not worth a retry.
-!perform(G, P, Job)[error(E)] : retryable(E)
   <- .print("goal ", G, " failed (", E, "): given up, its retries used up");
      +failed_goal(G);
      give_up(G, budget_exhausted, E);
      !finished(G).
-!perform(G, P, Job)[error(E)]
   <- .print("goal ", G, " failed (", E, ")");
      +failed_goal(G);
      give_up(G, plan_failed, E);
      !finished(G).

@requeue[atomic]
+!requeue(G) : retrying(Role, G, P, Job)
   <- -retrying(Role, G, P, Job);
      !admit(G, P, Job).
+!requeue(G).                               // cancelled meanwhile

+!finished(G) <- -task(_, G, _); -asked(G, _); !forget(G).

// Percepts stay beliefs until removed: forget those of a finished goal, so that the
// operator may send the same goal (or cancel, or priority) again. A percept still held
// is mission state: a restarted reasoner perceives it again and re-derives the goal
// (its running action is adopted, not redone), so a goal is forgotten only when done.
+!forget(G)
   <- -area_goal_received(G, _)[source(percept)];
      -goal_cancelled(G)[source(percept)];
      -prioritychange(G, _)[source(percept)];
      -tried(G, _).

// Battery / water service of one robot: the service action runs above every goal's
// priority on the robot's motion resource, so the goal it was working on is suspended
// (its progress kept) and resumed by the RCL when the service is done. A service that
// fails for a cause worth a retry (the link was lost, the RCL restarted meanwhile) is
// tried again every second, max_service_tries times, and once more when the robot is
// available again. A service that fails for good holds the robot's actions (nothing
// flies on a low battery) until the percept goes away (fixed by hand).
+!service(R, Why, Action)
   <- +paused(R, Why);
      !serviced(R, Why, Action, 1).
+!serviced(R, Why, Action, N)
   <- !run_service(R, Action);
      -paused(R, Why);
      .print(R, " ", Action, " done");
      !release(R).
+!run_service(R, recharge) <- recharge(R, recharge)[priority(1000)].
+!run_service(R, refill) <- refill(R, refill)[priority(1000)].
-!serviced(R, Why, Action, N)[error(E)] : retryable(E) & max_service_tries(M) & N < M
   <- .print(R, " ", Action, " failed (", E, "): try ", N + 1, " of ", M, " in 1 s");
      .wait(1000);
      !serviced(R, Why, Action, N + 1).
-!serviced(R, Why, Action, N)[error(E)] : retryable(E)
   <- .print(R, " ", Action, " failed (", E, "): given up after ", N, " tries, until ",
             R, " is available again");
      +service_given_up(R, Why, Action);
      !hold(R);
      give_up(service(R, Action), budget_exhausted, E).
-!serviced(R, Why, Action, N)[error(E)]
   <- .print(R, " ", Action, " failed (", E, "): its goals wait until ", Why, " is fixed");
      !hold(R).

// a failed service leaves the robot paused: fixed by hand (the percept goes away), it
// goes on with its goals
-battery_low(R)[source(percept)] : paused(R, battery) & not .intend(service(R, battery, _))
   <- -paused(R, battery); -service_given_up(R, battery, _); !release(R).
-water_low(R)[source(percept)] : paused(R, water) & not .intend(service(R, water, _))
   <- -paused(R, water); -service_given_up(R, water, _); !release(R).
