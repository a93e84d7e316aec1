"""Effects: physical effects the T6 model can include, as composable parts of the model.

An :class:`Effect` declares its parameters (:class:`~physics.parameters.Parameter`: name, unit,
bounds; ``nominal`` is the value that switches the effect off when one exists, see
:attr:`Effect.off`) and one hook, :meth:`Effect.apply`, that edits the :class:`ModelSetup` of a
model before its world is built. Through the setup an effect may

- change the world's setup: the gravity vector (a tilted ground), the contact radius of the end
  caps and their shape (``cap_length`` 0: spheres at the nodes; > 0: cylinders of that length
  ending at the nodes), point masses on rods;
- add forces each physics step: ``force_terms``, kernels ``f(nodes, velocities, out)`` that add
  node forces (12 x 3) [N]; ``wrench_terms``, kernels ``f(q, dq, out)`` that add the rods'
  generalised forces (36,) (torques about a rod's own axis, which node forces cannot carry);
  both run after the model has written this step's node-cable tensions into ``tension`` (24,)
  [N], so a term may read them (cable anchors re-route them); ``contact_terms``, wrench kernels
  that run after all of those, so that ``out`` then holds the rods' whole applied wrench (cables
  and every effect's forces; gravity and contact excluded): laws that depend on the load a rod
  puts on the ground (rolling resistance);
- change the rods' spin: ``spin_damping`` (the axial damper [N m s], applied as given; None keeps
  the model's option times its mass scale, physics.scaling.rod_mass_scale) and ``orient``, which
  turns rods placed from nodes about their own axes (q (36,) -> q);
- replace a component: the cable law's coefficients (``cable``), the actuator (``actuator``),
  the delay between a command and the actuator seeing it (``command_delay``), an offset (24,)
  [m] added to every command (``command_offset``);
- transform observations: ``observation_offset`` (3,) [m], added to every observed node.

A model built from the T6 and effects e_1..e_m has the parameter space
θ = (15 T6 parameters, parameters of e_1, ..., parameters of e_m) (:func:`model_space`).
"""
from __future__ import annotations

import abc
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from physics.actuators import Actuator, MotorActuator, MotorGains
from physics.cables import CableLaw
from physics.errors import ParameterError
from physics.parameters import Parameter, ParameterSpace

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["Effect", "ModelSetup", "ForceTerm", "WrenchTerm", "model_space", "split_theta"]

#: f(nodes (12 x 3) [m], velocities (12 x 3) [m/s], out (12 x 3) [N]): add node forces into ``out``.
ForceTerm = Callable[[np.ndarray, np.ndarray, np.ndarray], None]
#: f(q (36,), dq (36,), out (36,)): add FreeJoint generalised forces (per rod: world torque about its
#: centre [N m], world force [N]) into ``out``, from FreeJoint positions and velocities.
WrenchTerm = Callable[[np.ndarray, np.ndarray, np.ndarray], None]


@dataclass
class ModelSetup:
    """Everything an effect may change, read by :class:`physics.tensegrity.T6Model` when it builds
    and steps its world. Shapes: gravity (3,) [m/s²], observation_offset (3,) [m]; point_masses
    holds (rod index, mass [kg], position along the rod axis from its centre [m]); ground_normal
    (3,) the unit normal of the ground plane through the world origin (z up, the data contract's
    world frame: a sloped floor tilts the plane, gravity stays along −z); tension (24,) [N]: the
    node cables' tensions, which the model writes in place each step before the force and wrench
    terms run (read them there, never replace the array); gains: the motor driver's gains as the
    model applies them (K_v times the mass scale, ModelOptions.motor_at)."""

    gravity: np.ndarray
    cap_radius: float
    cable: CableLaw
    actuator: Actuator
    gains: MotorGains
    dt: float
    command_delay: float = 0.0
    command_offset: np.ndarray = field(default_factory=lambda: np.zeros(24))
    point_masses: list[tuple[int, float, float]] = field(default_factory=list)
    force_terms: list[ForceTerm] = field(default_factory=list)
    wrench_terms: list[WrenchTerm] = field(default_factory=list)
    contact_terms: list[WrenchTerm] = field(default_factory=list)
    cap_length: float = 0.0
    spin_damping: float | None = None
    orient: Callable[[np.ndarray], np.ndarray] | None = None
    observation_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ground_normal: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    tension: np.ndarray = field(default_factory=lambda: np.zeros(24))

    @classmethod
    def base(cls, params: Mapping[str, float], gravity: float, gains: MotorGains, dt: float) -> ModelSetup:
        """The T6 without effects: vertical gravity, caps of radius ``radius``, linear cables, motors."""
        return cls(gravity=np.array([0.0, 0.0, -gravity]), cap_radius=float(params["radius"]),
                   cable=CableLaw(float(params["stiffnessActive"]), float(params["damping"])),
                   actuator=MotorActuator(params, gains, dt), gains=gains, dt=float(dt))


class Effect(abc.ABC):
    """A physical effect: parameters and a hook that edits a :class:`ModelSetup` (an abstract base
    class: the contract every effect of a model and of model criticism fulfils).

    Subclasses set ``name`` (unique in a model), ``description`` and ``switchable`` (False for an
    effect that replaces a component: no parameter value turns it off, only leaving it out does),
    and implement :meth:`parameters` and :meth:`apply`. Options that are not identified (which rod
    carries a point mass) are constructor arguments and appear in :meth:`config`, so that
    ``effect_from_config(effect.config()) == effect`` (:mod:`physics.effects.catalog`).
    """

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    switchable: ClassVar[bool] = True
    #: names of the effects this one makes redundant: they change the component it replaces
    replaces: ClassVar[frozenset[str]] = frozenset()
    #: T6 parameters the model no longer reads once this effect is in it (a model holds them fixed)
    inert: ClassVar[tuple[str, ...]] = ()

    @abc.abstractmethod
    def parameters(self) -> tuple[Parameter, ...]:
        """The effect's identified parameters, in the order they extend θ (:func:`model_space`)."""

    @abc.abstractmethod
    def apply(self, setup: ModelSetup, values: Mapping[str, float], params: Mapping[str, float]) -> None:
        """Edit ``setup`` for the effect's parameter ``values`` (by name) at the T6 parameters ``params``."""

    @property
    def off(self) -> dict[str, float] | None:
        """Parameter values that make the model equal to the model without the effect, or None."""
        return {p.name: p.nominal for p in self.parameters()} if self.switchable else None

    def start(self, trajectories: Sequence[xr.Dataset]) -> dict[str, float]:
        """Where a fit of the effect's parameters starts on these observed trajectories: values the
        data show directly (a floor's tilt at rest), else the nominal ones; always inside the box."""
        return {p.name: p.nominal for p in self.parameters()}

    def placements(self) -> tuple[Effect, ...]:
        """Where the effect could sit when the data must tell (an unplaced point mass: one per rod
        and end); criticism screens each and keeps the best, charged for the choice
        (criticism.search). Most effects have one placement, themselves."""
        return (self,)

    def bind(self, trajectories: Sequence[xr.Dataset]) -> Effect:
        """The effect as these observed trajectories determine it, before any fit. Most effects
        return themselves; one whose size the data show directly (a floor's tilt, at rest) returns
        a copy whose parameters may move only within what that measurement allows."""
        return self

    @property
    def evident(self) -> bool:
        """Whether the effect, as bound (:meth:`bind`), shows in the data beyond doubt without any fit
        of the dynamics (a floor tilted by degrees at rest, which no other part of the model can
        make): diagnose then adds it before identifying instead of searching for it. False for most."""
        return False

    def config(self) -> dict:
        """A JSON-able description: the effect's name and its options."""
        return {"effect": self.name}

    def __repr__(self) -> str:
        options = {k: v for k, v in self.config().items() if k != "effect"}
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in options.items())})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Effect) and self.config() == other.config()

    def __hash__(self) -> int:
        return hash(repr(sorted(self.config().items())))


def model_space(effects: Sequence[Effect] = (), base: ParameterSpace | None = None) -> ParameterSpace:
    """The parameter space of the T6 plus ``effects``: base parameters first, then each effect's."""
    base = base or ParameterSpace.t6()
    params = list(base.parameters)
    names = set(base.names)
    seen: set[str] = set()
    for effect in effects:
        if not isinstance(effect, Effect):
            raise ParameterError(f"effects must be physics.effects.Effect instances, got {type(effect).__name__}.")
        if effect.name in seen:
            raise ParameterError(f"effect {effect.name!r} is listed twice; each effect may appear once in a model.")
        seen.add(effect.name)
        for p in effect.parameters():
            if p.name in names:
                raise ParameterError(f"effect {effect.name!r} declares parameter {p.name!r}, which the model "
                                     "already has; rename it.")
            names.add(p.name)
            params.append(p)
    return ParameterSpace(tuple(params))


def split_theta(theta: np.ndarray, space: ParameterSpace, effects: Sequence[Effect],
                n_base: int) -> tuple[dict[str, float], list[dict[str, float]]]:
    """θ (D,) -> (T6 parameters by name, one dict of parameter values per effect)."""
    values = dict(zip(space.names, np.asarray(theta, float).tolist(), strict=True))
    base = {n: values[n] for n in space.names[:n_base]}
    return base, [{p.name: values[p.name] for p in e.parameters()} for e in effects]
