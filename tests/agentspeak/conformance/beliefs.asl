// belief order, + in front, +> at the end, annotations merge, -b, -+b, .abolish
b(1). b(2). b(3).
!start.
+!start
   <- .findall(X, b(X), L0); .print("initial ", L0);
      +b(4); +>b(5); .findall(X, b(X), L1); .print("after +b(4) +>b(5) ", L1);
      +b(2); .findall(X, b(X), L2); .print("re-adding b(2) keeps order ", L2);
      +c(1)[x]; +c(1)[y]; ?c(1)[x, y]; .print("annotations merged");
      -b(3); -b(99); .findall(X, b(X), L3); .print("after -b(3) ", L3);
      -b(_); .findall(X, b(X), L4); .print("-b(_) removes one ", L4);
      -+v(1); -+v(2); .findall(V, v(V), L5); .print("-+ replaces ", L5);
      .count(b(_), N); .print("count ", N);
      .abolish(b(_)); .count(b(_), M); .print("abolish leaves ", M);
      +~p(1); ?~p(X1); .print("strong negation ", X1);
      if (not p(1)) { .print("~p(1) is not p(1)") }.
+b(X)[source(self)] : X > 3 <- .print("event +b(", X, ")").
