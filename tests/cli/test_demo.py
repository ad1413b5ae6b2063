"""``uss demo``: the examples it builds are byte-exact with the shared vectors, and it runs."""

from __future__ import annotations

import pytest

from conftest import load_vectors
from pyuss.cli.demo import EXAMPLES, Example
from pyuss.cli.main import main

BY_NAME = {v["name"]: v for v in load_vectors("uss")["telegrams"]}


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.name for e in EXAMPLES])
def test_demo_example_matches_the_vector(example: Example) -> None:
    vec = BY_NAME[example.name]
    raw = example.build().encode()
    assert raw.hex(" ").upper() == vec["hex"]


def test_demo_runs(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    for example in EXAMPLES:
        assert example.title in out
    assert "fault NO_STX: first character after the start pause is 41h" in out
    assert "fault BCC: BCC is AAh, expected 55h" in out
    assert out.count("-> received telegram for address 5") == 2
