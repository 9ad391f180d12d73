// {include("file")}: the file's beliefs, rules and plans in place of the directive
{ include("lib/greetings.asl") }
!start.
+!start <- .findall(G, greeting(G), L); .print(L); !greet(world); !bye.
