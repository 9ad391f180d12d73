// .print concatenates its arguments; strings at top level print unquoted
!start.
+!start
   <- .print("hello", " ", world);
      .print(8/2, " ", 7/2, " ", 3.0, " ", -1, " ", 2.5);
      .print(7 div 2, " ", -7 div 2, " ", 7 mod 3, " ", -7 mod 3, " ", 2**10, " ", 2**0.5 > 1.41);
      .print([1, "a", b(c)], " ", []);
      .print(p("s", t, 1)[source(self), x], " ", ~q(1));
      .print(math.abs(-3), " ", math.round(2.5), " ", math.floor(2.7), " ", math.ceil(2.1));
      .print(math.sqrt(16), " ", math.max(3, 9), " ", math.min(3, 9), " ", 1 + 2 * 3 - 4);
      .print((1 + 2) * 3, " ", -(2 + 3), " ", 10 / 4).
