"""Shared output helpers of the CLI."""

from __future__ import annotations

import json
from typing import Any

import click

from motionlib.fileio import json_default


def emit_json(obj: Any) -> None:
    """Print one JSON object on stdout."""
    click.echo(json.dumps(obj, default=json_default))
