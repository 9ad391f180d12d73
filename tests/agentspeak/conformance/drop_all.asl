// .drop_all_desires removes queued goals and every intention (the current one too)
!start.
!other.
@a[atomic]
+!start <- !!w(1); .print("dropping"); .drop_all_desires; .print("never").
+!w(N) <- .print("never ", N).
+!other <- .print("never other").
