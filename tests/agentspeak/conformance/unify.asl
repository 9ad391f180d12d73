// unification, equality, strings vs atoms, numbers, lists and annotations
!start.
+!start
   <- X = f(Y, b); Y = a; .print(X);
      [H | T] = [1, 2, 3]; .print(H, " ", T);
      [A, B | _] = [x, y, z]; .print(A, B);
      if (3 == 3.0) { .print("3 == 3.0") };
      if (abc \== "abc") { .print("atom is not string") };
      if (not (abc = "abc")) { .print("atom does not unify with string") };
      if (p(1)[a] = p(1)[a, b]) { .print("annotations: subset unifies") };
      if (not (p(1)[a, b] = p(1)[a])) { .print("annotations: superset does not") };
      if (1 < a & a < "a" & "a" < [] & [] < f(x)) { .print("order: number < atom?") }
      else { .print("order: numbers < strings < lists < literals") };
      if ("abc" < "abd") { .print("strings compare lexically") };
      Z = 5; Z = 5.0; .print("bound ", Z).
