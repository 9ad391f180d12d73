// .relevant_rules: the rules that could prove a literal, as rule terms
near(X, Y) :- pos(X, PX) & pos(Y, PY) & math.abs(PX - PY) < 2.
near(home, X) :- at(X).
safe(X) :- pos(X, P) & P > 0.
pos(a, 1).
!start.
+!start
    <- .relevant_rules(near(_, _), Rs);
       .length(Rs, N);
       .print(N, " rules for near/2");
       .relevant_rules(near(a, b), Ab);
       .length(Ab, M);
       .print(M, " rule for near(a, b)");
       .relevant_rules(safe(z), S);
       .print(S);
       .relevant_rules(pos(_, _), P);
       .print("facts are not rules: ", P).
