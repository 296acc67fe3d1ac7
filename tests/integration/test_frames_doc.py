"""docs/frames-and-sources.md: every worked example runs as written and checks its own result."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

PAGE = Path(__file__).resolve().parents[2] / "docs" / "frames-and-sources.md"
EXAMPLES = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)


def test_page_has_one_example_per_piece():
    assert len(EXAMPLES) == 4


@pytest.mark.parametrize("index", range(len(EXAMPLES)), ids=["frames", "vision", "accommodation", "dual"])
def test_worked_example_runs(index):
    exec(compile(EXAMPLES[index], f"{PAGE}:example{index + 1}", "exec"), {"__name__": "__doc_example__"})
