// failure: -!g plans with error annotations; the caller continues after !g
!start.
!independent.
+!start
   <- !risky(1); .print("after risky(1)");
      !risky(2); .print("after risky(2)");
      !outer; .print("after outer");
      !noplan; .print("never printed").
+!risky(1) <- X = "a" + 1.
+!risky(2) <- .fail.
-!risky(N)[error(E)] <- .print("risky(", N, ") failed: ", E).
+!outer <- !inner; .print("never").
+!inner <- 1 > 2.
-!outer[error(E)] <- .print("outer handles ", E).
+!independent <- .print("independent 1"); .print("independent 2"); .print("independent 3");
   .print("independent 4"); .print("independent 5"); .print("independent 6").
