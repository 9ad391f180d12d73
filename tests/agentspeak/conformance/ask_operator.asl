// .ask_operator under `mrss agent`'s console host: the question goes out as an action
// (with its default timeout 0 and default answer, the first choice) and the console,
// which has no operator, succeeds it without an answer; a reasoner's host asks the
// dashboard and binds the answer (docs/mission.md)
!start.

+!start <- .ask_operator("Send the UGV into zone z1?", [go, hold], A); .print(A).
-!start[error(E)] <- .print(failed(E)).
