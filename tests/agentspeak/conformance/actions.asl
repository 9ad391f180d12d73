// environment actions go to the host (the console host prints and succeeds at once)
!start.
+!start <- move(1, 2); .print("moved"); say("hi"); .print("done").
