// .suspend / .resume / .suspended: a consumer that suspends itself while its queue is
// empty and a producer that resumes it; suspending an intention that waits in a
// .wait, and a goal that is still an event.
queue([]).
!consume.
!produce.

+!consume : queue([]) <- .print(consumer_sleeps); .suspend; .print(consumer_wakes); !consume.
+!consume : queue([H|T]) & H \== stop <- -+queue(T); .print(consumed(H)); !consume.
+!consume : queue([stop|_]) <- .print(consumer_stops).
^!consume[state(suspended)] <- +asleep.      // tells the producer (goal-state event)

+!produce <-
    .wait(asleep); -asleep;
    if (.suspended(consume, R)) { .print(consume_suspended_because(R)) }
    if (.intend(consume)) { .print(still_intended) }
    .findall(S, .intention(_, S), States); .print(States);
    for (.member(X, [a, b])) { ?queue(Q); .concat(Q, [X], Q2); -+queue(Q2) }
    .print(produced);
    .resume(consume);
    .resume(consume);                        // not suspended any more: nothing happens
    .wait(asleep); -asleep;
    -+queue([stop]); .resume(consume);
    !walker_test; !event_test.

+!walker_test <-
    !!walker; .wait(walker_waits);
    .suspend(walker);
    if (.suspended(walker, R)) { .print(walker_suspended_because(R)) }
    +go;                                     // its .wait ends while it is suspended
    .print(go_given);
    .findall(S, .intention(_, S), States); .print(States);
    .resume(walker);
    .wait(walked).
+!walker <- .wait({+go}); +walked; .print(walker_done).
^!walker[state(waiting)] <- +walker_waits.

+!event_test <- !hold_later; .wait(later_ran); .print(event_test_done).
@hold[atomic]                                // +!later stays an event while this runs
+!hold_later <-
    !!later; .suspend(later);
    if (.desire(later)) { .print(later_is_a_desire) }
    if (not .intend(later)) { .print(later_not_intended) }
    if (.suspended(later, R)) { .print(later_suspended_because(R)) }
    .resume(later).
+!later <- +later_ran; .print(later_runs).
