// functions inside expressions: .count(Q) and .length(L) as values, math.* calls as the
// first operand of arithmetic, math.sum/average/max/min of lists
b(1). b(2). b(3).
pos(r1, 1, 5). pos(r2, 4, 1).
manhattan(A, B, D) :- pos(A, X1, Y1) & pos(B, X2, Y2)
                      & D = math.abs(X1 - X2) + math.abs(Y1 - Y2).
!start.
+!start : .count(b(_)) > 2
   <- X = .count(b(_)) + 1; .print("count plus one: ", X);
      .print("count of b > 1: ", .count(b(V) & V > 1));
      L = [a, b];
      .print("length times 10: ", .length(L) * 10);
      .print("length of a string: ", .length("hello"));
      .length(L, N); .print("the action still works: ", N);
      ?manhattan(r1, r2, D); .print("manhattan: ", D);
      Y = math.abs(-2) * 3 + math.max(1, 4); .print("Y: ", Y);
      .print(math.sum([1, 2, 3.5]), " ", math.average([1, 2]), " ",
             math.max([1, 7, 3]), " ", math.min([4, 2, 9]));
      if (math.abs(1 - 3) + 1 > 2) { .print("condition with a function first") };
      +b(4);
      .print("count now: ", .count(b(_))).
