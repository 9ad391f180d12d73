// rules with backtracking, recursion, not, |
parent(tom, bob). parent(bob, ann). parent(bob, pat). parent(pat, jim).
ancestor(X, Y) :- parent(X, Y).
ancestor(X, Y) :- parent(X, Z) & ancestor(Z, Y).
leaf(X) :- parent(_, X) & not parent(X, _).
big(X) :- X > 10 | X < -10.
!start.
+!start
   <- .findall(Y, ancestor(tom, Y), L); .print("tom's descendants ", L);
      .findall(X, leaf(X), Leaves); .print("leaves ", Leaves);
      if (big(20) & big(-20) & not big(5)) { .print("big ok") };
      ?ancestor(A, jim); .print("first ancestor of jim ", A);
      .findall(pair(P, C), parent(P, C) & C \== ann, Pairs); .print(Pairs).
