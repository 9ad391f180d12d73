// .at (an event later, on the agent's clock) and .eval (the truth of a formula)
b(3).
!start.

+!start <-
    .at("now +20 ms", {+!later(1)});
    .at(1, {+tick});
    .print(scheduled);
    .eval(R1, b(X) & X > 2); .eval(R2, b(Y) & Y > 5); .print(R1, " ", R2);
    .wait({+!later(_)}); .print(saw_later).
+!later(N) <- .print(later(N)).
+tick <- .print(tick).
