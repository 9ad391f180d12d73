// The tuidemo agent: a fire percept sends a free robot to patrol the area.
robot(ugv1).
robot(ugv2).

+fire(A) : robot(R) & not busy(R) <- +busy(R); !extinguish(R, A).
+fire(A) : true <- .print("no robot free for ", A).

+!extinguish(R, A) : true <- .print(R, " patrols ", A); patrol(R, A, 25); -busy(R); .print(A, " done").
-!extinguish(R, A) : true <- -busy(R); .print(A, " not extinguished").
