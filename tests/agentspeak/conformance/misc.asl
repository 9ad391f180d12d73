// .my_name .time .date .random .nano_time .println .fail with annotations
!start.
+!start
   <- .my_name(Me); .print("I am ", Me);
      .time(H, M, S); if (H >= 0 & H < 24 & M < 60 & S < 61) { .print("time ok") };
      .date(Y, Mo, D); if (Y > 2000 & Mo >= 1 & D >= 1) { .print("date ok") };
      .random(R); if (R >= 0 & R < 1) { .print("random ok") };
      .nano_time(T1); .nano_time(T2); if (T2 >= T1) { .println("nano_time ok") };
      !custom; .list_files("/no/such/folder", Files); .print("files ", Files);
      .print("end").
+!custom <- .fail(reason(busy)).
-!custom[reason(W)] <- .print("custom failure: ", W).
