// the directory facilitator: alice provides services, bob subscribes, carol searches
!start.
+!start <- .df_register(extinguish); .df_register(scout, aerial); .print(registered);
    .send(carol, tell, ready).
+!stop_scouting[source(S)] <- .df_deregister(scout); .print(deregistered); .send(S, tell, done).
