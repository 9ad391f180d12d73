// .log(Level, Args...) prints like .print at severe, warning and info (Jason's default
// console shows INFO and above); fine, finer and finest are not shown
!start.
+!start
   <- .log(info, "created counter ", c1, " with ", [1, "two"]);
      .log(warning, "low battery: ", 15, "%");
      .log(severe, "lost link");
      .log(fine, "not shown");
      .log(finest, "not shown either");
      .print("end").
