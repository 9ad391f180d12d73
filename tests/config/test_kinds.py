"""Components are named by kind in project.toml; former module paths start, with a warning."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.check.runner import check_project
from mrss.config.kinds import FORMER_TARGETS, KINDS, ComponentKind, kind_of_target
from mrss.config.loader import load_file
from mrss.errors import ConfigError
from mrss.runtime.main import load_class
from mrss.supervision.spec import ChildKind


def project(tmp_path: Path, components: str) -> Path:
    path = tmp_path / "project.toml"
    path.write_text('[project]\nname = "p"\n' + components, encoding="utf-8")
    return path


@pytest.mark.parametrize("kind", list(ComponentKind))
def test_every_kind_names_a_component_class_that_imports(kind: ComponentKind) -> None:
    cls = load_class(KINDS[kind].target)
    assert hasattr(cls, "start") and hasattr(cls, "stop")


def test_every_former_path_means_a_kind_and_todays_path_means_the_same() -> None:
    for target, kind in FORMER_TARGETS.items():
        assert kind_of_target(target) is kind
        assert kind_of_target(KINDS[kind].target) is kind
    assert kind_of_target("beacon:Beacon") is None


def test_a_kind_resolves_to_its_class_and_child_kind(tmp_path: Path) -> None:
    config = load_file(project(tmp_path, '[components.rcl]\nkind = "rcl"\n'
                                         '[components.bus]\nkind = "bus"\n'))
    rcl, bus = config.components
    assert (rcl.kind, rcl.module, rcl.child) == (
        ComponentKind.RCL, KINDS[ComponentKind.RCL].target, ChildKind.SUPERVISOR)
    assert rcl.child_spec().kind is ChildKind.SUPERVISOR
    assert bus.backoff is False and rcl.backoff is True  # the proxy restarts at once
    assert config.warnings == ()


def test_a_projects_own_class_keeps_its_module_and_may_be_a_supervisor(tmp_path: Path) -> None:
    config = load_file(project(tmp_path, '[components.own]\nmodule = "beacon:Beacon"\n'
                                         'child = "supervisor"\n'))
    (own,) = config.components
    assert (own.kind, own.module, own.child) == (None, "beacon:Beacon", ChildKind.SUPERVISOR)
    assert "child" not in own.options and config.warnings == ()


def test_a_misspelt_kind_is_refused_with_the_line_and_a_suggestion(tmp_path: Path) -> None:
    path = project(tmp_path, '[components.rcl]\nkind = "reasonr"\n')
    with pytest.raises(ConfigError) as info:
        load_file(path)
    assert info.value.key == "components.rcl.kind"
    assert info.value.file == f"{path}:4"
    assert "did you mean 'reasoner'?" in str(info.value)


def test_kind_and_module_together_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as info:
        load_file(project(tmp_path, '[components.rcl]\nkind = "rcl"\nmodule = "a:B"\n'))
    assert info.value.key == "components.rcl.module" and "not both" in str(info.value)


def test_a_former_module_path_starts_as_its_kind_with_a_warning(tmp_path: Path) -> None:
    path = project(tmp_path, '[components.rcl]\nmodule = "mrss.actors.rcl_service:RclService"\n'
                             'kind = "supervisor"\n')
    config = load_file(path)
    (rcl,) = config.components
    assert rcl.kind is ComponentKind.RCL and rcl.module == KINDS[ComponentKind.RCL].target
    assert rcl.child is ChildKind.SUPERVISOR
    texts = [str(w) for w in config.warnings]
    assert texts == [
        f"{path}:5: components.rcl.kind: kind = 'supervisor' is the former spelling of the "
        "child kind; write drop it (the component's kind implies it)",
        f"{path}:4: components.rcl.module: module = 'mrss.actors.rcl_service:RclService' names "
        "a class inside MRSS; write kind = 'rcl'"]


def test_mrss_check_names_a_former_spelling_with_file_and_line(tmp_path: Path) -> None:
    path = project(tmp_path, '[components.bus]\nmodule = "mrss.bus.component:ProxyComponent"\n')
    report = check_project(load_file(path))
    former = [f for f in report.warnings if f.check == "config"]
    assert [(f.file, f.line, f.key) for f in former] == [(str(path), 4, "components.bus.module")]
    assert "write kind = 'bus'" in former[0].message


def test_a_project_of_the_previous_release_starts(tmp_path: Path) -> None:
    """The shipped wildfire project as the previous release wrote it (a copy kept here)
    loads as the same components running the same classes, each former spelling warned."""
    repo = Path(__file__).resolve().parents[2]
    old = tmp_path / "wildfire"
    old.mkdir()
    (old / "project.toml").write_bytes(
        (Path(__file__).parent / "previous_release" / "wildfire.toml").read_bytes())
    today = load_file(repo / "projects" / "wildfire" / "project.toml")
    before = load_file(old / "project.toml")
    fleet = {"sim_uav2", "sim_uav3", "sim_ugv2"}  # the robots added since (3 UAVs, 2 UGVs)
    assert [(c.id, c.kind, c.module, c.child) for c in before.components] == \
        [(c.id, c.kind, c.module, c.child) for c in today.components if c.id not in fleet]
    assert len(before.warnings) == len(before.components) + 1  # + the rcl's `kind`
