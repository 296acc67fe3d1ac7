"""A fixed, seeded sample of the reader fuzzing of ``benchmarks/fuzz.py`` (issue 13).

The mutators, the readers' use of each file and the independent range check live in the
benchmark script, imported here, so the test and the 10^6-input benchmark run the same
code. Every reader gets its share of a few thousand mutated inputs through the API (no
exception other than :class:`motionlib.errors.MotionlibError`, no accepted file outside the
documented ranges), and a smaller sample goes through the CLI commands that open the file
(`crane show`, `scene check`, `view`, `inspect`, `select`, `execute --operator`, `analyze`: one
line on error, never a traceback, never the "bug" exit status 70; spec files only through the
API, as `build` would plan an accepted one).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from motionlib_cli.main import cli

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import fuzz  # noqa: E402

SEED = 20261123  # fixed: the sample is the same on every run
#: Inputs per reader through the API (about 2,600 in all; the slower HDF5 readers get fewer).
N_API = {"crane": 500, "scene": 400, "spec": 300, "script": 500, "plan": 250, "library": 250, "runlog": 300,
         "checkpoint": 100, "commands": 300, "gaze": 300}
N_CLI = 25  # per command below


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory):
    return fuzz.make_fixtures(tmp_path_factory.mktemp("fuzz-fixtures"))


@pytest.fixture(scope="module")
def readers(fixtures):
    return fuzz.make_readers(fixtures)


@pytest.mark.parametrize("name", list(N_API))
def test_fuzzed_files_give_package_errors_only(readers, name, tmp_path):
    index = list(readers).index(name)
    result = fuzz.run_cases(readers[name], index, SEED, range(N_API[name]), tmp_path)
    counts = result["counts"]
    assert counts["exception"] == 0 and counts["violation"] == 0, result["examples"]
    assert sum(counts.values()) == N_API[name]
    # The sample must exercise both sides: mostly clean errors, some accepted files.
    assert counts["clean"] > N_API[name] // 2 and counts["accepted"] > 0, counts


#: Inputs the benchmark found to be mishandled, kept as a regression set: (reader, seed, input), each read as
#: ``python benchmarks/fuzz.py --seed SEED --reproduce READER:INPUT`` writes it (the mutation is a pure function of
#: the three); the tests of the fixes state each case independently of the mutators.
FOUND = [
    ("spec", 11, 4688),  # max_checks of 400 digits: OverflowError formatting the message (test_library_spec.py)
    ("plan", 11, 5298),  # the last spline breakpoint at 1e6 m: read, extrapolated (test_sealed_files.py)
    ("checkpoint", 12, 323),  # invalid UTF-8 in 'stage': kept, the library's write failed (test_sealed_files.py)
    ("checkpoint", 12, 952),  # the same in 'reason'
]


@pytest.mark.parametrize(("name", "seed", "case"), FOUND, ids=[f"{n}-{s}-{c}" for n, s, c in FOUND])
def test_inputs_the_benchmark_found_are_refused_cleanly(readers, name, seed, case, tmp_path):
    index = list(readers).index(name)
    result = fuzz.run_cases(readers[name], index, seed, range(case, case + 1), tmp_path)
    assert result["counts"]["clean"] == 1, result["examples"]


def test_range_check_catches_an_implausible_crane():
    """The independent check is not vacuous: a 10 km boom on a copy of a loaded crane is reported."""
    import copy
    from types import SimpleNamespace

    from motionlib.model.kinematics import Crane

    model = copy.copy(Crane.load("lab").model)
    assert fuzz.range_violations("crane", SimpleNamespace(model=model)) == []
    object.__setattr__(model, "boom_length", 1.0e4)  # past the reader, which would refuse it
    assert any("boom_length" in v for v in fuzz.range_violations("crane", SimpleNamespace(model=model)))


# Commands that open each kind of file; {} is the fuzzed file, {out} a scratch directory, {lib}
# the (good) fixture library. The target 0,3,0.9 is the end point of its first trajectory.
COMMANDS = {
    "crane": ["crane", "show", "--crane", "{}", "--json"],
    "scene": ["scene", "check", "{}", "--json"],
    "plan": ["view", "{}", "-o", "{out}/plan.html"],
    "library": ["inspect", "{}", "--json"],
    "library-select": ["select", "{}", "--target", "0,3,0.9", "--json"],
    "script": ["execute", "{lib}", "--target", "0,3,0.9", "--operator", "{}", "--time-limit", "1", "--json"],
    "runlog": ["analyze", "{}", "--crane", "lab"],
}


@pytest.mark.parametrize("command", list(COMMANDS))
def test_cli_never_prints_a_traceback_for_fuzzed_files(readers, fixtures, command, tmp_path):
    name = command.split("-")[0]
    reader, index = readers[name], list(readers).index(name)
    runner = CliRunner()
    codes = set()
    for i in range(N_CLI if name != "script" else 10):
        path = reader.make(SEED + 1, index, i, tmp_path)
        args = [a.replace("{}", str(path)).replace("{out}", str(tmp_path)).replace("{lib}", str(fixtures.library))
                for a in COMMANDS[command]]
        result = runner.invoke(cli, args)
        assert "Traceback" not in result.output, (args, result.output)
        assert result.exit_code != 70, (i, result.output)  # 70: the last line of defence caught a bug
        assert result.exception is None or isinstance(result.exception, SystemExit), (i, result.exception)
        if result.exit_code != 0:
            assert len(result.stderr.strip().splitlines()) == 1, (i, result.stderr)
        codes.add(result.exit_code)
    assert codes - {0}, "no fuzzed input was rejected: the sample does not exercise the reader"
    assert 0 in codes, "no fuzzed input was accepted: the command never got past the reader"
