"""The data layer reaches a token-guarded world model over HTTP with the project's token
(the real bus, the components in this process, real sockets)."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.actors.datalayer.service import DataLayerComponent
from mrss.actors.worldmodel.service import URL_FILE, WorldModelComponent
from mrss.bus import BusEndpoints, ProxyThread
from mrss.runtime.busport import ZmqBusPort
from mrss.runtime.component import ComponentContext
from mrss.runtime.datalayer_client import DataLayerClient, DataLayerError
from mrss.testing import wait_until
from tests.edge.fixture_project import PROJECT_FIXTURE

TOKEN = "datalayer-test-token-0123456789"


def guarded_project(root: Path, token: str) -> Path:
    folder = root / f"project-{token[:4]}"
    shutil.copytree(PROJECT_FIXTURE, folder, ignore=shutil.ignore_patterns("__pycache__"))
    (folder / "wm.token").write_text(token + "\n")
    toml = (folder / "project.toml").read_text()
    (folder / "project.toml").write_text(toml.replace('[worldmodel]\n',
                                                      '[worldmodel]\ntoken_file = "wm.token"\n'))
    return folder


@pytest.fixture()
def bus_and_world() -> Iterator[tuple[BusEndpoints, Path, Path, list[Any]]]:
    root = Path(tempfile.mkdtemp(prefix="mrss-dltok-"))
    run_dir = root / "run"
    run_dir.mkdir()
    endpoints = BusEndpoints.ipc(run_dir)
    project = guarded_project(root, TOKEN)
    started: list[Any] = []
    try:
        with ProxyThread(endpoints):
            world = WorldModelComponent()
            world.start(ComponentContext(name="worldmodel", incarnation=1,
                                         project_dir=project, run_dir=run_dir,
                                         bus=endpoints.to_dict()))
            started.append(world)
            yield endpoints, run_dir, root, started
    finally:
        for each in reversed(started):
            each.stop() if hasattr(each, "stop") else each.close()
        shutil.rmtree(root, ignore_errors=True)


def data_layer(endpoints: BusEndpoints, run_dir: Path, project: Path, name: str,
               started: list[Any]) -> DataLayerClient:
    url = (run_dir / URL_FILE).read_text().strip()
    component = DataLayerComponent()
    component.start(ComponentContext(name=name, incarnation=1, project_dir=project,
                                     run_dir=run_dir, bus=endpoints.to_dict(),
                                     options={"world_model": url}))
    started.append(component)
    caller = ComponentContext(name=f"caller-{name}", incarnation=1, project_dir=project,
                              run_dir=run_dir, bus=endpoints.to_dict())
    port = ZmqBusPort(endpoints, caller.publisher, f"caller-{name}")
    started.append(port)
    client = DataLayerClient(port)
    wait_until(lambda: client.request("ping", timeout=0.5).ok, timeout=15,
               message="data layer answering")
    return client


def test_the_data_layer_sends_the_projects_token(
        bus_and_world: tuple[BusEndpoints, Path, Path, list[Any]]) -> None:
    endpoints, run_dir, root, started = bus_and_world
    client = data_layer(endpoints, run_dir, guarded_project(root, "other" + TOKEN), "dl_wrong",
                        started)
    with pytest.raises(DataLayerError, match="HTTP 401"):
        client.call("ground", ["lake"], timeout=5)
    for each in (started.pop(), started.pop()):   # the wrong one leaves the bus
        each.stop() if hasattr(each, "stop") else each.close()
    client = data_layer(endpoints, run_dir, root / f"project-{TOKEN[:4]}", "dl", started)
    lake = client.call("ground", ["lake"], timeout=5)
    assert lake["kind"] == "water_source"
