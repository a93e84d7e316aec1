"""Effects the testbed robot can have, switched on by the data set and never declared in it.

Every field's off value leaves the robot as built. Each is the testbed's own modelling choice:

- ``slope`` [rad], ``slope_azimuth`` [rad]: the ground plane is tilted by ``slope`` about the
  horizontal axis perpendicular to azimuth (it rises toward the azimuth); gravity stays −z;
- ``marker_offset`` (x, y, z) [m]: a constant offset added to every observed node position;
- ``drag`` [N s/m]: a viscous force −drag·v on every rod end (air drag, linear in speed);
- ``actuator_delay`` [s]: commands reach the actuators this long after they are sent;
- ``hysteresis`` (0..1): while a cable shortens its spring force is (1 − hysteresis) k (L − L0)
  (it unloads softer than it loads);
- ``extra_mass`` [kg] on rod ``extra_mass_rod`` at ``extra_mass_at`` [m] along the rod axis
  from its centre toward its second node (a payload);
- ``ground_viscosity`` [N s/m]: a force −η v_t on each rod end closer than 1 cm to the ground
  (v_t: its velocity along the ground), mud or grass.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["Effects"]


@dataclass(frozen=True)
class Effects:
    """Switchable effects of the testbed (all off by default); see the module docstring."""

    slope: float = 0.0
    slope_azimuth: float = 0.0
    marker_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    drag: float = 0.0
    actuator_delay: float = 0.0
    hysteresis: float = 0.0
    extra_mass: float = 0.0
    extra_mass_rod: int = 0
    extra_mass_at: float = 0.0
    ground_viscosity: float = 0.0

    def __post_init__(self) -> None:
        if not (0.0 <= self.slope < 0.5):
            raise ValueError(f"slope must be in [0, 0.5) rad, got {self.slope!r}.")
        if len(self.marker_offset) != 3 or not np.all(np.isfinite(self.marker_offset)):
            raise ValueError(f"marker_offset must be 3 finite numbers [m], got {self.marker_offset!r}.")
        for name in ("drag", "actuator_delay", "extra_mass", "ground_viscosity"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {getattr(self, name)!r}.")
        if not (0.0 <= self.hysteresis < 1.0):
            raise ValueError(f"hysteresis must be in [0, 1), got {self.hysteresis!r}.")
        if self.extra_mass_rod not in range(6):
            raise ValueError(f"extra_mass_rod must be a rod index 0..5, got {self.extra_mass_rod!r}.")

    def active(self) -> dict[str, object]:
        """The fields that differ from their off value (what a data set records as its hidden truth)."""
        off = asdict(Effects())
        mine = asdict(self)
        on = {k: v for k, v in mine.items() if v != off[k] and not k.startswith(("slope_", "extra_mass_"))}
        if "slope" in on:
            on["slope_azimuth"] = self.slope_azimuth
        if "extra_mass" in on:
            on["extra_mass_rod"], on["extra_mass_at"] = self.extra_mass_rod, self.extra_mass_at
        return on

    def ground_normal(self) -> np.ndarray:
        """Unit normal (3,) of the ground plane in the world frame (z up)."""
        c, s = np.cos(self.slope_azimuth), np.sin(self.slope_azimuth)
        return np.array([-np.sin(self.slope) * c, -np.sin(self.slope) * s, np.cos(self.slope)])
