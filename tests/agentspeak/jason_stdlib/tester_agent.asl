// In place of the tester_agent.asl of Jason's stdlib tests (which reports to a
// test_manager agent it creates): tests/agentspeak/jason_stdlib_check.py appends to
// each test file a driver that runs its [test] plans in turn; each assertion prints
// pass, or FAIL with its values. The same file runs on Jason and on MRSS.
@[atomic] +!assert_equals(X,Y) : .list(X) & .list(Y) <-
    if (.findall(E, .member(E,X) & not .member(E,Y), []) &
        .findall(E2, .member(E2,Y) & not .member(E2,X), [])) { .print("pass") }
    else { .print("FAIL assert_equals(", X, ",", Y, ")") }.
@[atomic] +!assert_equals(X,Y) <- if (X == Y) { .print("pass") } else { .print("FAIL assert_equals(", X, ",", Y, ")") }.
@[atomic] +!assert_equals(X,Y,T) <- if (Y >= X-T & Y <= X+T) { .print("pass") } else { .print("FAIL assert_equals(", X, ",", Y, ",", T, ")") }.
@[atomic] +!assert_not_equals(X,Y) <- if (X \== Y) { .print("pass") } else { .print("FAIL assert_not_equals(", X, ",", Y, ")") }.
@[atomic] +!assert_true(X) <- if (X) { .print("pass") } else { .print("FAIL assert_true(", X, ")") }.
@[atomic] +!assert_false(X) <- if (X) { .print("FAIL assert_false(", X, ")") } else { .print("pass") }.
@[atomic] +!assert_contains(X,Y) <- if (.member(Y,X)) { .print("pass") } else { .print("FAIL assert_contains(", X, ",", Y, ")") }.
@[atomic] +!assert_not_contains(X,Y) <- if (.member(Y,X)) { .print("FAIL assert_not_contains(", X, ",", Y, ")") } else { .print("pass") }.
@[atomic] +!assert_greater_than(X,Y) <- if (X > Y) { .print("pass") } else { .print("FAIL assert_greater_than(", X, ",", Y, ")") }.
@[atomic] +!assert_greater_than_or_equals(X,Y) <- if (X >= Y) { .print("pass") } else { .print("FAIL assert_greater_than_or_equals(", X, ",", Y, ")") }.
@[atomic] +!assert_less_than(X,Y) <- if (X < Y) { .print("pass") } else { .print("FAIL assert_less_than(", X, ",", Y, ")") }.
@[atomic] +!force_pass <- .print("pass").
@[atomic] +!force_failure(M) <- .print("FAIL force_failure(", M, ")").
@[atomic] +!assert_greater_than_equals(X,Y) <- if (X >= Y) { .print("pass") } else { .print("FAIL assert_greater_than_equals(", X, ",", Y, ")") }.
@[atomic] +!assert_between(X,Y0,Y1) <- if (X >= Y0 & X <= Y1) { .print("pass") } else { .print("FAIL assert_between(", X, ",", Y0, ",", Y1, ")") }.
