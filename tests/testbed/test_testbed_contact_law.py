"""The contact law read from the foreign robot's flops (physics.contact_law): its flat cylinder
ends are told from DART's spheres, and its marker offset is measured, which the rest pose alone
cannot do (there the flat ends of its tilted rods sit 10 mm lower, just what the offset undoes)."""
from __future__ import annotations

import pytest

from physics import load_trajectory
from physics.contact_law import contact_law
from physics.effects.world import contact_excess


def _flops(name: str) -> list:
    from testbed.datasets import cached_dataset
    return [load_trajectory(cached_dataset(name, 0, noise=0.0002, version=2)[f"flop_{k}"]) for k in (0, 1)]


def test_the_testbed_has_flat_ends_and_its_marker_offset_is_read_from_the_flops() -> None:
    plain, offset = _flops("ground_viscosity"), _flops("marker_offset")
    assert abs(contact_excess(offset)) < 0.002          # at rest the offset data look like DART's spheres
    laws = {"plain": contact_law(plain), "offset": contact_law(offset)}
    for name, law in laws.items():
        assert law is not None and law.shape == "flat", (name, law)
        assert law.radius == pytest.approx(0.06, abs=0.003) and law.rms_sphere > 5 * law.rms_flat, (name, law)
    assert abs(laws["plain"].offset) < 0.003, laws["plain"]
    assert laws["offset"].offset == pytest.approx(0.01, abs=0.002), laws["offset"]
