// plans as values: .add_plan, .remove_plan, .relevant_plans, .plan_label
!start.

@g1 +!greet(N) : N > 1 <- .print("many: ", N).
@g2 +!greet(N) <- .print("one: ", N).
@g3 +!greet(hello) <- .print(hi).
+!unlabelled <- true.

+!start
    <- .relevant_plans({+!greet(_)}, Ps, Ls);
       .length(Ps, N);
       .print("relevant: ", N, " ", Ls);
       .relevant_plans({+!greet(hello)}, _, [First|_]);
       .print("first: ", First);
       .relevant_plans({+!nothing}, None);
       .print("none: ", None);
       .relevant_plans({+!unlabelled}, _, [Auto]);
       if (.atom(Auto)) { .print("an unlabelled plan gets a label") };
       X = 7;
       .add_plan({ @h1 +!hello(Who) <- .print("hello ", Who, " ", X) });
       !hello(bob);
       .add_plan({ @g0 +!greet(M) : M > 5 <- .print("lots: ", M) }, self, begin);
       !greet(9);
       !greet(2);
       .remove_plan(g0);
       !greet(9);
       .add_plan("@b1 +!bye <- .print(bye).");
       !bye;
       .plan_label(P, b1);
       .print(P);
       .relevant_plans({+!bye}, [Q]);
       .print(Q);
       .add_plan({ @t1 +!told <- .print(told) }, bob);
       .remove_plan(t1);
       !told;
       .remove_plan(t1, bob);
       .relevant_plans({+!told}, Told);
       .print("told: ", Told);
       .relevant_plans({+!greet(_)}, _, L2);
       .print("after: ", L2);
       .remove_plan([g1, g2]);
       .relevant_plans({+!greet(_)}, _, Gone);
       .print("left: ", Gone);
       if (not .plan_label(_, g1)) { .print("g1 is gone") };
       .remove_plan(g1);
       .print("removing again succeeds").
