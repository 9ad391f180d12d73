// The tuidemo agent: a fire percept sends a free robot to patrol the area. A patrol of
// 1000 legs (400 s) outlasts every test that drives it: the tests suspend, cancel or
// kill it, and none may race its end (25 legs, 10 s, ended first on a loaded machine).
robot(ugv1).
robot(ugv2).

+fire(A) : robot(R) & not busy(R) <- +busy(R); !extinguish(R, A).
+fire(A) : true <- .print("no robot free for ", A).

+!extinguish(R, A) : true <- .print(R, " patrols ", A); patrol(R, A, 1000); -busy(R); .print(A, " done").
-!extinguish(R, A) : true <- -busy(R); .print(A, " not extinguished").
