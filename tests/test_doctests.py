"""The examples in the library's docstrings run and print what they show.

Each module of the *imported* package (the installed one in CI, the checkout in an editable install) is
run through :func:`doctest.testmod`; a module whose examples fail fails here, with doctest's report.
"""

import doctest
import importlib
import io
import pkgutil
from contextlib import redirect_stdout

import pytest

import coexist

MODULES = sorted(m.name for m in pkgutil.walk_packages(coexist.__path__, "coexist.") if not m.name.endswith("__main__"))


def test_every_module_is_found():
    assert {"coexist.shooting", "coexist.numerics.roots", "coexist.cli.main", "coexist.studies.accuracy"} <= set(
        MODULES
    )


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    report = io.StringIO()
    with redirect_stdout(report):
        result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, report=True)
    assert result.failed == 0, report.getvalue()


def test_there_are_examples_to_run():
    """At least a dozen examples across the library (so that this file cannot pass by finding none)."""
    finder = doctest.DocTestFinder()
    examples = sum(
        len(t.examples) for name in MODULES for t in finder.find(importlib.import_module(name)) if t.examples
    )
    assert examples >= 12, examples
