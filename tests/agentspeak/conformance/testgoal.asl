// ?b queries beliefs, then +?b plans; otherwise the goal fails
known(1).
!start.
+!start
   <- ?known(X); .print("known ", X);
      ?computed(Y); .print("computed ", Y);
      ?missing(Z); .print("never").
+?computed(V) <- V = 42.
-!start[error(E)] <- .print("start failed: ", E).
