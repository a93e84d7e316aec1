"""Cable laws: tension never negative, slack cables apply nothing, forces balance, and the
generalised-force convention agrees with DART's own external forces."""
from __future__ import annotations

import dartpy as dart
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from physics import CABLE_NODES, T6Model
from physics.cables import cable_wrenches, node_kinematics

HALF = np.full(6, 0.87)
EA, EB = np.ascontiguousarray(CABLE_NODES[:, 0]), np.ascontiguousarray(CABLE_NODES[:, 1])


def _wrench(q, dq, rest, k=800.0, c=200.0, spin=0.0):
    f, t, L = np.zeros(36), np.zeros(24), np.zeros(24)
    cable_wrenches(q, dq, HALF, EA, EB, rest, k, c, 0.0, 0.0, spin, f, t, L)
    return f, t, L


state = st.lists(st.floats(-2.0, 2.0), min_size=36, max_size=36).map(np.array)


@settings(max_examples=60, deadline=None)
@given(q=state, dq=state, rest=st.lists(st.floats(0.2, 1.6), min_size=24, max_size=24).map(np.array))
def test_tension_is_never_negative_and_zero_when_slack(q, dq, rest):
    f, tension, length = _wrench(q, dq, rest)
    assert np.all(tension >= 0.0)
    assert np.all(tension[length <= rest] == 0.0)
    # a cable pulls at most twice its spring force (damping clipped to ±F_k)
    assert np.all(tension <= 2 * 800.0 * np.maximum(length - rest, 0.0) + 1e-9)


@settings(max_examples=40, deadline=None)
@given(q=state, dq=state, rest=st.lists(st.floats(0.2, 1.6), min_size=24, max_size=24).map(np.array))
def test_cable_forces_are_internal(q, dq, rest):
    """Sum of forces and of moments about the origin vanish (Newton's third law, central forces)."""
    f, _, _ = _wrench(q, dq, rest)
    f = f.reshape(6, 6)
    np.testing.assert_allclose(f[:, 3:].sum(axis=0), 0.0, atol=1e-8)
    centres = q.reshape(6, 6)[:, 3:]
    moment = f[:, :3].sum(axis=0) + np.cross(centres, f[:, 3:]).sum(axis=0)
    np.testing.assert_allclose(moment, 0.0, atol=1e-7)


def test_all_slack_gives_no_force():
    model = T6Model()
    q, dq = model._positions(), model._velocities()
    f, tension, _ = _wrench(q, dq + 1.0, np.full(24, 5.0))
    assert np.all(f == 0.0) and np.all(tension == 0.0)


def test_generalised_forces_match_dart_external_forces():
    """setForces([τ about the centre, f]) moves a FreeJoint body like addExtForce(f at a point)."""
    def world():
        w = dart.simulation.World()
        w.setGravity([0.0, 0.0, 0.0])
        sk = dart.dynamics.Skeleton()
        _, body = sk.createFreeJointAndBodyNodePair(None)
        body.setMass(2.0)
        body.setMomentOfInertia(1.0, 0.3, 0.5, 0.0, 0.0, 0.0)
        w.addSkeleton(sk)
        sk.setPositions([0.3, -0.5, 0.2, 1.0, 2.0, 3.0])
        return w, sk, body
    force, offset = np.array([1.0, 2.0, -3.0]), np.array([0.2, 0.1, -0.3])
    w1, sk1, b1 = world()
    b1.addExtForce(force, np.array([1.0, 2.0, 3.0]) + offset, False, False)
    w2, sk2, _ = world()
    sk2.setForces(np.r_[np.cross(offset, force), force])
    w1.step()
    w2.step()
    np.testing.assert_allclose(sk1.getVelocities(), sk2.getVelocities(), rtol=1e-12, atol=1e-15)


def test_node_kinematics_of_a_rigid_rod():
    q = np.zeros(36)
    q[3:6] = [1.0, 2.0, 3.0]
    dq = np.zeros(36)
    dq[0:3] = [0.0, 1.0, 0.0]   # spin about world y; rod 0 axis is z at zero rotation
    p, v, axes = node_kinematics(q, dq, HALF)
    np.testing.assert_allclose(p[1] - p[0], [0, 0, 1.74])
    np.testing.assert_allclose(v[1], np.cross([0, 1, 0], [0, 0, 0.87]))
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0)
