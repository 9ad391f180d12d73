// .at (an event later, on the agent's clock) and .eval (the truth of a formula).
// Sequenced so that no output depends on how fast the machine runs: the 20 ms event
// is scheduled by the tick's plan, after the start intention already waits for it.
b(3).
!start.

+!start <-
    .eval(R1, b(X) & X > 2); .eval(R2, b(Y) & Y > 5); .print(R1, " ", R2);
    .print(scheduled);
    .at(1, {+tick});
    .wait({+!later(_)}); .print(saw_later).
+!later(N) <- .print(later(N)).
+tick <- .print(tick); .at("now +20 ms", {+!later(1)}).
