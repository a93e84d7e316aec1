"""Rolling resistance (physics.effects.RollingResistance) by its law: only touching rods feel it,
in proportion to the load they put on the ground; it opposes their turn about axes in the ground
plane and never reverses it, and it takes energy out of a robot rolling on the ground."""
from __future__ import annotations

import numpy as np
import pytest

from physics import ModelOptions, ParameterError, T6Model
from physics.effects import RollingResistance, effect_from_config, model_space
from physics.effects.contact import rolling_torques

HALF = 0.85
UP = np.array([0.0, 0.0, 1.0])


def _upright_rods(heights: list[float], spin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """FreeJoint q, dq (36,): six vertical rods whose lower node is at ``heights`` [m], all turning at ``spin``."""
    q, dq = np.zeros(36), np.zeros(36)
    for i, h in enumerate(heights):
        q[6 * i + 3:6 * i + 6] = [2.0 * i, 0.0, h + HALF]
        dq[6 * i:6 * i + 3] = spin
    return q, dq


def _torques(q, dq, lever=0.1, contact_height=0.065, normal=UP, applied=None) -> np.ndarray:
    """Torques (6 x 3) [N m] for rods of 9 kg, transverse inertia 1 and axial 0.01 kg m², under
    gravity 10 m/s² along −z and applied forces ``applied`` (6 x 3) [N] (none by default), dt 1 ms."""
    out = np.zeros((6, 6))
    if applied is not None:
        out[:, 3:] = applied
    out = out.reshape(36)
    rolling_torques(q, dq, HALF, normal, contact_height, np.full(6, 9.0), np.array([0.0, 0.0, -10.0]), lever,
                    np.array([1.0, 0.01]), 1e-3, out)
    return out.reshape(6, 6)[:, :3]


def test_only_touching_rods_feel_it_in_proportion_to_their_weight():
    spin = np.array([2.0, -1.0, 3.0])
    q, dq = _upright_rods([0.06, 0.06, 0.5, 0.5, 0.5, 0.5], spin)
    torques = _torques(q, dq)
    assert np.all(torques[2:] == 0.0)
    perp = spin - (spin @ UP) * UP
    for t in torques[:2]:   # each touching rod weighs 90 N on the ground: |τ| = 0.1 m × 90 N
        np.testing.assert_allclose(t, -9.0 * perp / np.linalg.norm(perp), rtol=1e-12)
    assert np.all(_torques(*_upright_rods([0.5] * 6, spin)) == 0.0)     # nothing touches: no torque


def test_a_force_that_lifts_a_rod_lightens_it_and_one_that_presses_it_loads_it():
    spin = np.array([2.0, -1.0, 0.0])
    q, dq = _upright_rods([0.06] * 6, spin)
    applied = np.zeros((6, 3))
    applied[0, 2], applied[1, 2], applied[2, 2] = 50.0, -30.0, 120.0      # lift by 50 N, press by 30, lift it off
    applied[3, 0] = 70.0                                                  # along the ground: no load change
    sizes = np.linalg.norm(_torques(q, dq, applied=applied), axis=1)
    np.testing.assert_allclose(sizes, [4.0, 12.0, 0.0, 9.0, 9.0, 9.0], rtol=1e-12)


def test_it_never_acts_about_the_normal_and_never_reverses_a_turn():
    q, dq = _upright_rods([0.06] * 6, np.array([0.0, 0.0, 5.0]))     # spin about the normal only
    assert np.all(_torques(q, dq) == 0.0)
    slow = np.array([1e-3, 0.0, 0.0])
    q, dq = _upright_rods([0.06] * 6, slow)
    torques = _torques(q, dq, lever=1.0)            # μ_r N = 90 N m > I_t |ω| / dt = 1 N m: stops it in a step
    np.testing.assert_allclose(torques, np.tile(-1000.0 * slow, (6, 1)), rtol=1e-12)


def test_a_lying_rods_spin_about_its_own_axis_is_stopped_with_its_axial_inertia():
    q, dq = np.zeros(36), np.zeros(36)
    for i in range(6):       # rods along -y (rotation vector (π/2, 0, 0)) lying on the ground, spinning about y
        q[6 * i:6 * i + 6] = [np.pi / 2, 0.0, 0.0, 2.0 * i, 0.0, 0.06]
        dq[6 * i + 1] = 0.5
    torques = _torques(q, dq, lever=1.0)            # I_a ω / dt = 5 N m < μ_r N = 90 N m
    np.testing.assert_allclose(torques, np.tile([0.0, -5.0, 0.0], (6, 1)), atol=1e-9)


def test_on_a_sloped_floor_it_uses_the_floors_normal():
    tilt = np.array([np.sin(0.1), 0.0, np.cos(0.1)])
    spin = np.array([0.0, 0.0, 2.0])                                   # partly in the tilted plane
    q, dq = _upright_rods([0.06] + [0.5] * 5, spin)
    torque = _torques(q, dq, normal=tilt)[0]
    assert abs(torque @ tilt) < 1e-12 and torque @ spin < 0


def test_a_rolling_robot_loses_more_energy_with_it():
    def kinetic_after(lever: float) -> float:
        effects = [RollingResistance()]
        space = model_space(effects)
        theta = space.as_array({**space.as_dict(None), "rolling_resistance": lever}, check_bounds=False)
        model = T6Model(theta, effects=effects, options=ModelOptions(drop_height=0.0))
        model.settle(0.5)
        model._set_velocities(np.tile([0.0, 3.0, 0.0, 0.5, 0.0, 0.0], 6))   # rolling along x
        model.step(None, n=300)
        return model.energy()["kinetic"]

    assert kinetic_after(0.2) < 0.8 * kinetic_after(0.0)


def test_its_configuration_round_trips_and_bad_bands_are_refused():
    assert effect_from_config(RollingResistance(band=0.01).config()) == RollingResistance(band=0.01)
    with pytest.raises(ParameterError, match="band"):
        RollingResistance(band=0.0)
