// The rest of Jason's standard library: sets and sublists, strings, annotations,
// beliefs and plans listed, .include at run time, random seeds.
b(1). b(2)[x]. r(X) :- b(X).
!start.

@p1 +!start <-
    if (.empty([])) { .print(empty_list) }
    if (not .empty([a])) { .print(not_empty) }
    .findall(P, .prefix(P, [a, b, c]), Ps); .print(prefixes(Ps));
    .findall(S, .suffix(S, [a, b, c]), Ss); .print(suffixes(Ss));
    .findall(S, .sublist(S, [a, b, c]), Subs); .print(sublists(Subs));
    .union([c, a, b], [d, a], U); .intersection([c, a, b, a], [b, c, e], I);
    .difference([c, a, b], [b], D); .print(U, " ", I, " ", D);
    .shuffle([1, 2, 3, 4], Sh); .sort(Sh, Sorted); .length(Sh, Len); .print(Sorted, " ", Len);
    .term2string(p(a, "s", [1]), T); .print(T);
    .term2string(Back, "q(1, Y)"); Back = q(N, _); .print(N);
    .lower_case("MiXed", Lo); .upper_case("MiXed", Up); .print(Lo, " ", Up);
    .replace("a-b-c", "-", "+", Rep); .print(Rep);
    .printf("%s has %d items costing %.2f%n", basket, 3, 2.5);
    Who = world; .puts("hello #{Who}, #{Nobody}");
    .add_annot([a, b(1)], hot, Annotated); .print(Annotated);
    .add_nested_source(c[source(bob)], alice, Nested); .print(Nested);
    .findall(B, .belief(b(B)), Bs); .findall(R, r(R), Rs); .print(Bs, " ", Rs);
    .list_rules;
    .list_plans({+!late_goal});
    .include("lib/late.asl");
    ?late_rule(LR); .print(late_rule(LR));
    .list_plans({+!late_goal});
    .relevant_plan({+!start}, Plan, Label); .print(Label);
    .version(V); .print(V);
    .perceive;
    .set_random_seed(7); .random(R1); .set_random_seed(7); .random(R2);
    if (R1 == R2) { .print(same_random) }
    .print(done).
