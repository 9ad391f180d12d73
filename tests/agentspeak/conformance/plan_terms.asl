// plans as values: .add_plan, .remove_plan, .relevant_plans, .plan_label
!start.

@g1 +!greet(N) : N > 1 <- .print("many: ", N).
@g2 +!greet(N) <- .print("one: ", N).

+!start
    <- .relevant_plans({+!greet(_)}, Ps, Ls);
       .length(Ps, N);
       .print("relevant: ", N, " ", Ls);
       .relevant_plans({+!greet(_)}, _, [First|_]);
       .print("first: ", First);
       .relevant_plans({+!nothing}, None);
       .print("none: ", None);
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
       .plan_label(P, h1);
       .print("h1 has a plan");
       .relevant_plans({+!greet(_)}, _, L2);
       .print("after: ", L2);
       .remove_plan([g1, g2]);
       .relevant_plans({+!greet(_)}, Gone);
       .print("removed: ", Gone);
       if (not .plan_label(_, g1)) { .print("g1 is gone") };
       if (not .remove_plan(g1)) { .print("cannot remove twice") }.
