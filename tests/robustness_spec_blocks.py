"""Robustness specifications of the state blocks (``uwtutor.models.blocks``) and the clock-drift ranges
(``uwtutor.models.clock``): each block is built, stacked in a :class:`~uwtutor.models.blocks.BlockMotion` and used
once (``f, F, Q``); each measurement model is built on a block state and used once (``h, H, R``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from robustness_kinds import Hostile, Instance, Kind, Real
from robustness_spec import Spec
from robustness_spec_struct import _meas_use, _motion_use

_NONNEG = Real((), "nonneg")


@dataclass(frozen=True)
class _SlotName(Kind):
    """The name of a slot: an identifier. ``optional``: None is the documented default (no such slot)."""
    optional: bool = False

    def hostile(self, valid: Any) -> list[Hostile]:
        out = [Hostile("not an identifier", "no such-slot", True), Hostile("empty", "", True),
               Hostile("int", 1, True), Hostile("list", [valid], True)]
        if not self.optional:
            out.append(Hostile("None", None, True))
        return out


@dataclass(frozen=True)
class _SlotNames(Kind):
    """The names of the further slots of a state: a sequence of identifiers (or a dict of name -> size) that
    names every further component once; None is the documented default (names by index)."""

    def hostile(self, valid: Any) -> list[Hostile]:
        return [Hostile("a string", "range_bias", True), Hostile("not an identifier", ("range bias",), True),
                Hostile("empty name", ("",), True), Hostile("int", (1,), True), Hostile("too many", ("a", "b"), True),
                Hostile("too few", (), True), Hostile("size 0", {"range_bias": 0}, True),
                Hostile("size not an int", {"range_bias": 1.5}, True), Hostile("the position's name", ("position",),
                                                                                True),
                Hostile("not a sequence", 3, True)]


def _blocks():
    import uwtutor.models.blocks as b
    return b


def _in_motion(block_fn, x, u=None, **motion_kw):
    """A ``call``: build one block from the keyword arguments, stack it (with the blocks it reads), use it once."""
    def call(**kw):
        b = _blocks()
        blocks = block_fn(b, kw)
        return _motion_use(b.BlockMotion(*blocks, **motion_kw), x=x, u=u)
    return call


def _state():
    b = _blocks()
    return b.BlockMotion(b.OdometryPose(0.02, 1e-3), b.RandomWalk("scale", 1e-5),
                         b.OffsetAndRate("clock", rate_walk=1e-8), dt=1.0)


def _dead_reckoning():
    return __import__("uwtutor.models", fromlist=["x"]).DeadReckoning(np.diag([0.25, 0.25, 0.01]),
                                                                      names=("range_bias",))


_BEACONS = np.array([[5.0, 12.0], [-4.0, 3.0]])
_X = [1.0, 2.0, 0.3, 1.05, 1e-3, 2e-5]

SPECS_BLOCKS: dict[str, Spec] = {
    "uwtutor.models.blocks:OdometryPose": Spec(
        lambda: dict(sigma_distance=0.02, sigma_heading=1e-3, order="midpoint", gyro_bias="gyro_bias", name="pose"),
        kinds=dict(sigma_distance=Real((), "nonneg", vector_ok=True), sigma_heading=Real((), "nonneg",
                                                                                         vector_ok=True),
                   gyro_bias=_SlotName(optional=True), name=_SlotName()),
        call=_in_motion(lambda b, kw: (b.OdometryPose(**kw), b.RandomWalk("gyro_bias", 1e-4)),
                        x=[1.0, 2.0, 0.3, 1e-3], u=np.array([[1.0, 0.1]]), dt=1.0)),
    "uwtutor.models.blocks:Position": Spec(
        lambda: dict(Q=np.eye(2) * 0.25, current="current", name="position"),
        kinds=dict(current=_SlotName(optional=True), name=_SlotName()),
        call=_in_motion(lambda b, kw: (b.Position(**kw), b.Current(1e-3)), x=[1.0, 2.0, 0.1, 0.0],
                        u=np.array([[1.0, 0.5]]), dt=2.0)),
    "uwtutor.models.blocks:RandomWalk": Spec(
        lambda: dict(name="scale", walk=0.0, size=2, Q=np.eye(2) * 1e-4),
        kinds=dict(name=_SlotName(), walk=_NONNEG, size=Kind()),
        call=_in_motion(lambda b, kw: (b.RandomWalk(**kw),), x=[1.0, 1.0], dt=1.0)),
    "uwtutor.models.blocks:Current": Spec(
        lambda: dict(walk=1e-3, name="current"), kinds=dict(walk=_NONNEG, name=_SlotName()),
        call=_in_motion(lambda b, kw: (b.Current(**kw),), x=[0.1, 0.0], dt=1.0)),
    "uwtutor.models.blocks:OffsetAndRate": Spec(
        lambda: dict(name="clock", rate_walk=1e-8, offset_walk=1e-6),
        kinds=dict(name=_SlotName(), rate_walk=_NONNEG, offset_walk=_NONNEG),
        call=_in_motion(lambda b, kw: (b.OffsetAndRate(**kw),), x=[1e-3, 2e-5], dt=1.0)),
    "uwtutor.models.blocks:BlockMotion": Spec(
        lambda: dict(dt=1.0, times=None),
        kinds=dict(dt=Real((), "nonneg", vector_ok=True, optional=True), times=Kind()),
        call=lambda **kw: _motion_use(_blocks().BlockMotion(
            _blocks().OdometryPose(0.02, 1e-3), _blocks().OffsetAndRate("clock", 1e-8), **kw),
            x=[1.0, 2.0, 0.3, 1e-3, 2e-5], u=np.array([[1.0, 0.1]]))),
    "uwtutor.models.dead_reckoning:DeadReckoning": Spec(
        lambda: dict(Q=np.diag([0.25, 0.25, 0.01]), names=("range_bias",)), kinds=dict(names=_SlotNames()),
        call=lambda **kw: _motion_use(__import__("uwtutor.models.dead_reckoning", fromlist=["x"]).DeadReckoning(**kw),
                                      x=[1.0, 2.0, 0.5], u=np.array([[1.0, 0.5]]))),
    "uwtutor.models.range:RangeToBeacon": Spec(
        lambda: dict(beacon=(0.0, 0.0), R=1.0, state=_dead_reckoning(), bias="range_bias", position="position"),
        kinds=dict(state=Instance(optional=True), bias=_SlotName(optional=True), position=_SlotName()),
        call=lambda **kw: _meas_use(__import__("uwtutor.models.range", fromlist=["x"]).RangeToBeacon(**kw),
                                    x=[3.0, 4.0, 0.5])),
    "uwtutor.models.range:BlockRanges": Spec(
        lambda: dict(beacons=_BEACONS, R=0.36, state=_state(), scale="scale", bias=None, position="position"),
        kinds=dict(beacons=Real((None, 2)), R=Real((), "pos", vector_ok=True), state=Instance(),
                   scale=_SlotName(optional=True), bias=_SlotName(optional=True), position=_SlotName()),
        call=lambda **kw: _meas_use(__import__("uwtutor.models.range", fromlist=["x"]).BlockRanges(**kw), x=_X)),
    "uwtutor.models.clock:OneWayTravelTimeRanges": Spec(
        lambda: dict(beacons=_BEACONS, R=0.36, state=_state(), sound_speed=1500.0, slots=None, scale="scale"),
        kinds=dict(beacons=Real((None, 2)), R=Real((), "pos", vector_ok=True), state=Instance(),
                   sound_speed=Real((), "pos"), slots=Kind(), scale=_SlotName(optional=True)),
        call=lambda **kw: _meas_use(__import__("uwtutor.models.clock", fromlist=["x"]).OneWayTravelTimeRanges(**kw),
                                    x=_X)),
}

EXEMPT_BLOCKS: dict[str, str] = {
    "uwtutor.models.blocks:StateBlock": "an abstract base class, built with no argument; what a subclass returns is "
                                        "assembled and checked by BlockMotion's model contract "
                                        "(tests/test_model_contract.py)",
    "uwtutor.models.blocks:BlockMeasurement": "an abstract base class (no h): its state and slots arguments are "
                                              "specified through BlockRanges and OneWayTravelTimeRanges, which "
                                              "pass them on",
}
