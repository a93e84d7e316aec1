"""Cable anchors fixed to the rods (physics.effects.fixed_anchors), tested by their laws.

Placing rods from nodes turns each rod about its own axis until its anchors aim at their cables'
other ends, whatever spin it had; the anchored cables are internal forces (no net force and no net
moment on the robot); a slack cable exerts nothing; a rod twisted about its own axis is twisted back;
the model with the anchors rests on the ground and places itself from its own nodes without a jump.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from physics.effects import FixedCableAnchors, model_space
from physics.effects.anchors import anchor_points
from physics.effects.fixed_anchors import body_anchors, fixed_anchor_wrenches, orient_rods
from physics.geometry import CABLE_NODES, node_positions, rod_poses_from_nodes
from physics.tensegrity import T6Model

OFFSET, LENGTH, SPACE = 0.06, 1.7, 0.45
HALF = np.full(6, LENGTH / 2)


def _turned(q: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """q (36,) with rod i turned by angles[i] [rad] about its own axis."""
    q = q.reshape(6, 6).copy()
    q[:, :3] = (Rotation.from_rotvec(q[:, :3]) * Rotation.from_rotvec(np.outer(angles, [0, 0, 1]))).as_rotvec()
    return q.reshape(-1)


def _world_anchors(q: np.ndarray, local: np.ndarray) -> np.ndarray:
    """World anchors (24 x 2 x 3) of body-frame anchors ``local`` at FreeJoint positions q (36,)."""
    q6 = q.reshape(6, 6)
    rot = Rotation.from_rotvec(q6[:, :3]).as_matrix()
    rods = CABLE_NODES // 2
    return np.einsum("jsab,jsb->jsa", rot[rods], local) + q6[rods, 3:]


def _build() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    nodes = node_positions(LENGTH, SPACE)
    q, _ = rod_poses_from_nodes(nodes)
    return nodes, q, body_anchors(LENGTH, SPACE, OFFSET)


def test_placing_a_rod_aims_its_anchors_whatever_its_spin() -> None:
    nodes, q, local = _build()
    spun = _turned(q, np.random.default_rng(0).uniform(-np.pi, np.pi, 6))
    assert not np.allclose(_world_anchors(spun, local), anchor_points(nodes, OFFSET), atol=1e-3)
    placed = orient_rods(spun, local, OFFSET, LENGTH / 2)
    assert np.allclose(_world_anchors(placed, local), anchor_points(nodes, OFFSET), atol=1e-9)


def _wrench(q: np.ndarray, tension: np.ndarray, dq: np.ndarray | None = None) -> np.ndarray:
    _, _, local = _build()
    out = np.zeros(36)
    fixed_anchor_wrenches(q, np.zeros(36) if dq is None else dq, HALF, local, tension, 800.0, 200.0,
                          np.zeros(24), out)
    return out.reshape(6, 6)


def test_anchored_cables_are_internal_and_slack_ones_exert_nothing() -> None:
    _, q, _ = _build()
    q = _turned(q, np.full(6, 0.2)) + np.random.default_rng(1).normal(0, 0.01, 36)
    dq = np.random.default_rng(2).normal(0, 0.3, 36)
    w = _wrench(q, np.full(24, 120.0), dq)
    force, torque, centre = w[:, 3:], w[:, :3], q.reshape(6, 6)[:, 3:]
    assert np.abs(force).max() > 1.0
    assert np.allclose(force.sum(axis=0), 0.0, atol=1e-9)
    assert np.allclose((torque + np.cross(centre, force)).sum(axis=0), 0.0, atol=1e-9)
    assert np.all(_wrench(q, np.zeros(24), dq) == 0.0)


@pytest.mark.parametrize("twist", [0.05, -0.05])
def test_a_rod_twisted_about_its_axis_is_twisted_back(twist: float) -> None:
    _, q, local = _build()
    aimed = orient_rods(q, local, OFFSET, LENGTH / 2)
    twisted = _turned(aimed, np.r_[twist, np.zeros(5)])
    axis = Rotation.from_rotvec(twisted[:3]).as_matrix()[:, 2]
    before = _wrench(aimed, np.full(24, 120.0))[0, :3] @ axis
    after = _wrench(twisted, np.full(24, 120.0))[0, :3] @ axis
    assert np.sign(after - before) == -np.sign(twist) and abs(after - before) > 0.1


def test_the_anchored_model_rests_and_places_itself_without_a_jump() -> None:
    effects = [FixedCableAnchors()]
    space = model_space(effects)
    theta = space.as_array({**dict(zip(space.names, space.nominal, strict=True)), "fixed_anchor_offset": OFFSET})
    model = T6Model(theta, effects=effects)
    model.settle(1.5)
    nodes = model.node_positions()
    assert np.all(nodes[:, 2] >= model.params["radius"] - 2e-3)
    assert np.abs(model.node_velocities()).max() < 0.05
    model.set_nodes(nodes)
    model.step(None, 100)
    assert np.abs(model.node_positions() - nodes).max() < 1e-3
