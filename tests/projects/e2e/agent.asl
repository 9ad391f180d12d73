/* The end-to-end test agent: Listing 1 of the paper, plus one plan family per scenario.
   Every goal arrives as a percept; every environment action goes to the RCL. */

isuav(uav1).
available(uav1).

/* Listing 1: an area goal is covered by the UAV, then reported. */
+area_goal_received(G, P)[source(percept)] : isuav(R) & available(R)
    <- !coverarea(R, G, P).
+!coverarea(R, G, P) : available(R)
    <- -available(R); +currenttask(R, G, P);
       cover(R, G, 6)[priority(P)];
       -currenttask(R, G, P); +available(R); +covered(G);
       report(R, G).
-!coverarea(R, G, P)[error_msg(M)]
    <- -currenttask(R, G, P); +available(R); +cover_failed(G, M).

/* Long patrols, one action each (kill tests, teleop). */
+patrol_goal(R, G, N)[source(percept)] <- !patrol(R, G, N).
+!patrol(R, G, N) <- patrol(R, G, N); +patrolled(G).
-!patrol(R, G, N)[error_msg(M)] <- +patrol_failed(G, M).

/* Teleop: the operator takes a robot over and gives it back. */
+teleop(R, on)[source(percept)] <- rcl_goal_management(suspend, robot(R)).
+teleop(R, off)[source(percept)] <- rcl_goal_management(resume, robot(R)).

/* A probe whose skill raises: the -! plan sees the exception's message. */
+probe_goal(R, G)[source(percept)] <- !probe(R, G).
+!probe(R, G) <- probe(R, G); +probed(G).
-!probe(R, G)[error_msg(M)] <- +probe_failed(G, M).

/* Surveys share the airspace: the higher priority pre-empts the lower one. */
+survey_goal(R, G, P, N)[source(percept)] <- !survey(R, G, P, N).
+!survey(R, G, P, N) <- survey(R, G, N)[priority(P)]; +surveyed(G).
-!survey(R, G, P, N)[error_msg(M)] <- +survey_failed(G, M).

/* Gated work: the action ends when the test opens its gate (a file in the run dir). */
+gated_goal(R, G)[source(percept)] <- !gated(R, G).
+!gated(R, G) <- gated(R, G); +gated_done(G); -gated_goal(R, G)[source(percept)].
-!gated(R, G)[error(E)] <- +gated_failed(G, E).
