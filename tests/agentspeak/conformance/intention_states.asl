// .intention in the order Jason gives: the current intention, then the others; the
// state of each, and the trigger of its only plan taken from its stack
!launch.

@[atomic]
+!launch <-
    .add_plan({ +!go(X, Y) <- .wait({+done}) }, self, begin);
    !!go(1, 3); !!go(2, 3); !!check.

+!check <-
    .wait(go_waiting(2));
    .findall(i(I, S), .intention(I, S), L1); .length(L1, N1); .print(count(N1));
    .findall(I, .intention(I, running), L2); .length(L2, N2); .print(running(N2));
    .findall(T, .intention(_, _, [im(_, {+!T[_]}, _, _)]), L3); .print(L3);
    +done.

^!go(X, Y)[state(waiting)] <- ?go_waiting(N) ; -+go_waiting(N + 1).
go_waiting(0).
