"""``motionlib dual``: the dual-crane scenario from the command line, its figures, its view and bad input."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner
from motionlib_cli.main import cli

SCENARIO = str(Path(__file__).resolve().parents[2] / "scenarios" / "dual-lab.yaml")


def test_dual_reports_json_figures_and_view(tmp_path):
    view = tmp_path / "dual.html"
    res = CliRunner().invoke(cli, ["dual", SCENARIO, "--json", "--check", "--plot", str(tmp_path / "fig"),
                                   "--view", str(view)])
    assert res.exit_code == 0, res.output
    report = json.loads(res.output)
    assert report["status"] == "within_bounds" and report["accommodation"] is True
    assert report["peak_squeeze_n"] < report["force_bound_n"]
    assert [Path(p).name for p in report["plots"]] == ["internal_force.png", "tracking.png"]
    assert all(Path(p).stat().st_size > 10_000 for p in report["plots"])
    html = view.read_text(encoding="utf-8")
    assert "plotly" in html and "arm B" in html and '"log"' in html
    assert not list(tmp_path.glob("*.tmp*"))


def test_dual_without_accommodation_fails_the_check_in_one_line(tmp_path):
    res = CliRunner().invoke(cli, ["dual", SCENARIO, "--no-accommodation", "--check"])
    assert res.exit_code == 1
    lines = res.output.strip().splitlines()
    assert lines[0].startswith("dual-lab: accommodation off, force_exceeded")
    assert lines[-1].startswith("Error: internal force") and "Traceback" not in res.output


def test_dual_rejects_a_bad_scenario_without_a_traceback(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\ncranes: []\n", encoding="utf-8")
    res = CliRunner().invoke(cli, ["dual", str(bad)])
    assert res.exit_code == 1
    assert res.output.startswith("Error: ") and "bad.yaml" in res.output and "Traceback" not in res.output
