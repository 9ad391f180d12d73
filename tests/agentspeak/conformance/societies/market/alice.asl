// a society: run as `mrss agent alice.asl bob.asl carol.asl`
!start.
+!start <- .my_name(Me); .all_names(All); .print(Me, " knows ", All);
    .send(bob, tell, price(apple, 3));
    .send(bob, achieve, greet(alice));
    .send(bob, askOne, price(pear, _), A); .print("bob says ", A);
    .send(bob, askOne, price(kiwi, _), K); .print("kiwi: ", K);
    .send(bob, askAll, price(_, _), L); .print("all: ", L);
    .send(bob, tellHow, { @hi +!hi <- .print("hi from a told plan") });
    .send(bob, achieve, hi);
    .broadcast(tell, done).
+thanks[source(S)] <- .print("thanked by ", S).
