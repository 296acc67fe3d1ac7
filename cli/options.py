"""Options and parameter types shared by the commands: ``--json``, ``--crane``, ``--scene``, vectors, modes.

Each is declared once here; a command module applies the decorators it needs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar

import click
import numpy as np

from motionlib.checks import COORDINATE_M, parse_csv_floats
from motionlib.control.control_types import Mode
from motionlib.errors import InputError

F = TypeVar("F", bound=Callable[..., Any])

CRANE_HELP = "Shipped crane name (lab, forwarder) or path to a crane .yaml file."
MODES = tuple(m.value for m in Mode)
#: Largest magnitude of a vector option's values (positions m, joint values rad or m): the numeric
#: limit of a scene coordinate (motionlib.checks.COORDINATE_M).
VECTOR_LIMIT = COORDINATE_M.hard_hi
#: Longest simulated time of a run (s): a 200 Hz log of an hour is 720,000 rows.
RUN_TIME_LIMIT_S = 3600.0


class FloatList(click.ParamType):
    """A click type for ``"a,b,c"``: a float64 vector of a fixed length.

    Negative first values work both as ``--q=-0.3,0.4,...`` and as ``--q -0.3,0.4,...``
    (click takes the next argument as the option's value even when it starts with ``-``).
    """

    name = "x,y,..."

    def __init__(self, size: int, label: str, limit: float = VECTOR_LIMIT):
        self.size = size
        self.label = label
        self.limit = limit

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> np.ndarray:
        if isinstance(value, np.ndarray):
            return value
        try:
            return parse_csv_floats(str(value), self.size, self.label, self.limit)
        except InputError as exc:
            self.fail(str(exc), param, ctx)


class FiniteFloatRange(click.FloatRange):
    """:class:`click.FloatRange` that also refuses NaN and infinities.

    NaN passes every comparison, so the plain range accepts ``nan`` for any bounds; use this
    type for every float option.
    """

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return super().convert(number, param, ctx)


def json_option(f: F) -> F:
    """``--json``: print one JSON object instead of text (parameter ``as_json``)."""
    return click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")(f)


def crane_option(default: str | None = "forwarder", extra_help: str = "") -> Callable[[F], F]:
    """``--crane NAME|FILE`` (parameter ``crane_name``)."""
    return click.option(
        "--crane", "crane_name", default=default, show_default=default is not None, help=CRANE_HELP + extra_help
    )


def scene_option(required: bool = True) -> Callable[[F], F]:
    """``--scene FILE`` (parameter ``scene_file``)."""
    return click.option(
        "--scene", "scene_file", required=required, type=click.Path(dir_okay=False), help="Scene file (YAML)."
    )


def vector_option(name: str, size: int, help: str, required: bool = False) -> Callable[[F], F]:
    """``--NAME a,b,...``: a vector of ``size`` finite numbers (parameter named after the option)."""
    return click.option(f"--{name}", name.replace("-", "_"), type=FloatList(size, f"--{name}"), required=required,
                        help=help)


def mode_option(f: F) -> F:
    """``--mode M1..M6`` (000 section 3.3; parameter ``mode``)."""
    return click.option(
        "--mode", default="M6", show_default=True, type=click.Choice(MODES, case_sensitive=False),
        help="M1-M3 joint operation, M4-M6 Cartesian; manual, traded, shared (000 section 3.3).",
    )(f)


def _check_operator(ctx: click.Context, param: click.Parameter, value: str) -> str:
    """The ``--operator`` spec, checked when the option is parsed: before the runtime and the library are loaded."""
    from motionlib.errors import InputError
    from motionlib.sim.operators import operator_kind

    try:
        operator_kind(value)
    except InputError as exc:
        raise click.BadParameter(str(exc).removeprefix("operator: "), ctx, param) from exc
    return value


def operator_option(f: F) -> F:
    """``--operator passive|novice|expert|FILE.csv`` (parameter ``operator_spec``), checked when parsed."""
    return click.option(
        "--operator", "operator_spec", default="passive", show_default=True, callback=_check_operator,
        help="passive, novice, expert, or a stick script (.csv, format in docs/runtime.md).",
    )(f)


def format_q(q: np.ndarray) -> str:
    """``q1=... rad, ..., q4=... m``."""
    return ", ".join(f"q{i + 1}={v:.6f} {'m' if i == 3 else 'rad'}" for i, v in enumerate(q))
