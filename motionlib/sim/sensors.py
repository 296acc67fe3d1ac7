"""The per-step sensor hook of the closed loop: sensors read the simulated crane before anyone acts.

A source of the summing junction that needs a measurement the controller's state does not hold (a
camera image of the target, a force/torque reading; 001 sections 2.4-2.5) gets it from a
*sensor*: any object with one method

``sense(sim) -> None``
    Called by :func:`~motionlib.sim.loop.run_closed_loop` (and so by
    :func:`~motionlib.sim.execute.execute`) once per control step with the simulated crane
    (:class:`~motionlib.sim.plant.SimulatedCrane`) at the step's time ``sim.t``, *before* the
    operator samples its stick and the controller acts. It reads the plant's true state (``sim.t``,
    ``sim.q``, ``sim.tip``, ``sim.grapple``, ...) and keeps what it measured for its source; it must
    not change the plant.

On a real machine the same sources read real sensors; the hook is the simulation's stand-in. The
sensors are called in the order given. With no sensor the loop's step costs nothing more (one
truth test of an empty tuple).

Sensors: :class:`~motionlib.sim.camera.SimulatedCamera` (the vision source's camera),
:class:`~motionlib.sim.sensors.ForceSensor` (the plant's contact force for the accommodation).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from ..control.accommodation import AccommodationSource
from ..errors import InputError

if TYPE_CHECKING:
    from .plant import SimulatedCrane


@runtime_checkable
class Sensor(Protocol):
    """What the closed loop calls each control step (module docstring)."""

    def sense(self, sim: SimulatedCrane) -> None:
        """Read the simulated crane ``sim`` at ``sim.t`` (s), before the operator and the controller act."""


def sense_calls(sensors: Iterable[Sensor] | None) -> tuple[Callable[[SimulatedCrane], None], ...]:
    """The bound ``sense`` methods of ``sensors``, checked; an empty tuple for None or none.

    Raises
    ------
    InputError
        An entry has no callable ``sense``.
    """
    if sensors is None:
        return ()
    if isinstance(sensors, str | bytes) or not isinstance(sensors, Iterable):
        raise InputError(f"sensors: expected a sequence of objects with sense(sim), got {type(sensors).__name__}")
    calls = []
    for i, s in enumerate(sensors):
        fn = getattr(s, "sense", None)
        if not callable(fn):
            raise InputError(f"sensors[{i}]: expected an object with a sense(sim) method, got {type(s).__name__}")
        calls.append(fn)
    return tuple(calls)


class ForceSensor:
    """The force sensor above the grapple: each step, the plant's contact force goes to ``source``.

    A sensor of the loop's hook (this module). It keeps the force's magnitude (N) of every step
    (:attr:`forces`) for the run's steady contact force (:meth:`steady`).
    """

    def __init__(self, source: AccommodationSource):
        self.source = source
        self.forces: list[float] = []
        self.t: list[float] = []

    def sense(self, sim: SimulatedCrane) -> None:
        f = sim.contact_force
        self.source.sense(f)
        self.forces.append(math.sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]))
        self.t.append(sim.t)

    def steady(self) -> tuple[float, float, float, float]:
        """The longest hold: median, 10th and 90th percentile of its force (N) in its second half, and its length (s).

        A hold is a stretch of steps in contact, a force above the source's ``contact_force_n`` (the
        guard's definition of contact). The median of its second half is the force the push settled
        at (the landing lies in the first half); a contact that bounces holds only briefly. Zeros
        without contact.
        """
        touching = np.concatenate(([False], np.asarray(self.forces) > self.source.contact_force_n, [False]))
        edges = np.flatnonzero(np.diff(touching.astype(np.int8)))  # starts and ends (exclusive) of the holds
        if edges.size == 0:
            return 0.0, 0.0, 0.0, 0.0
        starts, ends = edges[0::2], edges[1::2]
        k = int(np.argmax(ends - starts))
        first, end = int(starts[k]), int(ends[k])
        half = (first + end) // 2
        f = np.asarray(self.forces[half:end])
        median, p10, p90 = np.percentile(f, [50.0, 10.0, 90.0])
        return float(median), float(p10), float(p90), self.t[end - 1] - self.t[first]
