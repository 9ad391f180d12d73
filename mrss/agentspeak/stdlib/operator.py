"""`.ask_operator`: a question to the human operator; the intention waits for the answer.

    .ask_operator(Question, Choices, Answer)
    .ask_operator(Question, Choices, Answer, Timeout, Default)

`Question` is a string, `Choices` a non-empty list of atoms or strings, `Timeout` in
milliseconds (as `.wait`'s; 0: none) and `Default`, one of the choices, the answer
taken when nobody answers in time. The question leaves for the agent's host as the
environment action `ask_operator(Question, Choices, Answer, Timeout, Default)`, and the
intention waits on it like on any action (`hostactions`): the host's completion binds
`Answer` to the chosen choice. With no host that knows the action, the intention fails
with `action_failed`; bad arguments fail it with `ia_failed` and the reason.
MRSS's reasoner is such a host (mrss.actors.reasoner.questions: journaled, shown on the
dashboard, survives a restart of the reasoner).
"""

from __future__ import annotations

from typing import Any

from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.terms import Struct, Var, deref, is_number, term_str, value

ACTION = "ask_operator"


@STDLIB.action(".ask_operator", min_args=3, max_args=5, body_only=True)
def ask_operator(ctx: IAContext, args: list[Any]) -> bool:
    it = ctx.intention
    if it is None or ctx.im is None:
        raise ctx.error("needs a running intention (it cannot be used in a plan context)")
    question = deref(args[0])
    if not isinstance(question, str) or not question.strip():
        raise ctx.error(f"the question must be a non-empty string, not {term_str(question)}")
    choices = value(args[1])
    if not isinstance(choices, tuple) or not choices:
        raise ctx.error(f"the choices must be a non-empty list, not {term_str(choices)}")
    for choice in choices:
        if not (isinstance(choice, str) or (type(choice) is Struct and not choice.args)):
            raise ctx.error(f"each choice must be an atom or a string, not {term_str(choice)}")
    if len({term_str(c) for c in choices}) != len(choices):
        raise ctx.error(f"the choices repeat one: {term_str(choices)}")
    timeout: Any = 0
    default: Any = choices[0]
    if len(args) == 4:
        raise ctx.error("a timeout needs its default answer: "
                        ".ask_operator(Question, Choices, Answer, Timeout, Default)")
    if len(args) == 5:
        timeout = deref(args[3])
        if not is_number(timeout) or timeout < 0:
            raise ctx.error(f"the timeout must be a number of milliseconds >= 0, not "
                            f"{term_str(timeout)}")
        default = value(args[4])
        if term_str(default) not in {term_str(c) for c in choices}:
            raise ctx.error(f"the default answer {term_str(default)} is not one of the "
                            f"choices {term_str(choices)}")
    answer = deref(args[2])
    if type(answer) is not Var and term_str(answer) not in {term_str(c) for c in choices}:
        raise ctx.error(f"the answer {term_str(answer)} can never be one of the choices "
                        f"{term_str(choices)}")
    lit = Struct(ACTION, (question, choices, answer, timeout, default))
    ctx.runtime.start_action(it, lit, it.line)
    return True
