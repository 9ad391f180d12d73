// included by lib/greetings.asl: relative to lib/, not to the agent's file
greeting(hi).
+!bye <- .print(bye).
