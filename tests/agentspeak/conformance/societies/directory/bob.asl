!start.
+!start <- .df_subscribe(extinguish); .send(carol, tell, ready).
+provider(A, S)[source(df)] <- .print(provider(A, S)).
+!register_too[source(S)] <- .df_register(extinguish); .send(S, tell, done).
