// the third agent: untell, unachieve, and errors that fail only the intention
!begin.
+!begin <- .send([alice, bob], tell, from_carol);
    .send(bob, untell, from_carol);
    .send(bob, achieve, wait_long); .send(bob, unachieve, wait_long);
    .send(dave, tell, x).
-!begin <- .print("cannot send to dave").
