// included by include.asl (a path relative to the including file)
{ include("more.asl") }
greeting(hello).
+!greet(W) : greeting(G) <- .print(G, " ", W).
