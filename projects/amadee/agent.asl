// The AMADEE-24 rover agent: one mobile manipulator in a Mars-analog field campaign.
// The mission support sends requests over MQTT (events.py); before every action the
// agent asks the data layer whether it is legal under the operational rules
// (legality.py, with the zones, crew and parameters of the world model):
//
//   query(legal, [Action], Verdict)   Verdict = ["legal"] | ["illegal", Rule, Detail]
//
// A legal action goes to the RCL (rcl.py refines it into skills.py's skills); an illegal
// one is refused, with the rule that forbids it: printed, believed as refused(G, Rule),
// and stored by the data layer as the world model object verdict_<G> for the operator.

rover(rover1).

+drive_received(G, Lat, Lon)[source(percept)] : rover(R)
   <- !act(G, drive(R, G, Lat, Lon)).
+home_received(G)[source(percept)] : rover(R)
   <- !act(G, return_home(R, G)).
+science_received(G, image)[source(percept)] : rover(R)
   <- !act(G, image(R, G)).
+science_received(G, spectrum)[source(percept)] : rover(R)
   <- !act(G, spectrum(R, G)).
+science_received(G, radar)[source(percept)] : rover(R)
   <- !act(G, radar(R, G)).
+science_received(G, sample)[source(percept)] : rover(R)
   <- !act(G, sample(R, G)).

// the dashboard's forms ([operator.commands] in project.toml): a point, a kind of science
+drive_point(G, [Lat, Lon])[source(percept)] : rover(R)
   <- !act(G, drive(R, G, Lat, Lon)).
+science_request(G, Kind)[source(percept)] : rover(R)
   <- !science(R, G, Kind).
+!science(R, G, image) <- !act(G, image(R, G)).
+!science(R, G, spectrum) <- !act(G, spectrum(R, G)).
+!science(R, G, radar) <- !act(G, radar(R, G)).
+!science(R, G, sample) <- !act(G, sample(R, G)).

+goal_cancelled(G)[source(percept)]
   <- .drop_intention(act(G, _));
      .print("goal ", G, " cancelled");
      !forget(G).

// The geofence ([datalayer] geofence = true): the data layer found the rover stopped
// inside a no-go zone and names its shortest legal way out. The drive out is checked like
// any other (no_go_path allows only it from inside); work that arrives meanwhile waits
// until the rover is out, then goes on. Trapped (every way out crosses another zone),
// the rover stays where it is and its moves are refused.
+geofence_exit(R, Z, Lat, Lon)[source(percept)] : rover(R)
   <- .print(R, " is stopped inside no_go zone ", Z, ": leaving it by the shortest legal path");
      !act(geofence, drive(R, geofence, Lat, Lon)).
+geofence_trapped(R, Z)[source(percept)] : rover(R)
   <- .print(R, " is stopped inside no_go zone ", Z,
             " and every way out crosses another zone: it stays where it is").

// the legality check, then the action or its refusal
+!act(G, A) : rover(R) & G \== geofence & geofence_exit(R, Z, _, _)
   <- .print("goal ", G, " waits until ", R, " is out of no_go zone ", Z);
      .wait(not geofence_exit(R, _, _, _));
      .print("goal ", G, " resumes: ", R, " is out of no_go zone ", Z);
      !act(G, A).
+!act(G, A)
   <- -refused(G, _); +acting(G);
      query(legal, [A], V);
      !decide(G, A, V).
-!act(G, A)[error(E)]
   <- .print("goal ", G, " failed: ", E);
      !forget(G).

+!decide(G, A, ["legal"])
   <- .print("goal ", G, ": ", A, " is legal");
      !run(A);
      .print("goal ", G, " done");
      !forget(G).
+!decide(G, A, ["illegal", Rule, Detail])
   <- .print("goal ", G, ": ", A, " refused by rule ", Rule, ": ", Detail);
      +refused(G, Rule);
      !forget(G).

+!run(drive(R, G, Lat, Lon)) <- drive(R, G, Lat, Lon).
+!run(return_home(R, G)) <- return_home(R, G).
+!run(image(R, G)) <- image(R, G).
+!run(spectrum(R, G)) <- spectrum(R, G).
+!run(radar(R, G)) <- radar(R, G).
+!run(sample(R, G)) <- sample(R, G).

+!forget(G)
   <- -drive_received(G, _, _)[source(percept)];
      -home_received(G)[source(percept)];
      -science_received(G, _)[source(percept)];
      -drive_point(G, _)[source(percept)];
      -science_request(G, _)[source(percept)];
      -acting(G);
      -goal_cancelled(G)[source(percept)].

+robot_unavailable(R)[source(percept)] <- .print(R, " is unavailable").
