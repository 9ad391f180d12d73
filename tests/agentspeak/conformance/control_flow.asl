// if/elif/else, while, for; bindings of an if condition stay; loops restore them
item(a, 3). item(b, 7). item(c, 12).
counter(0).
!start.
+!start
   <- for (item(N, Q)) { .print("item ", N, " ", Q) };
      for (.range(I, 1, 3)) { .print("range ", I) };
      for (.member(M, [x, y])) { .print("member ", M) };
      .print("after for, N is free: ", N);
      !classify(2); !classify(7); !classify(20);
      if (item(K, 7)) { .print("found ", K) };
      .print("K still bound: ", K);
      while (counter(C) & C < 3) { .print("counter ", C); -+counter(C + 1) };
      ?counter(F); .print("final counter ", F);
      if (false) { .print("no") }.
+!classify(X)
   <- if (X < 5) { .print(X, " small") }
      elif (X < 10) { .print(X, " medium") }
      else { .print(X, " large") }.
