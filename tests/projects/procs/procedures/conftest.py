"""These procedures run only under `mrss test procs`, never in the main test suite.

One of them fails on purpose (tests/commands/test_test_verb.py checks that `mrss test`
exits with pytest's code), so the folder is skipped unless `mrss test` set
MRSS_PROJECT_DIR to this project.
"""

from __future__ import annotations

import os
from pathlib import Path

_PROJECT = Path(__file__).resolve().parent.parent

if os.environ.get("MRSS_PROJECT_DIR", "") != str(_PROJECT):
    collect_ignore_glob = ["*"]
