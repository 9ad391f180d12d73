// facts and rules of one predicate are tried in program order (one list, as in Jason);
// +b puts a fact before all of them, +>b after all of them
src(a, fact1).
src(X, rule1) :- X = a | X = b.
src(a, fact2).
src(X, rule2) :- X = a.
!start.
+!start
   <- .findall(W, src(a, W), L1); .print("for a: ", L1);
      .findall(W, src(b, W), L2); .print("for b: ", L2);
      ?src(a, First); .print("first for a: ", First);
      +src(a, front); +>src(a, back);
      .findall(W, src(a, W), L3); .print("after +b and +>b: ", L3);
      -src(a, fact1);
      .findall(W, src(a, W), L4); .print("without fact1: ", L4).
