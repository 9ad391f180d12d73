// tail recursion: a long chain of sub-goals runs in constant stack space
!count(20000).
+!count(0) <- .print("done").
+!count(N) : N > 0 <- !count(N - 1).
