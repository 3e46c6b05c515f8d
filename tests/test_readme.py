"""The README's Python examples run as written and print what the README says they print."""

import contextlib
import io
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_has_python_examples():
    assert len(python_blocks()) >= 1


@pytest.mark.parametrize("index", range(len(python_blocks())))
def test_readme_example_runs_and_prints_what_it_claims(index):
    block = python_blocks()[index]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(block, f"README.md python block {index}", "exec"), {"__name__": "__readme__"})
    printed = out.getvalue().splitlines()
    # Every `print(...)  # ... 1.2345...` comment in the block states a number the output must start with.
    claims = [m.group(1) for m in re.finditer(r"print\(.*\)\s*#[^\n]*?(\d+\.\d+)\.\.\.", block)]
    assert claims, "a README example should state what it prints"
    for claim in claims:
        assert any(line.startswith(claim) for line in printed), (claim, printed)
