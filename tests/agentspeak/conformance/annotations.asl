// annotations on variables (X[a], _[source(a)]) and annotation lists with a tail
// ([a|T], [|T]), with Jason's unification: the annotated side's annotations must be a
// subset of the other's; a tail takes the annotations left over; X takes the literal
// without its annotations
b(1)[source(a)]. c(3)[source(a)]. d(4)[source(b)].
task(t7)[source(boss)].
!start.
+!start
   <- .count(_[source(a)], N); .print("beliefs from a: ", N);
      .findall(X, X[source(b)], L); .print("from b: ", L);
      ?task(t7)[|Annots]; .print("annotations of task(t7): ", Annots);
      ?task(T)[source(S)|Rest]; .print(T, " from ", S, ", rest ", Rest);
      W[An] = p(1)[a]; .print("W = ", W, ", An = ", An);
      W2[An2|R2] = p(2)[a, b]; .print("W2 = ", W2, ", An2 = ", An2, ", R2 = ", R2);
      Y = p(1)[a]; Z = Y[b]; .print("Z = ", Z);
      if (q[x] = q[x, y]) { .print("q[x] unifies with q[x,y]") };
      if (not (q[x, y] = q[x])) { .print("q[x,y] does not unify with q[x]") };
      if (not (q[A1, A2] = q[x])) { .print("two annotations need two to match") };
      if (q[B1, B2] = q[x, y]) { .print("q[B1,B2] = q[x,y]: ", B1, " ", B2) };
      !g(task(t7)[source(boss)]);
      .print("end").
+!g(Name[source(Who)]) <- .print("g of ", Name, " from ", Who).
