// The wildfire agent (KISecAssist, paper VI): one UAV covers areas and finds hotspots,
// one UGV brings water to them. Listing 1's priorities, cancellation and priority changes,
// generalised to any number of goals per robot:
//
// - a goal waits in `queued(R, G, P, Job)` until its robot is free, or pre-empts the
//   running task when its priority is higher: the running task is SUSPENDED through
//   rcl_goal_management (its intention stays blocked on its action, its progress is
//   kept by the RCL) and is resumed, from where it stopped, when it is the best again;
// - `paused(R, Why)` (battery, water, teleop) holds a robot's goals: the running one is
//   suspended, a high-priority service action runs (recharge, refill), then the
//   scheduler resumes the best goal;
// - percepts come from events.py (operator), the data layer (battery_low, water_low),
//   the world model rules (hotspot_detected) and the reasoner (robot_unavailable).
//
// Actions are `name(Robot, Goal, ...)`: the RCL (rcl.py) refines them into skills.

/* ---------------------------------------------------------------- initial beliefs */
isuav(uav1).
isugv(ugv1).
robot(uav1).
robot(ugv1).
water_per_hotspot(60).      // litres the UGV pumps on one hotspot
goals(0).                   // goals admitted so far

/* ---------------------------------------------------------------- rules */
paused(R) :- paused(R, _).
paused(R) :- robot_unavailable(R).
// Every goal of R that is not running, with a sort key: higher priority first, then a
// suspended goal before a queued one, then the oldest (`arrived` numbers the goals).
pending(R, G, c(P, 1, S, G)) :- waiting(R, G, P) & arrived(G, N) & S = 0 - N.
pending(R, G, c(P, 0, S, G)) :- queued(R, G, P, _) & arrived(G, N) & S = 0 - N.
known_goal(G) :- queued(_, G, _, _).
known_goal(G) :- waiting(_, G, _).
known_goal(G) :- task(_, G, _).
known_goal(G) :- retrying(_, G, _, _).
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
+area_goal_received(G, P)[source(percept)] : not known_goal(G) & isuav(R)
   <- .print("area goal ", G, " with priority ", P, " for ", R);
      !admit(R, G, P, cover).

// the operator's forms ([operator.commands] in project.toml)
// (a zone id already in use is refused, with why: the mission panel shows it)
+exclusion_zone(Z, _)[source(percept)] : excluded(Z)
   <- +refused(Z, already_excluded).
+exclusion_zone(Z, Shape)[source(percept)] : .length(Shape, N)
   <- .print("exclusion zone ", Z, " with ", N, " vertices: robots keep out");
      +excluded(Z).

+goal_cancelled(G)[source(percept)] : task(R, G, _)
   <- .print("cancelling running goal ", G);
      +cancelled_goal(G);
      -task(R, G, _);
      .drop_intention(perform(R, G, _, _));     // the RCL cancels its action
      !forget(G);
      !schedule(R).
+goal_cancelled(G)[source(percept)] : waiting(R, G, _)
   <- .print("cancelling suspended goal ", G);
      +cancelled_goal(G);
      -waiting(R, G, _);
      .drop_intention(perform(R, G, _, _));
      !forget(G).
+goal_cancelled(G)[source(percept)] : queued(R, G, _, _)
   <- .print("cancelling queued goal ", G);
      +cancelled_goal(G);
      -queued(R, G, _, _);
      !forget(G).
+goal_cancelled(G)[source(percept)] : retrying(R, G, _, _)
   <- .print("cancelling goal ", G, " before its retry");
      +cancelled_goal(G);
      -retrying(R, G, _, _);
      !forget(G).
+goal_cancelled(G)[source(percept)]
   <- .print("cancel of unknown goal ", G, " ignored");
      !forget(G).

+prioritychange(G, P)[source(percept)] : queued(R, G, Q, Job)
   <- -queued(R, G, Q, Job); +queued(R, G, P, Job);
      -prioritychange(G, P)[source(percept)];
      !schedule(R).
+prioritychange(G, P)[source(percept)] : waiting(R, G, Q)
   <- -waiting(R, G, Q); +waiting(R, G, P);
      -prioritychange(G, P)[source(percept)];
      !schedule(R).
+prioritychange(G, P)[source(percept)] : retrying(R, G, Q, Job)
   <- -retrying(R, G, Q, Job); +retrying(R, G, P, Job);
      -prioritychange(G, P)[source(percept)].
+prioritychange(G, P)[source(percept)] : task(R, G, Q)
   <- -task(R, G, Q); +task(R, G, P);
      -prioritychange(G, P)[source(percept)];
      !schedule(R).
+prioritychange(G, P)[source(percept)]
   <- .print("priority change of unknown goal ", G, " ignored");
      -prioritychange(G, P)[source(percept)].

/* ---------------------------------------------------------------- field percepts */
// a hotspot with no water source nearby (world model rule): the UGV brings water
+hotspot_detected(H, Lat, Lon)[source(percept)]
     : not known_goal(H) & not supplied(H) & isugv(R)
   <- .print("hotspot ", H, " at ", Lat, ",", Lon, ": sending ", R);
      !admit(R, H, 10, supply(Lat, Lon)).

// UAV battery low: suspend its goal, fly home, recharge, go on where it left off
+battery_low(R)[source(percept)] : isuav(R) & not paused(R, battery)
   <- .print(R, " battery low: returning home");
      !service(R, battery, recharge).

// UGV water low: suspend its goal, refill at base, go on
+water_low(R)[source(percept)] : isugv(R) & not paused(R, water)
   <- .print(R, " water low: refilling at base");
      !service(R, water, refill).

// Teleoperation (paper VI): the operator's wish is the percept teleop(R, on|off). On:
// suspend every goal of the robot and switch it to direct control with a skill; off:
// switch it back, then resume. Every change of the wish starts its own switch. One that
// fails for a cause worth a retry (the link is down, the RCL restarted) is tried again
// every 2 s, at most max_switch_tries times, for as long as the operator still wants
// that mode, and not once the wish has changed: "on" retried after the operator said
// "off" would leave the robot teleoperated while the agent believes it drives it (chaos
// seed 6). A refusal (`rejected`: the RCL has no such robot) is not tried again. A
// switch given up is tried again when its robot becomes available again.
+teleop(R, on)[source(percept)] : not paused(R, teleop)
   <- .print(R, " switched to teleoperation: its goals are suspended");
      +paused(R, teleop);
      !hold_task(R);
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
      !schedule(R).
+!switched(R, _).

// All robots hold (the operator's "all robots hold"): every robot's running goal is
// suspended, new goals queue; when the hold is lifted each robot resumes its best goal.
+hold_all[source(percept)]
   <- .print("operator: all robots hold");
      .findall(R, robot(R), Rs);
      !hold_each(Rs).
-hold_all[source(percept)]
   <- .print("operator: hold lifted");
      .findall(R, robot(R), Rs);
      !release_each(Rs).
+!hold_each([]).
+!hold_each([R|Rs]) <- +paused(R, hold); !hold_task(R); !hold_each(Rs).
+!release_each([]).
+!release_each([R|Rs]) <- -paused(R, hold); !schedule(R); !release_each(Rs).

+robot_unavailable(R)[source(percept)]
   <- .print(R, " is unavailable: its goals wait").
-robot_unavailable(R)[source(percept)]
   <- .print(R, " is available again");
      !retry_given_up(R);
      !schedule(R).
// What was given up for lack of the robot gets a new budget now that it is back.
+!retry_given_up(R) : switch_given_up(R, Mode) & teleop(R, Mode)
   <- -switch_given_up(R, Mode);
      !!switch_mode(R, Mode, 1).
+!retry_given_up(R) : service_given_up(R, Why, Action)
   <- -service_given_up(R, Why, Action);
      !!service(R, Why, Action).
+!retry_given_up(R).

/* ---------------------------------------------------------------- scheduling */
// The scheduling plans are [atomic]: between a plan's context (`not task(R, _, _)`,
// `queued(R, G, _, Job)`) and its belief changes no other intention may run. Goals that
// arrive together (a burst from the operator, or every durable goal perceived again at
// once by a restarted reasoner) would otherwise each find the robot free and start it
// two or three times.
@admit[atomic]
+!admit(R, G, P, Job) : goals(N)
   <- -done_goal(G); -cancelled_goal(G); -failed_goal(G);   // sent again: open again
      -+goals(N + 1);
      +arrived(G, N + 1);
      +queued(R, G, P, Job);
      !schedule(R).

// Start the best pending goal of R if R is free, or pre-empt a lower-priority task.
@schedule_paused[atomic]
+!schedule(R) : paused(R).
@schedule_free[atomic]
+!schedule(R) : not task(R, _, _) & .findall(K, pending(R, _, K), L) & L \== []
   <- .max(L, c(P, _, _, G));
      !begin(R, G, P).
@schedule_preempt[atomic]
+!schedule(R) : task(R, H, Q) & .findall(K, pending(R, _, K), L) & L \== []
             & .max(L, c(P, _, _, G)) & P > Q
   <- .print("goal ", G, " (priority ", P, ") pre-empts ", H, " (priority ", Q, ")");
      !hold_task(R);
      !begin(R, G, P).
@schedule_none[atomic]
+!schedule(R).

@begin_resume[atomic]
+!begin(R, G, P) : waiting(R, G, _)
   <- .print("resuming ", G, " on ", R);
      -waiting(R, G, _);
      +task(R, G, P);
      rcl_goal_management(resume, G).        // its intention goes on, from its progress
@begin_queued[atomic]
+!begin(R, G, P) : queued(R, G, _, Job)
   <- -queued(R, G, _, Job);
      +task(R, G, P);
      !!perform(R, G, P, Job).

// Suspend R's running task (if any): it waits to be resumed by the scheduler.
@hold_running[atomic]
+!hold_task(R) : task(R, H, Q)
   <- -task(R, H, Q);
      +waiting(R, H, Q);
      rcl_goal_management(suspend, H).
@hold_none[atomic]
+!hold_task(R).

// One intention per goal; it blocks on the action until the RCL reports the end.
+!perform(R, G, P, cover)
   <- .print(R, " covers ", G);
      cover(R, G)[priority(P)];
      .print(R, " covered ", G);
      +done_goal(G);                            // the dashboard shows how goals end
      !finished(R, G).
+!perform(R, G, P, supply(Lat, Lon)) : water_per_hotspot(L)
   <- .print(R, " brings water to ", G);
      supply_water(R, G, Lat, Lon, L)[priority(P)];
      .print(R, " pumped ", L, " l on ", G);
      +supplied(G);
      +done_goal(G);
      -hotspot_detected(G, _, _)[source(percept)];   // dealt with: not re-derived
      !finished(R, G).
// A failure whose cause is transient (a restarted component, a lost link, the robot's
// failsafe) puts the goal back in the queue a few times: the scheduler starts it again
// once the robot is available. Any other failure, or too many, ends the goal. For the
// second before it is queued again the goal is `retrying`: a cancel or a priority
// change meanwhile applies to it (a cancel is not one of an unknown goal).
-!perform(R, G, P, Job)[error(E)] : retryable(E) & tries(G, N) & max_tries(M) & N < M
   <- .print("goal ", G, " of ", R, " failed (", E, "): retry ", N + 1, " of ", M);
      -task(R, G, _); -waiting(R, G, _);
      -tried(G, _); +tried(G, N + 1);         // not -+tried: it replaces any goal's count
      +retrying(R, G, P, Job);
      .wait(1000);
      !requeue(R, G).
// Given up, the goal is told to the operator (give_up: an alert with its reason and
// the last cause): its retries used up, or a failure not worth a retry.
-!perform(R, G, P, Job)[error(E)] : retryable(E)
   <- .print("goal ", G, " of ", R, " failed (", E, "): given up, its retries used up");
      +failed_goal(G);
      give_up(G, budget_exhausted, E);
      !finished(R, G).
-!perform(R, G, P, Job)[error(E)]
   <- .print("goal ", G, " of ", R, " failed (", E, ")");
      +failed_goal(G);
      give_up(G, plan_failed, E);
      !finished(R, G).

@requeue[atomic]
+!requeue(R, G) : retrying(R, G, P, Job)
   <- -retrying(R, G, P, Job);
      +queued(R, G, P, Job);
      !schedule(R).
+!requeue(R, G).                            // cancelled meanwhile

+!finished(R, G) <- -task(R, G, _); -waiting(R, G, _); !forget(G); !schedule(R).

// Percepts stay beliefs until removed: forget those of a finished goal, so that the
// operator may send the same goal (or cancel, or priority) again. A percept still held
// is mission state: a restarted reasoner perceives it again and re-derives the goal
// (its running action is adopted, not redone), so a goal is forgotten only when done.
+!forget(G)
   <- -area_goal_received(G, _)[source(percept)];
      -goal_cancelled(G)[source(percept)];
      -prioritychange(G, _)[source(percept)];
      -tried(G, _);
      -arrived(G, _).

// Battery / water service: hold the goal, run the service action above every goal's
// priority, then let the scheduler resume the best goal. A service that fails for a
// cause worth a retry (the link was lost, the RCL restarted meanwhile) is tried again
// every second, max_service_tries times, and once more when the robot is available
// again: given up for good, it would leave the robot paused, its goals waiting on a
// battery or a tank nobody fills (chaos, 10 kills of the reasoner and the RCL).
+!service(R, Why, Action)
   <- +paused(R, Why);
      !hold_task(R);
      !serviced(R, Why, Action, 1).
+!serviced(R, Why, Action, N)
   <- !run_service(R, Action);
      -paused(R, Why);
      .print(R, " ", Action, " done");
      !schedule(R).
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
      give_up(service(R, Action), budget_exhausted, E).
-!serviced(R, Why, Action, N)[error(E)]
   <- .print(R, " ", Action, " failed (", E, "): its goals wait until ", Why, " is fixed").

// a failed service leaves the robot paused: fixed by hand (the percept goes away), it
// goes on with its goals
-battery_low(R)[source(percept)] : paused(R, battery) & not .intend(service(R, battery, _))
   <- -paused(R, battery); -service_given_up(R, battery, _); !schedule(R).
-water_low(R)[source(percept)] : paused(R, water) & not .intend(service(R, water, _))
   <- -paused(R, water); -service_given_up(R, water, _); !schedule(R).
