// a test goal on a compound formula: ?(f1 & f2), ?(f1 | f2), ?(not f)
position(r1, 3, 0). position(r2, 6, 1). position(r3, 8, 2).
!start.
+!start
   <- ?(position(R, X, _) & X > 4); .print("first beyond 4: ", R, " at ", X);
      ?(position(r9, _, _) | position(Q, 8, _)); .print("either: ", Q);
      ?(not position(r4, _, _)); .print("no r4");
      !probe.
+!probe <- ?(position(_, X, _) & X > 100); .print("not reached").
-!probe[error(E)] <- .print("probe failed: ", E).
