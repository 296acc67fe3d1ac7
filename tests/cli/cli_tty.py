"""Run the command line with stderr on a pseudo-terminal (what a user at a terminal sees) and stdout on a pipe."""

from __future__ import annotations

import os
import pty
import re
import subprocess
import sys


def run_on_tty(*args: str, timeout: float = 300.0) -> tuple[int, str, str]:
    """``motionlib ARGS`` with stderr on a pty: (exit code, stdout, what the terminal received, escapes removed)."""
    master, slave = pty.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-c", "from motionlib_cli.main import cli; cli()", *args],
        stdout=subprocess.PIPE,
        stderr=slave,
        stdin=subprocess.DEVNULL,
    )
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    out = proc.stdout.read().decode() if proc.stdout is not None else ""
    code = proc.wait(timeout=timeout)
    os.close(master)
    return code, out, re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", b"".join(chunks).decode(errors="replace"))
