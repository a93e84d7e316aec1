"""GP surrogate: interpolation quality, determinism, exact invariance to data order, fast predict = pyro's
GPRegression.forward, fantasize, validation."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from belief import BeliefError, GPSurrogate, SurrogateConfig
from belief.surrogate import _torch_context

BOUNDS = np.array([[0.0, 2.0], [-1.0, 1.0]])


def _f(z: np.ndarray) -> np.ndarray:
    return (z[:, 0] - 1.2) ** 2 + 0.5 * (z[:, 1] + 0.3) ** 2 + 0.01


def _data(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    z = BOUNDS[:, 0] + rng.random((n, 2)) * (BOUNDS[:, 1] - BOUNDS[:, 0])
    return z, _f(z)


@pytest.mark.parametrize("log_transform", [True, False])
def test_fit_predicts_held_out_points(log_transform: bool) -> None:
    z, e = _data(30)
    m = GPSurrogate(BOUNDS, config=SurrogateConfig(log_transform=log_transform)).fit(z, e)
    zt, et = _data(200, seed=1)
    mean, var = m.predict(zt)
    pred = m.inverse_transform(mean)
    assert mean.shape == var.shape == (200,) and np.all(var >= 0)
    assert np.median(np.abs(pred - et)) < 0.05 * np.ptp(et)
    # noiseless predictive collapses at the data (interpolation of a deterministic function)
    m0, v0 = m.predict(z)
    np.testing.assert_allclose(m.inverse_transform(m0), e, rtol=1e-2, atol=1e-3 * np.ptp(e))
    assert np.all(v0 < 1e-2 * var.mean())
    assert m.lengthscale_.shape == (2,) and m.noise_ > 0


def test_same_data_any_order_same_predictions_bit_for_bit() -> None:
    z, e = _data(25)
    perm = np.random.default_rng(5).permutation(25)
    a = GPSurrogate(BOUNDS).fit(z, e)
    b = GPSurrogate(BOUNDS).fit(z[perm], e[perm])
    zt, _ = _data(50, seed=2)
    ma, va = a.predict(zt)
    mb, vb = b.predict(zt)
    assert np.array_equal(ma, mb) and np.array_equal(va, vb)


def test_chunking_does_not_change_predictions() -> None:
    z, e = _data(20)
    zt, _ = _data(100, seed=3)
    a = GPSurrogate(BOUNDS, config=SurrogateConfig(chunk_size=7)).fit(z, e).predict(zt)
    b = GPSurrogate(BOUNDS, config=SurrogateConfig(chunk_size=4096)).fit(z, e).predict(zt)
    np.testing.assert_allclose(a[0], b[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a[1], b[1], rtol=1e-9, atol=1e-14)


def _pyro_predict(m: GPSurrogate, zq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference: pyro's own GPRegression.forward on all points at once, in t units."""
    with _torch_context(1), torch.no_grad():
        mu, v = m.gp_(m._scale(zq), full_cov=False, noiseless=True)
    return mu.numpy() * m.t_std_ + m.t_mean_, np.maximum(v.numpy(), 0.0) * m.t_std_**2


def _assert_same_prediction(m: GPSurrogate, zq: np.ndarray) -> None:
    mean, var = m.predict(zq)
    ref_mean, ref_var = _pyro_predict(m, zq)
    scale_var = float(m.gp_.kernel.variance.detach()) * m.t_std_**2  # prior variance in t units
    np.testing.assert_allclose(mean, ref_mean, rtol=1e-10, atol=1e-10 * np.abs(ref_mean).max())
    np.testing.assert_allclose(var, ref_var, rtol=1e-8, atol=1e-10 * scale_var)


@pytest.mark.parametrize("log_transform", [True, False])
def test_fast_predict_equals_pyro_gpregression_forward(log_transform: bool) -> None:
    rng = np.random.default_rng(11)
    bounds = np.array([[0.0, 2.0], [-1.0, 1.0], [-3.0, 5.0]])
    z = bounds[:, 0] + rng.random((40, 3)) * (bounds[:, 1] - bounds[:, 0])
    e = np.sum(np.sin(2.0 * z), axis=1) ** 2 + 0.1 * z[:, 2] ** 2 + 0.05
    m = GPSurrogate(bounds, config=SurrogateConfig(log_transform=log_transform, chunk_size=64)).fit(z, e)
    # random cells (some beyond the box), the data themselves (variance ~ 0) and a point next to one
    zq = np.vstack([bounds[:, 0] - 0.1 + rng.random((300, 3)) * (bounds[:, 1] - bounds[:, 0] + 0.2),
                    z, z[:1] + 1e-9])
    _assert_same_prediction(m, zq)
    # the fantasized copy has its own factorization; the original keeps its own
    f = m.fantasize(zq[:2], m.predict(zq[:2])[0])
    _assert_same_prediction(f, zq)
    _assert_same_prediction(m, zq)
    assert m.predict(np.zeros((0, 3)))[0].shape == (0,)


def test_joint_prediction_matches_marginal_and_is_psd() -> None:
    z, e = _data(20)
    m = GPSurrogate(BOUNDS).fit(z, e)
    zt, _ = _data(30, seed=4)
    mean, var = m.predict(zt)
    jm, cov = m.predict_joint(zt)
    np.testing.assert_allclose(jm, mean, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(np.diag(cov), var, rtol=1e-6, atol=1e-10)
    assert np.linalg.eigvalsh(0.5 * (cov + cov.T)).min() > -1e-8 * var.max()


def test_fantasize_shrinks_variance_only_near_the_new_point() -> None:
    z, e = _data(15)
    m = GPSurrogate(BOUNDS).fit(z, e)
    znew = np.array([[0.1, 0.9]])
    mean0, var0 = m.predict(znew)
    f = m.fantasize(znew, mean0)
    mean1, var1 = f.predict(znew)
    assert var1[0] < 1e-3 * var0[0]
    np.testing.assert_allclose(mean1, mean0, atol=1e-6 * (1 + abs(mean0[0])))
    # the original model is unchanged
    np.testing.assert_array_equal(m.predict(znew)[1], var0)


def test_jitter_escalates_on_duplicate_points_with_conflicting_values() -> None:
    z = np.array([[0.5, 0.0]] * 3 + [[1.0, 0.5], [1.5, -0.5]])
    e = np.array([1.0, 2.0, 3.0, 1.5, 0.5])
    m = GPSurrogate(BOUNDS, config=SurrogateConfig(log_transform=False, jitter=1e-12, noise_init=1e-9)).fit(z, e)
    mean, var = m.predict(z[:1])
    assert np.isfinite(mean).all() and np.isfinite(var).all()
    assert m.jitter_ >= 1e-12


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: GPSurrogate(BOUNDS).fit(np.zeros((3, 3)), np.zeros(3)), r"shape \(n, 2\)"),
        (lambda: GPSurrogate(BOUNDS).fit(np.zeros((3, 2)), np.zeros(4)), r"shape \(3,\)"),
        (lambda: GPSurrogate(BOUNDS).fit(np.zeros((1, 2)), np.zeros(1)), "at least 2"),
        (lambda: GPSurrogate(BOUNDS).fit(np.zeros((2, 2)), np.array([1.0, np.nan])), "finite"),
        (lambda: GPSurrogate(BOUNDS).predict(np.zeros((2, 2))), "not fitted"),
        (lambda: GPSurrogate(np.array([[1.0, 0.0]])), "lower < upper"),
        (lambda: SurrogateConfig(log_offset=0.0), "log_offset"),
        (lambda: SurrogateConfig(jitter=1.0, max_jitter=0.1), "jitter"),
        (lambda: SurrogateConfig(max_iter=0), "max_iter"),
        (lambda: SurrogateConfig(chunk_size=0), "chunk_size"),
        (lambda: SurrogateConfig(num_threads=0), "num_threads"),
        (lambda: SurrogateConfig(noise_init=0.0), "noise_init"),
    ],
)
def test_validation(call, match: str) -> None:
    with pytest.raises(BeliefError, match=match):
        call()
