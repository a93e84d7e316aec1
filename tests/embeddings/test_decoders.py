"""Decoders map every latent point of their box inside the parameter box; REMBO is seeded; validation."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from embeddings import REMBO, Decoder, EmbeddingError, Identity
from physics.parameters import ParameterSpace

SPACE = ParameterSpace.t6()


def _latent(decoder: Decoder, u: np.ndarray) -> np.ndarray:
    lo, hi = decoder.bounds[:, 0], decoder.bounds[:, 1]
    return lo + u * (hi - lo)


@settings(max_examples=60, deadline=None)
@given(d=st.integers(1, 15), seed=st.integers(0, 2**31 - 1), data=st.data())
def test_rembo_maps_inside_the_box(d: int, seed: int, data: st.DataObject) -> None:
    dec = REMBO(SPACE, dim=d, seed=seed)
    u = data.draw(arrays(np.float64, (7, d), elements=st.floats(0.0, 1.0)))
    theta = dec.decode(_latent(dec, u))
    assert theta.shape == (7, SPACE.dim)
    assert np.all(theta >= SPACE.lower) and np.all(theta <= SPACE.upper)
    SPACE.as_array(theta)  # physically valid and in bounds


@settings(max_examples=40, deadline=None)
@given(u=arrays(np.float64, (5, 15), elements=st.floats(0.0, 1.0)))
def test_identity_is_the_unit_cube_map(u: np.ndarray) -> None:
    dec = Identity(SPACE)
    theta = dec.decode(u)
    np.testing.assert_allclose(theta, SPACE.from_unit(u))
    np.testing.assert_allclose(dec.encode(theta), u, atol=1e-12)


def test_rembo_latent_box_and_projection() -> None:
    dec = REMBO(SPACE, dim=5, seed=1)
    np.testing.assert_allclose(dec.bounds, np.tile([-np.sqrt(5), np.sqrt(5)], (5, 1)))
    assert dec.A.shape == (15, 5)
    z = np.array([[2.0, -1.0, 0.5, 0.0, 1.5]])
    y = dec.A @ z[0]
    expected = SPACE.lower + 0.5 * (np.clip(y, -1, 1) + 1) * (SPACE.upper - SPACE.lower)
    np.testing.assert_allclose(dec.decode(z)[0], expected)
    # points mapped outside [-1, 1]^D land on the boundary: the projection is the nearest box point
    outside = np.abs(y) > 1
    assert outside.any()
    np.testing.assert_allclose(dec.decode(z)[0][outside], np.where(y > 0, SPACE.upper, SPACE.lower)[outside])
    # the centre of the latent box decodes to the centre of the parameter box
    np.testing.assert_allclose(dec.decode(np.zeros(5)), 0.5 * (SPACE.lower + SPACE.upper))


def test_rembo_same_seed_same_matrix() -> None:
    a, b, c = REMBO(SPACE, dim=3, seed=7), REMBO(SPACE, dim=3, seed=7), REMBO(SPACE, dim=3, seed=8)
    assert np.array_equal(a.A, b.A) and not np.array_equal(a.A, c.A)
    assert a.config() == b.config() != c.config()


def test_single_point_decodes_to_a_vector() -> None:
    assert Identity(SPACE).decode(np.full(15, 0.5)).shape == (15,)
    assert REMBO(SPACE, dim=2, seed=0).decode(np.zeros(2)).shape == (15,)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: REMBO(SPACE, dim=0, seed=0), "dim must be an integer in"),
        (lambda: REMBO(SPACE, dim=16, seed=0), "dim must be an integer in"),
        (lambda: REMBO(SPACE, dim=2, seed=1.5), "seed must be an integer"),
        (lambda: REMBO(SPACE, dim=2, seed=0, box_scale=-1.0), "box_scale"),
        (lambda: Identity(SPACE).decode(np.zeros((3, 4))), r"shape \(n, 15\)"),
        (lambda: Identity(SPACE).decode(np.full((1, 15), np.nan)), "NaN"),
        (lambda: Identity(SPACE).decode(np.full((1, 15), 1.5)), "must lie in the box"),
        (lambda: REMBO(SPACE, dim=2, seed=0).decode(np.array([[3.0, 0.0]])), "clip them"),
    ],
)
def test_validation(call, match: str) -> None:
    with pytest.raises(EmbeddingError, match=match):
        call()
