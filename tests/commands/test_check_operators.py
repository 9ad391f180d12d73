"""`mrss check` on the project's operators (secrets/operators.json, made by `mrss users`):
what every component would refuse at the first login is found before the system runs.
Each case copies projects/template and writes a store as `mrss users` does."""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import pytest

from mrss.auth.roles import Role
from mrss.auth.store import OperatorStore, store_path
from tests.commands.test_check_mistakes import Mistake, inject, line_of, project, run_check

__all__ = ["project"]  # the fixture, shared

SAMPLE = Mistake("a commander-only command", "project.toml", "",
                 '\n[operator.commands.seal]\nlabel = "Seal the area"\n'
                 'percept = "seal(Zone)"\nrole = "commander"\n'
                 'fields = [{ name = "zone", type = "text", atom = true }]\n', "", "")
SEAL_PLAN = Mistake("its plan", "agent.asl", "", "\n+seal(Zone) <- .print(sealed(Zone)).\n", "", "")


def _store(project: Path, **users: tuple[Role, float]) -> OperatorStore:
    store = OperatorStore.new(store_path(project))
    for name, (role, expires) in users.items():
        store = store.with_user(name, role, password="long-enough-1", expires=expires)
    store.save()
    return store


def _findings(capsys: pytest.CaptureFixture[str]) -> tuple[int, list[dict[str, object]]]:
    code, report = run_check(capsys)
    return code, [f for f in report["findings"] if f.get("check") == "operators"]


def test_a_project_without_users_and_one_with_a_sound_store_have_no_finding(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _findings(capsys) == (0, [])
    _store(project, cora=(Role.COMMANDER, 0.0), olga=(Role.OBSERVER, 0.0))
    assert _findings(capsys) == (0, [])


def test_a_store_open_to_others_is_an_error_with_the_chmod(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _store(project, cora=(Role.COMMANDER, 0.0))
    os.chmod(store_path(project), 0o644)
    code, found = _findings(capsys)
    assert code == 2 and [f["severity"] for f in found] == ["error"], found
    assert f"chmod 600 {store_path(project)}" in str(found[0]["message"])


def test_a_damaged_store_is_an_error_at_its_line_and_column(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _store(project, cora=(Role.COMMANDER, 0.0))
    path = store_path(project)
    path.write_text(path.read_text().replace('"role": "commander"', '"role": commander'))
    code, found = _findings(capsys)
    assert code == 2 and len(found) == 1, found
    line = line_of(path, '"role": commander')
    col = path.read_text().splitlines()[line - 1].index("commander") + 1
    assert (found[0]["file"], found[0]["line"], found[0]["col"]) == (str(path), line, col)
    assert "damaged" in str(found[0]["message"])


def test_an_unknown_role_in_the_store_is_named_with_its_key(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _store(project, cora=(Role.COMMANDER, 0.0))
    path = store_path(project)
    path.write_text(path.read_text().replace('"role": "commander"', '"role": "comander"'))
    code, found = _findings(capsys)
    assert code == 2 and found[0]["key"] == "users.cora.role", found
    assert "'comander' is not one of observer, operator, commander" in str(found[0]["message"])


def test_expired_users_no_commander_and_a_command_nobody_may_send_are_warnings(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inject(project, SAMPLE)
    inject(project, SEAL_PLAN)
    _store(project, cora=(Role.COMMANDER, time.time() - 60), otto=(Role.OPERATOR, 0.0))
    code, found = _findings(capsys)
    assert code == 0 and {f["severity"] for f in found} == {"warning"}, found
    messages = [str(f["message"]) for f in found]
    assert any(re.match(r"user 'cora' \(commander\) expired at .*mrss users flood add cora "
                        r"--role commander --expires-days N", m) for m in messages), messages
    assert any(m.startswith("no active user is a commander") for m in messages), messages
    seal = [f for f in found if f["key"] == "operator.commands.seal.role"]
    assert len(seal) == 1 and seal[0]["line"] == line_of(project / "project.toml",
                                                          'role = "commander"'), found


def test_a_user_who_cannot_log_in_is_a_warning(
        project: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = _store(project, cora=(Role.COMMANDER, 0.0))
    store.with_user("nopass", Role.OPERATOR).save()
    code, found = _findings(capsys)
    assert code == 0 and [f["message"] for f in found] == [
        "user 'nopass' has neither a password nor a token: they cannot log in"], found
