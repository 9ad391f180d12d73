// .drop_all_desires removes queued goals and every intention but the current one, which
// goes on (Jason's drop_all_desires.java: the running intention is in none of its sets)
!start.
!other.
@a[atomic]
+!start <- !!w(1); .print("dropping"); .drop_all_desires; .print("goes on").
+!w(N) <- .print("never ", N).
+!other <- .print("never other").
