// a variable as a goal: !G and !!G post the literal G is bound to (source(self))
!start.
+!start
   <- G = greet(bob); !G;
      H = count(2); !H;
      .print("end of start");
      !!G.
+!greet(P)[source(S)] <- .print("hello ", P, " from ", S).
+!count(0) <- .print("count done").
+!count(N) <- .print("count ", N); M = count(N - 1); !M.
