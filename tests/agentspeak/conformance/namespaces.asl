// Namespaces as prefixes of literals: ns::b is another predicate than b; default::b is b
b(1). ns1::b(2). default::c(3). ns1::~d.
!start.

+!start <-
    .findall(X, b(X), L1); .findall(X, ns1::b(X), L2); .print(L1, " ", L2);
    ?c(C); .print(C);
    +ns2::e(1);
    !ns1::go(5);
    if (ns1::~d) { .print(negated_in_ns1) }
    .findall(N, .namespace(N), Ns); .print(Ns);
    .findall(B, ns1::b(B)[source(self)], L3); .print(L3);
    if (not .namespace(nowhere)) { .print(no_namespace_nowhere) }
    .namespace_set_prop(family, uri, "http://example.org"); .namespace_set_prop(family, size, 4);
    .namespace_get_prop(family, uri, U); .namespace_get_prop(family, kk, KK, k1);
    .findall(pair(K, V), .namespace_get_prop(family, K, V), Props); .print(U, " ", KK, " ", Props);
    .print(done).
+!ns1::go(N) <- .print(go(N)).
+ns2::e(X) <- .print(ns2_e(X)).
