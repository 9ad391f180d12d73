// .intention(Id, State[, Stack[, current]]) and .current_intention(I)
!start.

+!start <- !!napper; !g5(test).
+!g5(X) <- !g3.
@g3 +!g3 <-
    .current_intention(intention(Id, [im(Label[code_line(Line)], Trigger, _, Map) | _]));
    .print(Id, " ", Label, " ", Line, " ", Trigger, " ", Map);
    .intention(Id, running, Stack, current);
    .length(Stack, N); .print(depth(N));
    .nth(1, Stack, im(_, _, Body, Bindings)); .print(Body, " ", Bindings);
    for (.intention(I, S)) { .print(I, " ", S) }
    .suspend(napper);
    .findall(pair(I2, S2), .intention(I2, S2), L); .print(L);
    .resume(napper);
    +ready.
+!napper <- .wait({+ready}); .print(napper_done).
