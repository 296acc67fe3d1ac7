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

from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Protocol, runtime_checkable

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

    A sensor of the loop's hook (this module).
    """

    def __init__(self, source: AccommodationSource):
        self.source = source

    def sense(self, sim: SimulatedCrane) -> None:
        self.source.sense(sim.contact_force)
