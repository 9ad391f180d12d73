"""`[nodes]` and `node = ...` through `mrss check` (file:line:col, did-you-mean), `mrss
keys`, and `mrss supervise --node` refusing a missing, unknown or superfluous node."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest

from mrss.cli import main

PROJECT = Path(__file__).parent / "nodes_project"


def _project(tmp: Path, monkeypatch: pytest.MonkeyPatch,
             edit: tuple[tuple[str, str], ...] = (), nodes: bool = True) -> Path:
    folder = tmp / "nodesdemo"
    folder.mkdir()
    for name in ("rcl.py", "beacon.py"):
        shutil.copy(PROJECT / name, folder / name)
    text = (PROJECT / "project.toml.in").read_text()
    for key, value in (("@BASE@", "127.0.0.1"), ("@FIELD@", "127.0.0.2"), ("@PORT@", "5710"),
                       ("@PORT2@", "5710")):
        text = text.replace(key, value)
    if not nodes:
        text = re.sub(r"\[nodes\.\w+\]\naddress = .*\nport = .*\n", "", text)
    for old, new in edit:
        assert old in text, old
        text = text.replace(old, new)
    (folder / "project.toml").write_text(text)
    monkeypatch.setenv("MRSS_PROJECTS", str(tmp))
    return folder


def _findings(capsys: pytest.CaptureFixture[str]) -> list[dict[str, object]]:
    assert main(["check", "nodesdemo", "--json"]) == 2
    found: list[dict[str, object]] = json.loads(capsys.readouterr().out)["findings"]
    return [f for f in found if f["severity"] == "error"]


def test_node_mistakes_are_findings_at_their_line_and_column(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    _project(tmp_path, monkeypatch, (('node = "base"', 'node = "bsae"'),
                                     ("port = 5710\n\n[nodes.field]",
                                      "prot = 5710\n\n[nodes.field]")))
    found = _findings(capsys)
    by_key = {f["key"]: f for f in found}
    typo = by_key["components.rcl.node"]
    assert "no node 'bsae'; did you mean 'base'?" in str(typo["message"])
    assert typo["line"] == 28 and typo["col"] == 1
    assert "did you mean 'port'" in str(by_key["nodes.base.prot"]["message"])


def test_node_without_nodes_declared(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    folder = _project(tmp_path, monkeypatch, nodes=False)
    text = (folder / "project.toml").read_text()
    assert "[nodes" not in text
    found = _findings(capsys)
    assert {f["key"] for f in found} >= {"components.rcl.node", "components.beacon.node",
                                         "components.rcl.robots.ugv1.node"}
    assert all("declares no [nodes]" in str(f["message"]) for f in found)


def test_keys_and_supervise_node_choice(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    folder = _project(tmp_path, monkeypatch)
    assert main(["keys", "nodesdemo", "--node", "feild"]) == 2
    assert "no node 'feild'; did you mean 'field'?" in capsys.readouterr().err
    assert main(["keys", "nodesdemo"]) == 0
    assert (folder / "keys" / "base.secret").stat().st_mode & 0o777 == 0o600
    assert main(["keys", "nodesdemo", "--node", "base"]) == 2
    assert "--force" in capsys.readouterr().err
    (folder / "keys" / "field.secret").chmod(0o644)
    assert main(["check", "nodesdemo"]) == 2
    assert "chmod 600" in capsys.readouterr().err
    (folder / "keys" / "field.secret").chmod(0o600)
    assert main(["supervise", "nodesdemo", "--no-tui"]) == 2
    assert "runs on nodes base, field: say which one" in capsys.readouterr().err
    assert main(["supervise", "nodesdemo", "--no-tui", "--node", "fild"]) == 2
    assert "did you mean 'field'?" in capsys.readouterr().err
    (folder / "keys" / "base.secret").unlink()
    assert main(["supervise", "nodesdemo", "--no-tui", "--node", "base"]) == 2
    assert "no secret key of node 'base'" in capsys.readouterr().err
