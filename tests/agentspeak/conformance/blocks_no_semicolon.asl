// Jason 3: the `;` after the `}` of if/elif/else, for and while may be left out
n(2).
!start.
+!start
   <- if (n(X) & X > 1) { .print("big ", X) } .print("after if");
      if (n(3)) { .print("no") } elif (n(2)) { .print("elif") } else { .print("no") }
      for (.member(M, [a, b])) { .print("for ", M) }
      while (n(C) & C < 4) { -+n(C + 1) }
      if (false) { .print("no") };
      ?n(F);
      .print("n is ", F);
      !nested.
+!nested
   <- for (.range(I, 1, 2)) { if (I == 1) { .print("one") } else { .print("two") } .print("end ", I) }
      .print("done").
