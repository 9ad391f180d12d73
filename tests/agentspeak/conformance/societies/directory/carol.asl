!start.
+!start <- .wait(ready[source(alice)] & ready[source(bob)]);
    .df_search(extinguish, L1); .df_search(scout, aerial, L2); .df_search(scout, ground, L3);
    .print(L1, " ", L2, " ", L3);
    .send(bob, achieve, register_too); .send(alice, achieve, stop_scouting);
    .wait(done[source(alice)] & done[source(bob)]);
    .df_search(extinguish, L4); .df_search(scout, L5); .print(L4, " ", L5).
