"""``motionlib live``: the server starts on a free port, serves the page, and stops cleanly on SIGINT and SIGTERM."""

from __future__ import annotations

import re
import signal
import socket
import subprocess
import sys
import urllib.request

import psutil
import pytest
from click.testing import CliRunner
from motionlib_cli.main import cli


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_live_serves_and_stops_on_a_signal(live_library, sig):
    proc = subprocess.Popen(
        [sys.executable, "-c", "from motionlib_cli.main import cli; cli()", "live", str(live_library), "--port", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    try:
        line = proc.stdout.readline()
        match = re.match(
            r"motionlib live: serving (http://127\.0\.0\.1:(\d+)/) \(4 motions of library live-demo, mode M6, "
            r"passive operator\); Ctrl\+C stops$",
            line.strip(),
        )
        assert match, line + proc.stderr.read() if proc.poll() is not None else line
        url, port = match.group(1), int(match.group(2))
        with urllib.request.urlopen(url, timeout=30) as response:
            assert response.status == 200 and b"<title>Viser</title>" in response.read()
        server = psutil.Process(proc.pid)
        threads, children = server.num_threads(), server.children(recursive=True)
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert out.strip() == "motionlib live: stopped after 0 motions" and err == ""
    assert threads > 1 and children == [] and not psutil.pid_exists(proc.pid)  # threads, no process
    with socket.socket() as s:
        assert s.connect_ex(("127.0.0.1", port)) != 0


def test_live_bad_input_is_one_line(tmp_path):
    missing = CliRunner().invoke(cli, ["live", str(tmp_path / "missing.h5"), "--port", "0"])
    assert missing.exit_code == 1 and missing.output.startswith("Error: ") and missing.output.count("\n") == 1
    bad_port = CliRunner().invoke(cli, ["live", str(tmp_path / "missing.h5"), "--port", "70000"])
    assert bad_port.exit_code == 2 and "--port" in bad_port.output and bad_port.output.count("\n") == 1
