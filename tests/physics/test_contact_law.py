"""The contact law read from the flops (physics.contact_law): flat ends and spheres told apart,
and the observations' offset measured where the data allow it."""
from __future__ import annotations

import numpy as np
import pytest

from physics import make_trajectory
from physics.contact_law import contact_law

RADIUS = 0.06


def _rolling(shape: str, offset: float, *, tilts: tuple[float, float] = (20.0, 50.0), seconds: float = 2.0,
             rate: float = 100.0, noise: float = 2e-4, seed: int = 0):
    """Three rods whose lower nodes touch a level floor while their tilt sweeps ``tilts`` [deg]
    (each rod a little out of phase), three rods held high; a flat end rests its node r cos α
    above the floor, a sphere r; every observation is raised by ``offset`` [m]."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / rate)
    nodes = np.zeros((len(t), 12, 3))
    for rod in range(6):
        heading = rod * np.pi / 3
        if rod < 3:
            alpha = np.radians(np.interp(t / seconds + 0.1 * rod, [0.0, 1.3], tilts))
            low = RADIUS * (np.cos(alpha) if shape == "flat" else np.ones_like(alpha))
        else:
            alpha, low = np.full(len(t), np.radians(30.0)), np.full(len(t), 0.5)
        base = np.stack([0.3 * np.cos(heading) * np.ones_like(t), 0.3 * np.sin(heading) * np.ones_like(t), low], 1)
        axis = np.stack([np.cos(alpha) * np.cos(heading), np.cos(alpha) * np.sin(heading), np.sin(alpha)], 1)
        nodes[:, 2 * rod], nodes[:, 2 * rod + 1] = base, base + 1.7 * axis
    nodes[..., 2] += offset
    return make_trajectory(t, nodes + rng.normal(0.0, noise, nodes.shape), np.zeros((len(t), 24)))


def test_flat_ends_give_the_offset_and_the_radius() -> None:
    law = contact_law([_rolling("flat", 0.01, seed=k) for k in range(2)])
    assert law is not None and law.shape == "flat", law
    assert law.offset == pytest.approx(0.01, abs=5e-4) and law.radius == pytest.approx(RADIUS, abs=1e-3)
    assert law.rms_sphere > 5 * law.rms_flat and 0 < law.offset_se < 1e-3


def test_spheres_leave_the_offset_and_the_radius_as_one_number() -> None:
    law = contact_law([_rolling("sphere", 0.01, seed=k) for k in range(2)])
    assert law is not None and law.shape == "sphere" and law.offset is None, law
    assert law.sphere_height == pytest.approx(RADIUS + 0.01, abs=5e-4) and abs(law.radius) < 2e-3


def test_one_tilt_cannot_tell_the_shapes_apart_and_too_few_samples_give_nothing() -> None:
    law = contact_law([_rolling("flat", 0.0, tilts=(33.0, 33.0))])
    assert law is not None and law.shape == "undecided" and law.offset is None, law
    assert contact_law([_rolling("flat", 0.0, seconds=0.05)]) is None


def test_a_node_hovering_above_the_floor_does_not_move_the_reading() -> None:
    ds = _rolling("flat", 0.01)
    nodes = ds["nodes"].values.copy()
    nodes[:20, 6] = nodes[:20, 0] + [0.2, 0.0, 0.015]  # a high rod's node passes 15 mm above the floor for 0.2 s
    law = contact_law([ds.assign(nodes=(ds["nodes"].dims, nodes))])
    assert law is not None and law.shape == "flat" and law.offset == pytest.approx(0.01, abs=1e-3), law


def test_the_project_engine_has_spheres_at_its_nodes(flop_data) -> None:
    """DART's contact shapes are spheres of the rod radius at the nodes: a flop reads "sphere",
    resting its nodes at about the radius."""
    law = contact_law([flop_data])
    assert law is not None and law.shape == "sphere", law
    assert law.sphere_height == pytest.approx(RADIUS, abs=0.004)
