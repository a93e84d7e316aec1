from __future__ import annotations

import numpy as np
import pytest

from physics import CABLE_NODES, ParameterError, closed_faces, node_positions, rod_mass_properties


def test_every_node_has_four_cables_and_no_cable_joins_a_rod():
    counts = np.bincount(CABLE_NODES.ravel(), minlength=12)
    assert np.all(counts == 4)
    assert not np.any(CABLE_NODES[:, 0] // 2 == CABLE_NODES[:, 1] // 2)
    assert len({tuple(sorted(c)) for c in CABLE_NODES.tolist()}) == 24


def test_all_cables_have_the_reference_length():
    h, s = 0.87, 0.45
    nodes = node_positions(2 * h, s)
    lengths = np.linalg.norm(nodes[CABLE_NODES[:, 1]] - nodes[CABLE_NODES[:, 0]], axis=1)
    np.testing.assert_allclose(lengths, np.sqrt(s**2 + (h - s) ** 2 + h**2))
    assert abs(lengths[0] - 1.066) < 1e-3


def test_eight_closed_faces():
    faces = closed_faces()
    assert len(faces) == 8
    edges = {tuple(sorted(c)) for c in CABLE_NODES.tolist()}
    for a, b, c in faces:
        assert {(a, b), (a, c), (b, c)} <= edges


def test_rod_mass_matches_reference():
    mp = rod_mass_properties(311, 0.06, 104, 0.035, 1.74, 1.0)
    assert abs(mp.mass - 3.0) < 0.01          # reference: ends 2.60 kg + middle 0.40 kg
    assert mp.transverse > mp.axial > 0
    with pytest.raises(ParameterError, match="must be shorter than rod_length"):
        rod_mass_properties(311, 0.06, 104, 0.035, 1.0, 1.2)
