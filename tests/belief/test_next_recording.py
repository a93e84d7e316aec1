"""What to record next (belief.next_recording) on linear residual models, where every information
matrix is known exactly: the design must pick the motion that sees what the data do not, price it
by the Gaussian information gain, count the model-error floor's growth, and leave the mass–force
scale out."""
from __future__ import annotations

import numpy as np
import pytest
from linear_objective import LinearObjective, unit_space

from belief.errors import BeliefError
from belief.identifiability import identifiability
from belief.next_recording import MIN_GAIN, DesignConfig, suggest_recording
from physics.candidate_recordings import FlopMotion
from physics.measurements import Measurement, MeasurementPrior
from physics.parameters import Parameter, ParameterSpace

THETA = np.full(3, 0.5)
SIGMA2 = 0.01


def _candidates(blocks: list[np.ndarray], space: ParameterSpace | None = None) -> LinearObjective:
    """One segment per motion: its residuals y − A_a θ, each block the same number of rows."""
    A = np.vstack(blocks)
    objective = LinearObjective(A, A @ THETA, segments=len(blocks))
    if space is not None:
        objective.space = space
    return objective


def _motions(n: int) -> tuple[FlopMotion, ...]:
    return tuple(FlopMotion(heading=float(k)) for k in range(n))


def _gain(F_data: np.ndarray, F_a: np.ndarray, c: float = 1.0) -> float:
    """½ log det C − ½ log det C_a in relative changes: θ̂ = 0.5 in a unit box, so x = log θ has
    du = 0.5 dx and the box's precision is 12 · 0.5² = 3 per axis."""
    T, box = np.diag(np.full(3, 0.5)), 3.0 * np.eye(3)
    C = np.linalg.inv(T @ F_data @ T + box)
    C_a = np.linalg.inv(c * T @ (F_data + F_a) @ T + box)
    return 0.5 * (np.linalg.slogdet(C)[1] - np.linalg.slogdet(C_a)[1])


def test_the_motion_that_sees_the_unseen_parameter_wins_with_the_exact_gain() -> None:
    """Data pin p0 and p1; motion 0 sees p0 again, motion 1 sees p2: motion 1 is suggested, its gain is
    the Gaussian information gain computed by hand, and the widest direction (p2) narrows."""
    rng = np.random.default_rng(0)
    A = np.column_stack([rng.normal(size=40), rng.normal(size=40), 0.01 * rng.normal(size=40)])
    data = LinearObjective(A, A @ THETA)
    seen, unseen = np.zeros((40, 3)), np.zeros((40, 3))
    seen[:, 0], unseen[:, 2] = rng.normal(size=40), rng.normal(size=40)
    out = suggest_recording(data, THETA, _candidates([seen, unseen]), _motions(2), noise_var=SIGMA2,
                            floor_scaled=False, config=DesignConfig(directions=1))
    assert out.best.motion == _motions(2)[1]
    expected = [_gain(A.T @ A / SIGMA2, B.T @ B / SIGMA2) for B in (unseen, seen)]
    assert [s.gain for s in out.scores] == pytest.approx(expected, rel=1e-4)
    assert "p2" in out.directions[0] and out.best.after_pct[0] < 0.5 * out.before_pct[0]
    assert out.lines()[1].startswith("  record a flop toward")


def test_under_the_model_error_floor_more_of_the_same_buys_nothing() -> None:
    """σ² ∝ E: recording the same motion again doubles the data and σ² alike, so the information is
    unchanged (gain 0, and the line says no motion is expected to narrow P); with σ² measured from
    the noise the same motion halves the variance along every seen direction."""
    rng = np.random.default_rng(1)
    A = rng.normal(size=(30, 3))
    data = LinearObjective(A, A @ THETA)
    floored = suggest_recording(data, THETA, _candidates([A]), _motions(1), noise_var=SIGMA2, floor_scaled=True)
    measured = suggest_recording(data, THETA, _candidates([A]), _motions(1), noise_var=SIGMA2, floor_scaled=False)
    F = A.T @ A / SIGMA2
    assert floored.best.gain == pytest.approx(_gain(F, F, c=0.5), abs=1e-6) and abs(floored.best.gain) < MIN_GAIN
    assert measured.best.gain == pytest.approx(_gain(F, F), rel=1e-4) and measured.best.gain > 1.0
    assert "no candidate flop is expected to narrow P" in floored.lines()[1]
    assert any("model-error floor" in n for n in floored.notes)


def test_the_mass_force_scale_is_left_out_when_the_data_cannot_see_it() -> None:
    """A mass (kg) and a force (N) moved together leave the residuals unchanged: that direction, the
    widest of all (the box's alone), is not reported; the widest left is l, seen weakly, and the
    notes say a weighed rod fixes the scale. With the mass measured, nothing is left out."""
    space = ParameterSpace(tuple(Parameter(name, unit, 0.5, 0.0, 1.0, "", minimum=-np.inf)
                                 for name, unit in (("m", "kg"), ("f", "N"), ("l", "m"))))
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=30), rng.normal(size=30)
    A = np.column_stack([a, -a, 0.05 * b])
    data = LinearObjective(A, A @ THETA)
    data.space = space
    out = suggest_recording(data, THETA, _candidates([np.column_stack([a, -a, b])], space), _motions(1),
                            noise_var=SIGMA2, floor_scaled=False, config=DesignConfig(directions=2))
    assert any("mass–force scale" in n and "--measured rod_mass" in n for n in out.notes)
    assert out.directions[0] == "+1.00 l" and out.directions[1] in ("+0.71 m −0.71 f", "+0.71 f −0.71 m")
    known = MeasurementPrior(space, (Measurement("m", 0.5, 0.01),))
    kept = suggest_recording(data, THETA, _candidates([np.column_stack([a, -a, b])], space), _motions(1),
                             noise_var=SIGMA2, floor_scaled=False, measurements=known,
                             config=DesignConfig(directions=1))
    assert not kept.notes and kept.directions[0] == "+1.00 l"


def test_mismatched_candidates_and_bad_settings_are_refused() -> None:
    A = np.eye(3)
    data = LinearObjective(A, A @ THETA)
    with pytest.raises(BeliefError, match="one segment per motion"):
        suggest_recording(data, THETA, _candidates([A, A]), _motions(3), noise_var=SIGMA2, floor_scaled=False)
    with pytest.raises(BeliefError, match="noise_var"):
        suggest_recording(data, THETA, _candidates([A]), _motions(1), noise_var=0.0, floor_scaled=False)
    with pytest.raises(BeliefError, match="directions"):
        DesignConfig(directions=0)
    with pytest.raises(BeliefError, match="step"):
        DesignConfig(step=0.5)


def test_the_local_stages_map_gives_back_the_information_it_was_built_from() -> None:
    """Identifiability.information() rebuilds F_x = T (JᵀJ/σ²) T from the map's directions, so the
    design reads what the local stage's P used."""
    rng = np.random.default_rng(3)
    J, space, theta = rng.normal(size=(50, 3)), unit_space(3), np.array([0.2, 0.5, 0.8])
    pin = identifiability(J, noise_var=SIGMA2, space=space, theta=theta, width=np.ones(3))
    T = np.diag(theta)
    assert pin.information() == pytest.approx(T @ J.T @ J @ T / SIGMA2, rel=1e-9, abs=1e-6)
