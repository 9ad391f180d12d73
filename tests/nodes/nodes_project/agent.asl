// The nodes project's agent (chaos.toml.in): the operator asks for a patrol of ugv1,
// the robot behind node field. A patrol that failed because field was cut off
// (node_down) or for another passing cause is tried again a second later.
retryable(node_down).
retryable(link_down).
retryable(transient).
max_tries(30).
tries(G, N) :- tried(G, N).
tries(G, 0) :- not tried(G, _).

+patrol_received(G, R)[source(percept)]
   <- !patrol(R, G).

+!patrol(R, G)
   <- patrol(R, G, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20]);
      .print("patrol ", G, " done by ", R);
      !forget(G).
-!patrol(R, G)[error(E)] : retryable(E) & tries(G, N) & max_tries(M) & N < M
   <- .print("patrol ", G, " failed (", E, "): try ", N + 1, " of ", M);
      -tried(G, _); +tried(G, N + 1);
      .wait(1000);
      !patrol(R, G).
-!patrol(R, G)[error(E)]
   <- .print("patrol ", G, " failed: ", E);
      !forget(G).

+!forget(G)
   <- -patrol_received(G, _)[source(percept)];
      -tried(G, _).
