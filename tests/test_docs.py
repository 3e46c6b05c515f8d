"""Every public function, class and method of the library has a numpydoc docstring.

Public: a name without a leading underscore, at module level or in a public class. Every one has a
docstring; a function or method that takes parameters (besides ``self``/``cls``) has a ``Parameters``
section, and one that returns a value a ``Returns`` (or ``Yields``) section. Exempt: the click commands
in ``coexist/cli`` (their docstring is the command's help, their parameters are its options, documented
by ``--help``) and properties (their docstring describes the value).
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "coexist"


def _own_returns(fn: ast.FunctionDef) -> bool:
    """Whether ``fn`` itself (not a function nested in it) returns or yields a value."""
    stack = list(ast.iter_child_nodes(fn))
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
            continue
        if isinstance(node, (ast.Yield, ast.YieldFrom)):
            return True
        if (
            isinstance(node, ast.Return)
            and node.value is not None
            and not (isinstance(node.value, ast.Constant) and node.value.value is None)
        ):
            return True
        stack.extend(ast.iter_child_nodes(node))
    return False


def _problems(path: Path, root: Path = PACKAGE) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    cli = "cli" in path.relative_to(root).parts
    out: list[str] = []

    def visit(node, prefix=""):
        for child in ast.iter_child_nodes(node):
            if not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                continue
            if child.name.startswith("_"):
                continue
            where = f"{path.relative_to(root.parent)}:{child.lineno} {prefix}{child.name}"
            doc = ast.get_docstring(child)
            if not doc:
                out.append(f"{where}: no docstring")
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                decorators = {getattr(d, "id", getattr(d, "attr", "")) for d in child.decorator_list}
                if cli or decorators & {"property", "cached_property", "setter"}:
                    continue
                params = [a.arg for a in child.args.posonlyargs + child.args.args + child.args.kwonlyargs]
                params = [p for p in params if p not in ("self", "cls")]
                if child.args.vararg:
                    params.append("*" + child.args.vararg.arg)
                if params and "Parameters\n" not in doc:
                    out.append(f"{where}: no Parameters section ({', '.join(params)})")
                if _own_returns(child) and "Returns\n" not in doc and "Yields\n" not in doc:
                    out.append(f"{where}: no Returns section")
            if isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")

    visit(tree)
    return out


MODULES = sorted(p for p in PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=[str(p.relative_to(PACKAGE)) for p in MODULES])
def test_public_api_has_numpydoc(path):
    problems = _problems(path)
    assert not problems, "\n".join(problems)


def test_the_checker_finds_what_it_should(tmp_path):
    """The checker itself can fail: a module with an undocumented function, a function without its
    Parameters section and one without its Returns section gives three problems."""
    sample = tmp_path / "sample.py"
    sample.write_text(
        "def a(x):\n    return x\n\n"
        'def b(x):\n    """B.\n\n    Returns\n    -------\n    int\n    """\n    return x\n\n'
        'def c(x):\n    """C.\n\n    Parameters\n    ----------\n    x : int\n    """\n    return x\n\n'
        "def _private(x):\n    return x\n",
        encoding="utf-8",
    )
    problems = _problems(sample, tmp_path)
    assert len(problems) == 3, problems
    assert any("a: no docstring" in p for p in problems)
    assert any("b: no Parameters" in p for p in problems)
    assert any("c: no Returns" in p for p in problems)
