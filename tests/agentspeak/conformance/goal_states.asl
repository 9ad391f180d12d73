// Goal-state meta-events (Jason 3): ^!g[state(S)[reason(R)]] follows goal g through
// pending, executing, waiting/resumed, suspended, achieved, failed, dropped, finished.
!main.

+!main <- !ok(1); !bad; !lost; !waits; !!sleeper; !!victim; .print(main_done).

+!ok(N) <- act(N).

+!bad <- .fail(error(oops)).
-!bad <- .print(recovered_bad).

+!lost <- !nowhere.
-!lost[error(E)] <- .print(lost_failed_with(E)).

+!waits <- !!ping; .wait({+pong}); .print(got_pong).
+!ping <- +pong.

+!sleeper <- .suspend; .print(sleeper_back).
+!victim <- .resume(sleeper); .drop_intention(victim).

^!ok(N)[state(S)[reason(R)]] <- .print("ok(", N, "): ", S, " ", R).
^!bad[state(S)[reason(R)]] : S \== pending <- .print("bad: ", S, " ", R).
^!nowhere[state(S)[reason(R)]] <- .print("nowhere: ", S, " ", R).
^!waits[state(S)[reason(R)]] : S == waiting | S == resumed <- .print("waits: ", S, " ", R).
^!sleeper[state(S)[reason(R)]] : S == suspended | S == resumed <- .print("sleeper: ", S, " ", R).
^!victim[state(S)] : S == dropped | S == finished <- .print("victim: ", S).
