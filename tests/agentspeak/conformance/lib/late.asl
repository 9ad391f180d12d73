// included at run time by stdlib_more.asl
late_fact(1).
late_rule(X) :- late_fact(X).
+!late_goal <- .print(late_plan_runs).
!late_goal.
