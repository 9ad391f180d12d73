"""The simulated UAV's parameters, named and scaled as ArduCopter's where one exists.

Ground stations fetch them (PARAM_REQUEST_LIST) and may set them (PARAM_SET); setting
one changes the flight model at once. ``SIM_`` parameters exist only in the simulator.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from mrss.sim.copter import CopterModel
from mrss.sim.gcs_failsafe import GcsFailsafe
from mrss.sim.hotspots import ThermalCamera


@dataclass(frozen=True)
class ParamSpec:
    """How one named parameter reads and writes the model (value in parameter units)."""

    name: str
    get: Callable[[], float]
    set: Callable[[float], None] | None  # None: read-only


class UavParams:
    """The ordered parameter table of one simulated vehicle."""

    def __init__(self, model: CopterModel, camera: ThermalCamera, sysid: int,
                 failsafe: GcsFailsafe) -> None:
        p = model.params

        def setter(attr: str, scale: float) -> Callable[[float], None]:
            def apply(value: float) -> None:
                if value <= 0:
                    raise ValueError(f"{attr} must be positive")
                setattr(p, attr, value / scale)
            return apply

        def set_radius(value: float) -> None:
            if value <= 0:
                raise ValueError("camera radius must be positive")
            camera.radius_m = value

        def set_gcs_sysid(value: float) -> None:
            if int(value) != value or not 1 <= value <= 255:
                raise ValueError("SYSID_MYGCS must be a system id 1..255")
            failsafe.gcs_sysid = int(value)

        self._specs = [
            ParamSpec("SYSID_THISMAV", lambda: float(sysid), None),
            ParamSpec("FRAME_CLASS", lambda: 1.0, None),  # quad
            ParamSpec("WPNAV_SPEED", lambda: p.speed_mps * 100, setter("speed_mps", 100)),
            ParamSpec("WPNAV_SPEED_UP", lambda: p.climb_mps * 100, setter("climb_mps", 100)),
            ParamSpec("WPNAV_SPEED_DN", lambda: p.descent_mps * 100,
                      setter("descent_mps", 100)),
            ParamSpec("LAND_SPEED", lambda: p.land_mps * 100, setter("land_mps", 100)),
            ParamSpec("RTL_ALT", lambda: p.rtl_alt_m * 100, setter("rtl_alt_m", 100)),
            ParamSpec("FS_GCS_ENABLE", lambda: float(failsafe.enable), failsafe.set_enable),
            ParamSpec("FS_GCS_TIMEOUT", lambda: failsafe.watch.timeout_s, failsafe.set_timeout),
            ParamSpec("SYSID_MYGCS", lambda: float(failsafe.gcs_sysid), set_gcs_sysid),
            ParamSpec("SIM_ENDURANCE", lambda: p.endurance_s, setter("endurance_s", 1)),
            ParamSpec("SIM_BATT_FS_PCT", lambda: p.failsafe_pct, setter("failsafe_pct", 1)),
            ParamSpec("SIM_CAM_RADIUS", lambda: camera.radius_m, set_radius),
        ]
        self._by_name = {spec.name: spec for spec in self._specs}

    def __len__(self) -> int:
        return len(self._specs)

    def at(self, index: int) -> tuple[str, float] | None:
        """Name and value of the parameter at `index`, or None if out of range."""
        if 0 <= index < len(self._specs):
            spec = self._specs[index]
            return spec.name, spec.get()
        return None

    def index_of(self, name: str) -> int | None:
        """Position of a parameter in the table, or None if there is no such parameter."""
        spec = self._by_name.get(name)
        return self._specs.index(spec) if spec is not None else None

    def set(self, name: str, value: float) -> bool:
        """Set a writable parameter; False if unknown, read-only or an invalid value."""
        spec = self._by_name.get(name)
        if spec is None or spec.set is None:
            return False
        try:
            spec.set(value)
        except ValueError:
            return False
        return True
