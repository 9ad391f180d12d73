// .setof, .drop_event, .drop_all_events
n(3). n(1). n(2). n(3). n(1).
!start.

@s[atomic] +!start  // atomic: the !! events wait in the set of events meanwhile
    <- .setof(X, n(X), S);
       .print("set: ", S);
       .findall(X, n(X), F);
       .print("all: ", F);
       .setof(p(X), n(X) & X > 1, P);
       .print("pairs: ", P);
       .setof(X, n(X) & X > 5, E);
       .print("empty: ", E);
       !!later(1);
       !!later(2);
       !!other;
       .drop_event(later(1));
       .print("dropped later(1)");
       !!more;
       .drop_all_events;
       .print("dropped all");
       !!last.

+!later(N) <- .print("later ", N).
+!other <- .print(other).
+!more <- .print(more).
+!last <- .print(last).
