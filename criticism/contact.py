"""The contact read from the flops, as parts of the model: the end caps' shape and the offset of
the observations (physics.contact_law).

The model touches the ground with spheres at the nodes. When the contact nodes' heights follow
the flat-end law h = b + r cos α instead (``ContactLaw.shape == "flat"``), the model takes the
flat ends (:class:`physics.effects.CylinderCaps`) before anything is fitted, and only then does
the law's offset b mean what a :class:`physics.effects.SensorBias` means: the observations' shift
along the floor's normal. That bias is bound with ``from_flops`` and a box of
± max(FLOPS_OFFSET_WIDTH, 3 standard errors), and is evident (it joins the model without a
search, as a slope measured at rest does) when it exceeds EVIDENT_OFFSET and its box leaves out
zero (SensorBias.evident). Under the sphere law b and r are one number, and nothing is read.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import xarray as xr

from physics.contact_law import ContactLaw, contact_law
from physics.effects import CylinderCaps, Effect, SensorBias
from physics.effects.sensing import FLOPS_OFFSET_WIDTH

__all__ = ["ContactReading", "read_contact"]


@dataclass(frozen=True)
class ContactReading:
    """law: the contact law fitted to the flops (None without enough contact samples); components:
    the model parts it replaces (CylinderCaps for flat ends); bias: the observations' offset it
    reads, bound (None unless the ends are flat)."""

    law: ContactLaw | None
    components: tuple[Effect, ...]
    bias: SensorBias | None

    def text(self) -> str:
        """One line for the report."""
        if self.law is None:
            return "contact law: too few contact samples to read the end caps"
        added = ", ".join(e.name for e in self.components) or "nothing"
        return f"contact law: {self.law.text()}; the model takes {added}"

    def as_dict(self) -> dict:
        """A JSON-able record: the law's fields, the components' and the bias's configs."""
        return {"law": None if self.law is None else vars(self.law),
                "components": [e.config() for e in self.components],
                "bias": None if self.bias is None else self.bias.config()}


def read_contact(trajectories: Sequence[xr.Dataset]) -> ContactReading:
    """The contact law of ``trajectories`` and the model parts it implies (module docstring)."""
    law = contact_law(trajectories)
    if law is None or law.shape != "flat" or law.offset is None:
        return ContactReading(law, (), None)
    width = max(FLOPS_OFFSET_WIDTH, 3.0 * law.offset_se)
    bias = SensorBias(measured=law.offset, width=width, from_flops=True)
    return ContactReading(law, (CylinderCaps(),), bias)
