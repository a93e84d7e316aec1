"""The noise that benchmarks/effects_oracle.py's floor adds: the data sets' marker noise, on the
nodes only, the same for the same seed, and no exact velocities left to the objective."""
from __future__ import annotations

import numpy as np
import xarray as xr
from effects_oracle import NOISE, noisy_copies


def _clean(T: int = 400) -> xr.Dataset:
    t = np.arange(T) * 0.01
    nodes = np.broadcast_to(np.linspace(0.0, 1.0, 12 * 3).reshape(1, 12, 3), (T, 12, 3)).copy()
    return xr.Dataset({"nodes": (("time", "node", "axis"), nodes),
                       "velocities": (("time", "node", "axis"), np.zeros_like(nodes)),
                       "controls": (("time", "cable"), np.ones((T, 24)))}, coords={"time": t})


def test_noisy_copies_add_the_data_noise_to_the_nodes_only() -> None:
    clean = _clean()
    copies = noisy_copies(clean, 3)
    assert len(copies) == 3
    for noisy in copies:
        assert "velocities" not in noisy
        assert noisy.attrs["noise_m"] == NOISE
        added = noisy["nodes"].values - clean["nodes"].values
        assert abs(added.std() / NOISE - 1.0) < 0.05
        assert abs(added.mean()) < 0.05 * NOISE
        np.testing.assert_array_equal(noisy["controls"].values, clean["controls"].values)
    assert not np.array_equal(copies[0]["nodes"].values, copies[1]["nodes"].values)
    np.testing.assert_array_equal(clean["velocities"].values, 0.0)


def test_noisy_copies_repeat_for_the_same_call() -> None:
    first, again = noisy_copies(_clean(), 2), noisy_copies(_clean(), 2)
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a["nodes"].values, b["nodes"].values)
