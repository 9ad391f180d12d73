"""The PostGIS test server: without it the tests skip, or fail when it is required (CI)."""

from __future__ import annotations

import pytest

from tests.actors.worldmodel.pgcluster import REQUIRE_ENV, unavailable


def test_missing_postgis_skips_or_fails_when_required(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(REQUIRE_ENV, raising=False)
    with pytest.raises(pytest.skip.Exception, match="postgresql-15-postgis-3: no server"):
        unavailable("no server")
    monkeypatch.setenv(REQUIRE_ENV, "1")
    with pytest.raises(pytest.fail.Exception, match="MRSS_REQUIRE_POSTGIS=1"):
        unavailable("no server")
