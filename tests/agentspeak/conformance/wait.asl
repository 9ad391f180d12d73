// .wait: milliseconds, an event, a condition, timeouts
!start.
!ticker.
+!start
   <- .wait(30); .print("waited 30 ms");
      +ready; .wait({+tick(3)}); .print("saw tick 3");
      .wait(tick(5)); .print("tick 5 believed");
      .wait({+never}, 20, T); if (T >= 20) { .print("elapsed at least 20 ms") };
      !timeout; .print("after timeout").
+!ticker <- .wait(ready); for (.range(I, 1, 6)) { .wait(10); +tick(I) }.  // ticks after start waits
+!timeout <- .wait({+never}, 20).
-!timeout[error(E)] <- .print("timeout failed: ", E).
