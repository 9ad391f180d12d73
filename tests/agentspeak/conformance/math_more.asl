// Arithmetic functions no other program runs: math.log, math.pi, math.e, math.random.
!start.
+!start
   <- .print(math.log(1), " ", math.log(math.e));
      if (math.pi > 3.14159 & math.pi < 3.1416) { .print(pi_ok) };
      if (math.e > 2.71828 & math.e < 2.7183) { .print(e_ok) };
      X = math.random(10);
      if (X >= 0 & X < 10) { .print(random_below_10) };
      Y = math.random;
      if (Y >= 0 & Y < 1) { .print(random_below_1) };
      .print(math.median([3, 1, 2, 5]), " ", math.median([4, 1, 7]), " ",
             math.std_dev([2, 4, 4, 4, 5, 5, 7, 9])).
