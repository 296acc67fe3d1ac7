"""Shared output helpers of the CLI."""

from __future__ import annotations

import json
from typing import Any

import click

from motionlib.fileio import json_default, json_safe


def emit_json(obj: Any) -> None:
    """Print one JSON object on stdout (valid JSON: NaN and infinities as null)."""
    click.echo(json.dumps(json_safe(obj), default=json_default, allow_nan=False))
