"""The agent's questions to the operator as the dashboard knows them (`.ask_operator`).

Each `OperatorQuestion` (a transition, or a repeat after `ctl.questions`) replaces what
was known of its id; `pending` are those still waiting for an answer, oldest first.
A repeat never takes a settled question back to pending (it may come late).
"""

from __future__ import annotations

from mrss.messages import OperatorQuestion, QuestionState

KEPT = 200  # settled questions remembered (the incident record keeps them all)


class QuestionsModel:
    """Questions by id, in the order they were first heard of."""

    def __init__(self) -> None:
        self.questions: dict[str, OperatorQuestion] = {}

    def apply(self, q: OperatorQuestion) -> bool:
        """Take one message; whether anything changed."""
        known = self.questions.get(q.id)
        if known is not None and known.state.terminal and not q.state.terminal:
            return False  # a late repeat of a question settled since
        if known == q:
            return False
        self.questions[q.id] = q
        settled = [k for k, v in self.questions.items() if v.state.terminal]
        for key in settled[:max(0, len(settled) - KEPT)]:
            del self.questions[key]
        return True

    def pending(self) -> list[OperatorQuestion]:
        return [q for q in self.questions.values() if q.state is QuestionState.PENDING]

    def get(self, qid: str) -> OperatorQuestion | None:
        return self.questions.get(qid)
