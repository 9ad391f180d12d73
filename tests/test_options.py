"""Options are read through their declarations: one default, in one place."""

from __future__ import annotations

import pytest

from mrss.actors.rcl import options as rcl_options
from mrss.actors.rcl.core import RclCore
from mrss.actors.rcl.service import RclService
from mrss.errors import ConfigError
from mrss.options import Check, Option, OptionValues

DECLARED = (Option("period", float, 60.0, check=Check.POSITIVE),
            Option("limit", int, 5, check=Check.POSITIVE),
            Option("mode", str, "fast", choices=("fast", "slow")),
            Option("robots", dict, {}), "plain_name")


def test_an_absent_option_reads_as_its_declared_default_and_a_table_default_is_fresh() -> None:
    values = OptionValues(DECLARED, {})
    assert (values["period"], values.whole("limit"), values.text("mode")) == (60.0, 5, "fast")
    values["robots"]["x"] = 1
    assert values["robots"] == {}


def test_a_present_option_is_read_and_an_int_is_taken_as_a_float() -> None:
    values = OptionValues(DECLARED, {"period": 2, "mode": "slow"})
    assert values["period"] == 2.0 and isinstance(values["period"], float)
    assert values["mode"] == "slow"


@pytest.mark.parametrize(("table", "key", "fragment"), [
    ({"period": "soon"}, "rcl.period", "must be a number, not 'soon'"),
    ({"period": -1}, "rcl.period", "must be > 0"),
    ({"limit": True}, "rcl.limit", "must be an integer"),
    ({"mode": "medium"}, "rcl.mode", "must be one of fast, slow"),
])
def test_a_bad_value_is_a_config_error_naming_its_key(table: dict[str, object], key: str,
                                                      fragment: str) -> None:
    name = key.split(".")[1]
    with pytest.raises(ConfigError) as info:
        OptionValues(DECLARED, table, section="rcl")[name]
    assert info.value.key == key and fragment in str(info.value)


def test_an_undeclared_option_cannot_be_read() -> None:
    with pytest.raises(KeyError):
        OptionValues(DECLARED, {"undeclared": 1})["undeclared"]


def test_the_rcl_core_defaults_are_the_declared_ones() -> None:
    """max_robot_restarts and its neighbours have one default: the RCL's declaration."""
    import inspect

    params = inspect.signature(RclCore.__init__).parameters
    for name in ("max_robot_restarts", "restart_period", "probation", "adopt_grace",
                 "adopt_grace_suspended", "preempted_timeout"):
        assert params[name].default == rcl_options.default(name), name
    assert RclService.OPTIONS is rcl_options.RCL_OPTIONS
