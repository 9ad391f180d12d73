"""The `mrss` command: version, verbs, not-yet-built verbs and unknown projects."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mrss import __version__
from mrss.cli import VERBS, Verb, main

DESIGN_VERBS = {"supervise", "tui", "new", "check", "test", "agent", "send", "record",
                "replay", "recording", "incident", "sim", "bench", "chaos", "keys",
                "users"}


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mrss", *args], capture_output=True,
                          text=True, timeout=60)


def test_version_prints_package_version() -> None:
    out = run_cli("--version")
    assert out.returncode == 0
    assert out.stdout.strip() == f"mrss {__version__}"


def test_help_lists_every_design_verb() -> None:
    out = run_cli("--help")
    assert out.returncode == 0
    for verb in DESIGN_VERBS:
        assert verb in out.stdout
    assert {v.name for v in VERBS} == DESIGN_VERBS


@pytest.mark.parametrize("verb", sorted(DESIGN_VERBS))
def test_each_verb_has_its_own_help(verb: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([verb, "--help"])
    assert exit_info.value.code == 0
    assert f"mrss {verb}" in capsys.readouterr().out


def test_a_verb_not_built_yet_says_so_and_exits_2(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import mrss.cli

    monkeypatch.setattr(mrss.cli, "VERBS", (*VERBS, Verb("teleport", "not built", True)))
    assert main(["teleport", "wildfire"]) == 2
    assert "not yet available" in capsys.readouterr().err


def test_unknown_project_exits_2_listing_the_known_ones(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", "no_such_project"]) == 2
    err = capsys.readouterr().err
    assert "unknown project 'no_such_project'" in err
    assert "wildfire" in err and "template" in err


def test_unknown_benchmark_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "nonesuch"]) == 2
    assert "unknown benchmark" in capsys.readouterr().err


def test_a_verb_imports_only_its_own_module(tmp_path: Path) -> None:
    # `mrss agent` used to import every verb (the check runner, the links, pymavlink ...)
    # before running: most of its time for a short agent
    program = tmp_path / "hello.asl"
    program.write_text("!hello.\n+!hello <- .print(hi).\n")
    code = ("import sys\nfrom mrss.cli import main\n"
            f"code = main(['agent', {str(program)!r}])\n"
            "heavy = sorted(m for m in ('mrss.commands.check', 'mrss.check', 'mrss.links',"
            " 'mrss.supervision', 'pymavlink', 'mrss.commands.tui') if m in sys.modules)\n"
            "print(code, heavy)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == ["hi", "0 []"]
