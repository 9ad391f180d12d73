price(pear, 5).
+price(F, P)[source(S)] <- .print(S, " says ", F, " costs ", P).
+!greet(W)[source(S)] <- .print("hello ", W, " (asked by ", S, ")"); .send(S, tell, thanks).
+done[source(S)] <- .print(S, " is done").
+from_carol[source(S)] <- .print("from_carol by ", S).
-from_carol[source(S)] <- .print("from_carol untold by ", S).
+!wait_long <- .wait(100000); .print("never").
