// type tests: .atom .number .string .list .literal .structure .ground .type
!start.
+!start
   <- !show(atom, [b, b(10), ~b, a[x], 10, "home", [a, b]]);
      !show(number, [10, 2.5, "10", b]);
      !show(string, ["home", b, 10]);
      !show(list, [[], [a, b, c(X)], b(10), "home"]);
      !show(literal, [b, b(10), ~b(1)[a], 10, "J", [a, b]]);
      !show(structure, [b(10), [a, b], 10, "home"]);
      !show(ground, [b(10), b(X), [a, Y], 3, "s"]);
      if (.atom(Z)) { .print("free Z is an atom") } else { .print("free Z is not an atom") };
      Z = ok;
      if (.atom(Z)) { .print("Z bound to ok is an atom") };
      .findall(T, .type(10, T), L1); .print("types of 10: ", L1);
      .findall(T, .type("s", T), L2); .print("types of \"s\": ", L2);
      .findall(T, .type(p(1), T), L3); .print("types of p(1): ", L3);
      .findall(T, .type([a], T), L4); .print("types of [a]: ", L4);
      .findall(T, .type(W, T), L5); .print("types of a free variable: ", L5);
      if (.type(p(X2), ground)) { .print("p(X2) ground") } else { .print("p(X2) not ground") };
      if (.type(p(1), literal)) { .print("p(1) literal") }.
+!show(Test, Terms)
   <- for (.member(T, Terms)) {
        if (Test == atom & .atom(T)) { .print(Test, " ", T, ": true") }
        elif (Test == number & .number(T)) { .print(Test, " ", T, ": true") }
        elif (Test == string & .string(T)) { .print(Test, " ", T, ": true") }
        elif (Test == list & .list(T)) { .print(Test, " ", T, ": true") }
        elif (Test == literal & .literal(T)) { .print(Test, " ", T, ": true") }
        elif (Test == structure & .structure(T)) { .print(Test, " ", T, ": true") }
        elif (Test == ground & .ground(T)) { .print(Test, " ", T, ": true") }
        else { .print(Test, " ", T, ": false") }
      }.
