// The fleetloss agent: each sweep the operator asks for goes to any UAV with a camera,
// near the place it names; the RCL picks the robot, and hands the sweep to another when
// its robot is lost (the agent hears `reassigned`).
+sweep_received(G, Lat, Lon, N)[source(percept)]
   <- !sweep(G, Lat, Lon, N).

+!sweep(G, Lat, Lon, N)
   <- sweep(any([uav, camera], at(Lat, Lon)), G, N);
      .print("sweep ", G, " done");
      !forget(G).
-!sweep(G, _, _, _)[error(E)]
   <- .print("sweep ", G, " failed: ", E);
      !forget(G).

+reassigned(sweep(_, G, _), From, To)[source(percept)]
   <- -reassigned(sweep(_, G, _), From, To)[source(percept)];
      .print("sweep ", G, " went from ", From, " to ", To).

+!forget(G)
   <- -sweep_received(G, _, _, _)[source(percept)].
