// Listing 1 of the MRSS paper (shared/paper.txt), line breaks broken by the PDF
// repaired (e.g. `!\ncoverarea` -> `!coverarea`, `;\n;` -> `;`), otherwise unchanged.
/* Initial beliefs */
isuav("rl").
available("rl").
/* Percepts */
+area_goal_received(G,P)[source(percept)] : true <- !coverarea("dl", G, P).
+goal_cancelled(G)[source(percept)] : currenttask(R,G,_) &
isuav(R) <- -currenttask(R,G,_); .drop_intention(
coverarea(R,G,_)); +available(R).
+prioritychange(G,P)[source(percept)] : .intend(coverarea(
R,G,P)) <- .drop_intention(coverarea(R,G,P)); !!coverarea(R,G,P).
/* Plans */
+!coverarea(R, G, P) : isuav(R) & available(R) <- -available(R); +currenttask(R, G, P); cover(R, G); -currenttask(R,G,P); +available(R).
+!coverarea(R, G, P) : isuav(R) & not available(R) &
currenttask(R, H, Q) & P>Q <- -currenttask(R,H,Q); +currenttask(R,G,P); .drop_intention(coverarea(R,H,Q)); !!coverarea(R,H,Q); cover(R,G); -currenttask(R,G,P); +available(R).
+!coverarea(R, G, P) : isuav(R) & not available(R) <- .wait(2000); !!coverarea(R, G, P).
