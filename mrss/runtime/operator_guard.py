"""The check an operator command passes at the component that executes it.

Every component that executes operator commands (the RCL: teleop, decommission, debug
action controls; the reasoner: percepts from the percept line; the root supervisor:
faults and stop; the events manager: the project's operator commands over MQTT; the
world model: HTTP writes) asks its `OperatorGuard` before it acts:

- a project without users (no `secrets/operators.json`, `mrss.auth.store`) accepts
  every command, as before roles existed: one local operator;
- a message from a supervised component (a bus envelope of incarnation > 0, proven by
  the run's incarnation key: mrss/bus/incarnations.py) is the system's own: accepted;
- anything else must carry a credential (`mrss.auth.sessions`) of a known, unexpired
  user whose role allows the command's kind (`mrss.auth.roles.PERMISSIONS`, and a
  declared command's own `role`). Otherwise it is refused: not executed, counted
  (the component's `Rejections` on the bus, which the dashboard shows) and logged once
  per (who, reason) and interval. An operators file that is too open or damaged
  refuses everything, saying why.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mrss.auth.roles import CommandKind, Role, refusal
from mrss.auth.sessions import claimed_user, verify
from mrss.auth.store import AuthError, OperatorStore, store_path
from mrss.edge.rejections import RejectionLog
from mrss.errors import ConfigError
from mrss.messages import Envelope, Message

LOCAL = "local operator"  # the author of a command when no users are configured


@dataclass(frozen=True)
class Verdict:
    """What the guard decided: `ok`, `who` sent it ("alice (operator)", or LOCAL, or the
    component), and why it was refused."""

    ok: bool
    who: str
    reason: str = ""


class OperatorGuard:
    """Checks operator commands against the project's identity store."""

    def __init__(self, project_dir: Path | None, log: logging.Logger) -> None:
        self.path = store_path(project_dir) if project_dir is not None else None
        self.refusals = RejectionLog(log, "operator command")

    @property
    def active(self) -> bool:
        """Whether the project has users (then credentials are checked)."""
        return self.path is not None and self.path.exists()

    def check(self, credential: str, kind: CommandKind, what: str, *,
              least: Role | None = None, sender: str = "") -> Verdict:
        """Whether `credential` may send `what` (of `kind`; `least`: its own least role)."""
        if not self.active:
            return Verdict(True, LOCAL)
        assert self.path is not None
        who = claimed_user(credential) or sender or "?"
        try:
            identity = verify(OperatorStore.load(self.path), credential)
        except (AuthError, ConfigError, OSError) as exc:
            return self._refuse(who, f"{what}: {exc}")
        why = refusal(identity.role, kind, least)
        if why:
            return self._refuse(str(identity), f"{what}: {why}")
        return Verdict(True, str(identity))

    def check_envelope(self, env: Envelope, kind: CommandKind, what: str, *,
                       least: Role | None = None) -> Verdict:
        """`check` for a bus message: a supervised component's own is accepted."""
        if env.inc > 0:
            return Verdict(True, env.src)
        return self.check(env.op, kind, what, least=least, sender=env.src)

    def _refuse(self, who: str, reason: str) -> Verdict:
        self.refusals.reject(who, reason)
        return Verdict(False, who, reason)


def percept_guard(guard: OperatorGuard, handler: Callable[[Envelope], None]
                  ) -> Callable[[Envelope], None]:
    """`handler`, behind the check of an operator's percepts (`CommandKind.PERCEPT`):
    a percept from anyone but a supervised component needs an operator's credential."""
    from mrss.messages import Percept

    def checked(env: Envelope) -> None:
        body = env.body
        if isinstance(body, Percept) and env.inc <= 0 and guard.active:
            verdict = guard.check_envelope(env, CommandKind.PERCEPT,
                                           f"percept {body.op} {body.literal}"[:120])
            if not verdict.ok:
                return
        handler(env)
    return checked


def answer_guard(guard: OperatorGuard, handler: Callable[[Envelope], None],
                 reply: Callable[[Message], object]) -> Callable[[Envelope], None]:
    """`handler`, behind the check of answers to the agent's questions
    (`CommandKind.ANSWER`): with users configured, an answer needs a credential whose
    role may answer; a refused one is told so (`AnswerReply` REFUSED) and changes
    nothing, a taken one is recorded as given by the identity the credential proves
    (never by the name the answer claims)."""
    from mrss.messages import AnswerReply, AnswerVerdict, QuestionAnswer

    def checked(env: Envelope) -> None:
        body = env.body
        if isinstance(body, QuestionAnswer) and env.inc <= 0 and guard.active:
            verdict = guard.check_envelope(env, CommandKind.ANSWER,
                                           f"answer {body.answer!r} to {body.id}"[:120])
            if not verdict.ok:
                reply(AnswerReply(body.request, body.id, AnswerVerdict.REFUSED,
                                  f"answer refused: {verdict.reason}: nothing changed"))
                return
            env = dataclasses.replace(env, body=dataclasses.replace(body, by=verdict.who))
        handler(env)
    return checked
