// list and string internal actions
!start.
+!start
   <- .length([a, b, c], L1); .length("hello", L2); .print("length ", L1, " ", L2);
      .findall(X, .member(X, [1, 2, 3]), M); .print("member ", M);
      .nth(1, [a, b, c], E); .print("nth ", E);
      .sort([c, 3, "x", b(1), a, 1.5, [z]], S); .print("sort ", S);
      .reverse([1, 2, 3], R); .reverse("abc", RS); .print("reverse ", R, " ", RS);
      .delete(b, [a, b, c, b], D1); .delete(0, [a, b, c], D2); .print("delete ", D1, " ", D2);
      .max([3, 9, 2], Mx); .min([3, 9, 2], Mn); .print("max ", Mx, " min ", Mn);
      .concat([1, 2], [3], C1); .concat("ab", "cd", 1, C2); .print("concat ", C1, " ", C2);
      if (.substring("ll", "hello")) { .print("substring found") };
      .substring("l", "hello", P); .print("first position ", P);
      .findall(P2, .substring("l", "hello", P2), Ps); .print("positions ", Ps);
      .findall(I, .range(I, 10, 1, -3), Rg); .print("range down ", Rg);
      .count(.member(_, [a, b]), Cn); .print("count ", Cn).
