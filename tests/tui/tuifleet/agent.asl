// The tuifleet agent: each fire goes to whichever ground robot the RCL finds best.
+fire(F, Lat, Lon) : true
   <- .print("fire ", F, ": any ugv");
      patrol(any([ugv], at(Lat, Lon)), F, 600).
