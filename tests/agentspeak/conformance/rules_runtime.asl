// Rules added and removed at run time: +{ h :- b } and -{ h :- b }
q(1). q(2). r(3).
!start.

+!start <-
    Min = 2;
    +{ p(X) :- q(X) & X >= Min };         // Min is 2 in the rule
    .findall(X, p(X), L1); .print(L1);
    +{ p(X) :- r(X) };
    .findall(X, p(X), L2); .print(L2);
    .relevant_rules(p(_), Rs); .print(Rs);
    -{ p(Y) :- q(Y) & Y >= 2 };           // the same rule up to variable names
    .findall(X, p(X), L3); .print(L3);
    -{ p(Y) :- missing(Y) };              // no such rule: nothing happens
    +{ twice(X, Y) :- Y = X * 2 };
    ?twice(21, T); .print(T);
    .print(done).
