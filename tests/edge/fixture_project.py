"""The small project the edge components' tests run (tests/edge/project_fixture)."""

from __future__ import annotations

from pathlib import Path

PROJECT_FIXTURE = Path(__file__).parent / "project_fixture"
