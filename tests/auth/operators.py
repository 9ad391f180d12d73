"""Helpers of the role tests: a copy of tests/tui/tuimission with operators."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

from mrss.auth.roles import Role
from mrss.auth.store import OperatorStore, store_path

TUIMISSION = Path(__file__).resolve().parent.parent / "tui" / "tuimission"
WILDFIRE_AGENT = Path(__file__).resolve().parents[2] / "projects" / "wildfire" / "agent.asl"
PASSWORDS = {"cora": "cora-secret-1", "olga": "olga-secret-1", "eddy": "eddy-secret-1"}


def project_with_users(projects: Path) -> tuple[Path, str]:
    """tuimission copied under `projects` with its users: cora (commander), otto
    (operator, a token), olga (observer), eddy (expired); its folder and otto's token."""
    folder = projects / "tuimission"
    shutil.copytree(TUIMISSION, folder)
    toml = folder / "project.toml"
    toml.write_text(toml.read_text().replace('"../../../projects/wildfire/agent.asl"',
                                             f'"{WILDFIRE_AGENT}"'))
    otto = "mrss_" + "o" * 43
    store = OperatorStore.new(store_path(folder))
    store = store.with_user("cora", Role.COMMANDER, password=PASSWORDS["cora"])
    store = store.with_user("otto", Role.OPERATOR, token=otto)
    store = store.with_user("olga", Role.OBSERVER, password=PASSWORDS["olga"])
    store = store.with_user("eddy", Role.OPERATOR, password=PASSWORDS["eddy"],
                            expires=time.time() - 60)
    store.save()
    return folder, otto
