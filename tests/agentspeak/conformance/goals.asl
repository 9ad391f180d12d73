// sub-goals return bindings; !! starts a new intention; intentions interleave one step each
!start.
+!start
   <- !double(21, X); .print("double ", X);
      !!other; .print("start 1"); .print("start 2"); .print("start 3").
+!double(N, R) <- R = N * 2.
+!other <- .print("other 1"); .print("other 2").
