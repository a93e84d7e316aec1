"""physics re-exports lazily: belief and embeddings load without the simulator (dartpy, numba kernels)."""
from __future__ import annotations

import subprocess
import sys

HEAVY = ("dartpy", "physics.tensegrity", "physics.cables", "physics.actuators", "physics.predictor", "physics.trajectory_objective")


def _run(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_belief_and_embeddings_do_not_import_the_simulator():
    out = _run("import belief, embeddings; import sys; print('dartpy' in sys.modules); "
               f"import physics.parameters, physics.objective; print([m for m in {HEAVY!r} if m in sys.modules])")
    assert out.splitlines() == ["False", "[]"]


def test_public_names_resolve_on_first_use():
    out = _run("import sys, physics; assert 'dartpy' not in sys.modules; "
               "from physics import TrajectoryObjective, BatchResult, simulate; import physics.simulation; "
               "print(TrajectoryObjective.__module__, BatchResult.__module__, physics.simulate is simulate, "
               "callable(simulate), 'dartpy' in sys.modules, set(physics.__all__) <= set(dir(physics)))")
    assert out == "physics.trajectory_objective physics.objective True True True True"


def test_every_public_name_exists():
    import physics
    missing = [name for name in physics.__all__ if not hasattr(physics, name)]
    assert not missing
    assert sorted(physics.__all__) == sorted(physics._ORIGIN)
    try:
        physics.no_such_name  # noqa: B018
    except AttributeError as exc:
        assert "no_such_name" in str(exc)
    else:  # pragma: no cover
        raise AssertionError("physics.no_such_name should raise AttributeError")
