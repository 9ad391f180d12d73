"""The world model served beyond loopback, through real processes: only with a token, and
the project's own clients (the wildfire adapter via `mrss.api`) send it by themselves."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.config.kinds import KINDS, ComponentKind
from mrss.runtime.component import ComponentContext
from mrss.testing import wait_until
from mrss.world.access import WorldModelClient, WorldModelRejected
from tests.edge.supervised_edge import SupervisedEdge

TOKEN = "wildfire-ops-token-9f8e7d6c5b4a"
CENTER = [-35.3625, 149.1650]


@pytest.fixture()
def exposed() -> Iterator[SupervisedEdge]:
    root = Path(tempfile.mkdtemp(prefix="mrss-wmtok-"))
    run = SupervisedEdge(root, worldmodel_extra='http_host = "0.0.0.0"\n'
                                                'token_file = "secrets/worldmodel.token"\n',
                         files={"secrets/worldmodel.token": TOKEN + "\n"}, token=TOKEN)
    try:
        run.wait_ready()
        yield run
    finally:
        run.close()
        shutil.rmtree(root, ignore_errors=True)


@pytest.mark.slow
def test_the_adapter_stores_goals_in_a_token_guarded_world_model(
        exposed: SupervisedEdge) -> None:
    url = (exposed.run_dir / "worldmodel.url").read_text().strip()
    assert url.startswith("http://0.0.0.0:")
    exposed.publish("mrss/ui/area", {"goal": "a7", "priority": 3, "center": CENTER,
                                     "radius": 100, "id": "op-7"})
    wait_until(lambda: exposed.percepts("area_goal_received(a7,3)"), 60,
               message=f"the goal percept\n{exposed.log_text()[-3000:]}")
    stored = exposed.world.get("a7")                       # a client with the token
    assert stored is not None and stored["attributes"]["priority"] == 3
    with pytest.raises(WorldModelRejected, match="HTTP 401"):
        WorldModelClient(run_dir=exposed.run_dir, timeout=2.0).get("a7")
    assert exposed.reports("accepted", event_id="op-7")


def test_the_world_model_refuses_to_start_beyond_loopback_without_a_token(
        tmp_path: Path) -> None:
    project = tmp_path / "project"
    project.mkdir()
    (project / "project.toml").write_text('[worldmodel]\nhttp_host = "0.0.0.0"\n')
    ctx = ComponentContext(name="worldmodel", incarnation=1, project_dir=project,
                           run_dir=tmp_path)
    out = subprocess.run(
        [sys.executable, "-m", "mrss.runtime.main",
         KINDS[ComponentKind.WORLDMODEL].target, "--name", "worldmodel",
         "--context", ctx.to_json()], capture_output=True, text=True, timeout=60)
    assert out.returncode != 0
    assert "key 'worldmodel.token_file'" in out.stderr
    assert "http_host '0.0.0.0' is not a loopback address" in out.stderr
    assert "Traceback" not in out.stderr
    assert not (tmp_path / "worldmodel.url").exists()      # nothing was served


def test_mrss_check_names_the_token_key(tmp_path: Path) -> None:
    folder = tmp_path / "projects" / "open"
    folder.mkdir(parents=True)
    (folder / "project.toml").write_text(
        '[components.worldmodel]\nkind = "worldmodel"\n'
        '[worldmodel]\nhttp_host = "10.0.0.7"\n')
    out = subprocess.run([sys.executable, "-m", "mrss", "check", "open", "--json"],
                         capture_output=True, text=True, timeout=120,
                         env={"MRSS_PROJECTS": str(folder.parent), "PATH": "/usr/bin:/bin"})
    assert out.returncode == 2, out.stderr
    errors = [f for f in json.loads(out.stdout)["findings"] if f["severity"] == "error"]
    assert [e["key"] for e in errors] == ["worldmodel.token_file"]
    assert errors[0]["line"] == 4 and "10.0.0.7" in errors[0]["message"]
