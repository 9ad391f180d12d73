// .intend .drop_intention .succeed_goal .fail_goal .suspend .resume .desire .drop_desire
!start.
+!start
   <- !!worker(1); !!worker(2); !!worker(3);
      .wait(ready(1) & ready(2) & ready(3));
      .findall(N, .intend(worker(N)), L); .print("intended ", L);
      .drop_intention(worker(1));
      .findall(N, .intend(worker(N)), L2); .print("after drop ", L2);
      .succeed_goal(hold(2));
      .wait(done(2));
      .fail_goal(hold(3));
      .wait(done(3));
      !!sleepy; .suspend(sleepy);
      .print("sleepy is suspended"); .print("still suspended");
      .resume(sleepy); .wait(sleepy_done);
      !check_desire;
      !!idle(1); !!idle(2); .wait(ready(idle(1)) & ready(idle(2)));
      .drop_all_intentions;                  // all but this one, as Jason
      .print("goes on").
+!worker(N) <- !hold(N); .print("worker ", N, " continues"); +done(N).
+!hold(N) <- +ready(N); .wait({+never(N)}); .print("never").
-!hold(N) <- .print("hold(", N, ") failed, handled").
+!sleepy <- .print("sleepy resumed"); +sleepy_done.
@chk[atomic]
+!check_desire
   <- !!later;
      if (.desire(later) & not .intend(later)) { .print("later is desired, not intended") };
      .drop_desire(later);
      if (not .desire(later)) { .print("later dropped") }.
+!later <- .print("never printed").
+!idle(N) <- +ready(idle(N)); .wait({+never}).
