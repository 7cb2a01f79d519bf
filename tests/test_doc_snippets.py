"""Every Python snippet of the docs that shows its output is run as it stands, and prints
that output: numbers to the precision printed (docs/python-api.md §3 left out two arguments,
and printed 161.8045 GPa and 40.7500 Hz where a reader got 161.789 GPa and 40.748 Hz).

A snippet is a ```python block followed directly by an output block (``` without a
language); it runs in a fresh interpreter in an empty folder where ``examples/`` is the
repository's, as a reader runs it from the repository folder. Each takes 1–5 s (load 9: the
six 22 s in all), so all run in the default suite."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ("docs/python-api.md", "README.md")
NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?(?![\w.])")
FENCE = re.compile(r"^```(\w*)\n(.*?)^```[ \t]*$", re.S | re.M)


def snippets() -> list:
    """(code, documented output) of each ```python block directly followed by an output block."""
    found = []
    for doc in DOCS:
        text = (ROOT / doc).read_text()
        blocks = list(FENCE.finditer(text))
        for block, after in zip(blocks, blocks[1:]):
            if block[1] != "python" or after[1] or text[block.end():after.start()].strip():
                continue
            heading = ([line for line in text[:block.start()].splitlines() if line.startswith("#")] or [doc])[-1]
            name = f"{doc} {heading.lstrip('# ').split(' — ')[0]}"
            found.append(pytest.param(block[2], after[2], id=name))
    return found


def shape(text: str) -> tuple[list[str], list[float]]:
    """The text with every number replaced by #, and the numbers (lines right-stripped)."""
    lines = [line.rstrip() for line in text.strip("\n").splitlines()]
    joined = "\n".join(lines)
    return NUMBER.sub("#", joined).splitlines(), [float(n) for n in NUMBER.findall(joined)]


def test_the_docs_have_snippets_with_output():
    assert len(snippets()) >= 6  # the six tutorials of docs/python-api.md


@pytest.mark.parametrize("code, documented", snippets())
def test_snippet_prints_what_the_docs_show(code, documented, tmp_path):
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    text, numbers = shape(run.stdout)
    want_text, want_numbers = shape(documented)
    assert text == want_text, f"printed:\n{run.stdout}\ndocumented:\n{documented}"
    # the same numbers as printed: a value the docs round differently is a wrong number in the docs
    assert numbers == want_numbers, f"printed:\n{run.stdout}\ndocumented:\n{documented}"


def test_shape_tells_numbers_from_text():
    assert shape("E = 161.8045 GPa, f1 46.42 → 40.7500 Hz\n") == (["E = # GPa, f1 # → # Hz"], [161.8045, 46.42, 40.75])
    assert shape("k3 = 1.004e+10 ± 3.3e+07") != shape("k3 = 1.003e+10 ± 3.3e+07")
