// runtime errors fail only their intention; the agent keeps running
!bad_arith.
!bad_action.
!good.
+!bad_arith <- X = "a" * 2; .print("never").
+!bad_action <- go(Y); .print("never").
+!good <- .print("good 1"); .print("good 2"); .print("good 3").
