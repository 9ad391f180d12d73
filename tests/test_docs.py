"""The documents hold: no reference outside the repository, every example config loads."""

from __future__ import annotations

import importlib
import json
import re
import tomllib
from pathlib import Path

import pytest

from mrss.actors.reasoner.messages import action_request
from mrss.agentspeak.parser import parse_literal, parse_program
from mrss.check.robots import ROBOT_KEYS
from mrss.config.loader import load_file
from mrss.config.nodes import read_nodes
from mrss.links.factory import LINK_OPTIONS, option_value_problems

REPO = Path(__file__).resolve().parent.parent
DOCUMENTS = sorted((REPO / "docs").glob("*.md")) + [REPO / "README.md"]
# Files outside the repository, a developer's machine, a virtualenv by absolute path.
FORBIDDEN = re.compile(r"shared/|/work/|/root/|/home/\w|/Users/\w|(?<![\w.])/\S*\.venv/")
TOML_BLOCK = re.compile(r"```toml\n(.*?)```", re.S)
# What a fragment of project.toml is completed with (the components it does not define).
BASE_COMPONENTS = ("bus", "broker", "worldmodel", "datalayer", "events", "rcl", "reasoner")


def examples() -> list[tuple[str, str]]:
    return [(f"{doc.name}#{n}", m.group(1)) for doc in DOCUMENTS
            for n, m in enumerate(TOML_BLOCK.finditer(doc.read_text(encoding="utf-8")), 1)]


def completed(block: str) -> str:
    """`block` with the components it does not define (a fragment becomes a project)."""
    missing = [c for c in BASE_COMPONENTS if not re.search(rf"^\[components\.{c}\]", block, re.M)]
    prelude = "".join(f'[components.{c}]\nkind = "{c}"\n' for c in missing)
    return prelude + block


@pytest.mark.parametrize("doc", DOCUMENTS, ids=lambda p: p.name)
def test_no_document_refers_outside_the_repository(doc: Path) -> None:
    hits = [f"{doc.name}:{n}: {line.strip()}"
            for n, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1)
            if FORBIDDEN.search(line)]
    assert not hits, "\n".join(hits)


def test_the_forbidden_pattern_catches_what_it_should() -> None:
    for bad in ("see `shared/DESIGN.md`", "/work/main/.venv/bin/python -m pytest",
                "/root/.cache", "/home/alice/mrss/.venv/bin/mrss"):
        assert FORBIDDEN.search(bad), bad
    for good in (".venv/bin/python -m pytest", "installed (PATH or `/usr/sbin`)"):
        assert not FORBIDDEN.search(good), good


def test_every_document_has_its_toml_examples_found() -> None:
    names = {name.split("#")[0] for name, _ in examples()}
    assert {"config.md", "robots.md", "rcl.md", "edges.md"} <= names


@pytest.mark.parametrize(("where", "block"), examples(), ids=[w for w, _ in examples()])
def test_every_toml_example_loads_as_a_project(where: str, block: str, tmp_path: Path) -> None:
    tomllib.loads(block)  # the example as written is TOML
    path = tmp_path / "project.toml"
    path.write_text(completed(block), encoding="utf-8")
    config = load_file(path)
    assert not read_nodes(config)[1], f"{where}: {read_nodes(config)[1]}"
    for comp in config.components:
        module, _, cls = comp.module.partition(":")
        if module.startswith("mrss."):
            assert hasattr(importlib.import_module(module), cls), f"{where}: {comp.module}"
        robots = comp.options.get("robots", {})
        for robot, options in robots.items():
            kind = options.get("link")
            if kind is None:
                continue
            assert kind in LINK_OPTIONS, f"{where}: robot {robot}: link {kind!r}"
            unknown = set(options) - set(LINK_OPTIONS[kind]) - set(ROBOT_KEYS)
            assert not unknown, f"{where}: robot {robot}: unknown link options {unknown}"
            assert not option_value_problems(options), f"{where}: robot {robot}"


@pytest.mark.parametrize(("where", "block"), [e for e in examples() if "[map" in e[1]],
                         ids=[w for w, b in examples() if "[map" in b])
def test_every_map_example_reads_as_the_dashboard_reads_it(where: str, block: str) -> None:
    from mrss.config.map import read_map

    config = read_map(tomllib.loads(block)["map"], file=where)
    assert config.kinds or config.hide, where


def test_the_map_examples_are_found() -> None:
    names = {w.split("#")[0] for w, b in examples() if "[map" in b}
    assert {"config.md", "tui.md"} <= names


def test_the_world_model_json_example_is_a_valid_seed() -> None:
    from mrss.actors.worldmodel.model import WorldModel
    from mrss.actors.worldmodel.store import Position, SqliteWorldStore

    text = (REPO / "docs" / "edges.md").read_text(encoding="utf-8")
    section = text.split("## The world model", 1)[1]
    block = re.search(r"```json\n(.*?)```", section, re.S)
    assert block, "the world model section shows a seed in a ```json block"
    world = WorldModel(SqliteWorldStore())
    assert world.seed(json.loads(block.group(1))) == 3
    zone = world.get("zone_a")
    assert zone is not None and zone.geometry is not None
    assert [o.id for o, _ in world.near(Position(43.61, 1.45), 0)] == ["zone_a"]


def test_the_amadee_rules_data_example_is_what_the_rules_read() -> None:
    """docs/amadee.md, "The rules' data": a terrain grid and a time window, seeded with
    the project's world.json, forbid what the document says they forbid."""
    from mrss.api.testing import memory_world
    from mrss.runtime.loader import import_project_module

    project = REPO / "projects" / "amadee"
    legality = import_project_module(project, "legality.py")
    text = (REPO / "docs" / "amadee.md").read_text(encoding="utf-8")
    block = re.search(r"```json\n(.*?)```", text.split("### The rules' data", 1)[1], re.S)
    assert block, "the rules' data section shows them in a ```json block"
    seed = json.loads((project / "world.json").read_text(encoding="utf-8"))
    world = memory_world(seed + json.loads(block.group(1)))
    world.upsert({"id": "rover1", "kind": "robot",
                  "position": {"lat": 39.77, "lon": 44.8}, "attributes": {"speed": 0.0}})
    during, after = 1_795_615_600.0, 1_795_616_600.0    # 14:06:40Z and 14:23:20Z
    found = legality.judge("drive(rover1,g1,39.77225,44.7985)", world, during)
    assert (found.rule, "'relay_pass'" in found.detail) == ("time_window", True)
    found = legality.judge("drive(rover1,g1,39.77225,44.7985)", world, after)
    assert (found.rule, "'dune_field'" in found.detail) == ("slope_limit", True)
    assert legality.judge("image(rover1,g2)", world, during).legal


def test_the_architecture_table_is_the_layer_contract() -> None:
    """docs/architecture.md lists the import-linter layers of pyproject.toml, in order."""
    contracts = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["importlinter"]
    (layers,) = [c["layers"] for c in contracts["contracts"] if c["type"] == "layers"]
    text = (REPO / "docs" / "architecture.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| (\d+) \| (.*?) \|", text, re.M)
    assert [int(n) for n, _ in rows] == list(range(1, len(layers) + 1))
    for (_, folders), layer in zip(rows, layers, strict=True):
        named = {m.strip("/").removesuffix(".py").replace("/", ".")
                 for m in re.findall(r"`(mrss/[\w/.]+)`", folders)}
        assert named == {m.strip() for m in re.split(r"[|:]", layer)}, folders


ASL_BLOCK = re.compile(r"```agentspeak\n(.*?)```", re.S)


def test_the_role_examples_parse_and_become_role_requests() -> None:
    blocks = [m.group(1) for doc in ("agentspeak.md", "rcl.md")
              for m in ASL_BLOCK.finditer((REPO / "docs" / doc).read_text(encoding="utf-8"))]
    assert len(blocks) == 3  # two roles, one reassigned(Task, From, To) plan
    roles = []
    for block in blocks:
        parse_program(block)  # the example is AgentSpeak
        for line in block.splitlines():  # each action, its place's variables bound
            if "<- " in line and "any(" in line:
                text = line.split("<- ", 1)[1].rstrip(".").replace("Lat", "48.2")
                roles.append(action_request(parse_literal(text.replace("Lon", "16.3"))).role)
    assert {"capabilities": ["camera"]} in roles
    assert [r for r in roles if r["capabilities"] == ["uav", "camera"]] == [
        {"capabilities": ["uav", "camera"], "near": [48.2, 16.3]}] * 2
