"""What if: the wildfire recording (conftest.py) replayed through the agent, robots not
involved: unchanged, it decides what was recorded; with one plan changed, the first
difference is that plan's action."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mrss.errors import DecodeError
from mrss.messages import decode
from mrss.recording.files import recorded_messages
from mrss.recording.whatif import what_if
from mrss.recording.whatif_timeline import timeline
from tests.commands.cli_bus import mrss
from tests.recording.conftest import WILDFIRE

RECORDED_PLAN = "supply_water(Role, G, Lat, Lon, L)[priority(P)];"
EDITED_PLAN = "supply_water(Role, G, Lat, Lon, L / 2)[priority(P)];"
# what the agent decides is asked of a role (the RCL's award names the UGV, not the agent)
UGV_NEAR_HS1 = "any([ugv,water],at(-35.360387,149.165678))"


def _line(path: Path):  # type: ignore[no-untyped-def]
    def envelopes():  # type: ignore[no-untyped-def]
        with path.open("rb") as handle:
            for message in recorded_messages(handle):
                try:
                    yield decode(*message.frames), message.t
                except DecodeError:
                    continue
    return timeline(envelopes())


@pytest.mark.slow
def test_the_unchanged_agent_decides_what_was_recorded(wildfire_recording: Path) -> None:
    result = what_if(WILDFIRE / "agent.asl", _line(wildfire_recording))
    assert {"cover", "supply_water", "teleop_mode"} <= {d.name for d in result.recorded}
    assert result.first_difference is None, [d.text for d in result.edited]
    assert [d.text for d in result.edited] == [d.text for d in result.recorded]


@pytest.mark.slow
def test_a_changed_plans_action_is_the_first_difference(wildfire_recording: Path,
                                                          tmp_path: Path) -> None:
    source = (WILDFIRE / "agent.asl").read_text()
    assert source.count(RECORDED_PLAN) == 1
    edited = tmp_path / "edited.asl"
    edited.write_text(source.replace(RECORDED_PLAN, EDITED_PLAN))
    result = what_if(edited, _line(wildfire_recording))
    first = result.first_difference
    assert first is not None
    was, now = result.recorded[first], result.edited[first]
    assert (was.name, was.robot, was.args[1]) == ("supply_water", UGV_NEAR_HS1, "hs1")
    assert (now.name, now.robot, now.args[1]) == ("supply_water", UGV_NEAR_HS1, "hs1")
    assert float(was.args[-1]) == 60 and float(now.args[-1]) == 30
    assert [d.text for d in result.edited[:first]] == [d.text for d in result.recorded[:first]]

    out = mrss("replay", str(wildfire_recording), "--agent", str(edited))
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert f"first difference: decision {first + 1}" in lines
    said = {line[:12]: line for line in lines if line.startswith(("  recorded: ", "  edited:   "))}
    for who, water in (("  recorded: ", 60), ("  edited:   ", 30)):
        head, _, rest = said[who].partition(" arguments ")
        assert head == f"{who}supply_water on {UGV_NEAR_HS1},", said
        args = json.loads(rest.split(" at +")[0])
        assert args[0] == "hs1" and float(args[-1]) == water, said


def test_an_edited_agent_that_does_not_parse_is_named_with_its_line(tmp_path: Path) -> None:
    from tests.recording.test_mcap_bad_input import good_recording
    path = tmp_path / "ok.mcap"
    path.write_bytes(good_recording()[0])
    bad = tmp_path / "bad.asl"
    bad.write_text("+!g <- .print(\n")
    out = mrss("replay", str(path), "--agent", str(bad))
    assert out.returncode == 2
    assert "bad.asl:" in out.stderr and "Traceback" not in out.stderr, out.stderr
    ok = tmp_path / "ok.asl"
    ok.write_text("+p(X) <- act(r1, X).\n")
    out = mrss("replay", str(path), "--agent", str(ok))
    assert out.returncode == 0, out.stderr
    assert "first difference: decision 1" in out.stdout  # it acts; nothing was recorded
    assert "edited:   act on r1, arguments [0]" in out.stdout, out.stdout
