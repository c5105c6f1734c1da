"""The architecture of issue 18, checked on the source:

* the import-linter contracts in pyproject.toml (``lint-imports``): the layers core <- scene <-
  render <- mr <- eval <- apps <- cli, nothing imports the command line, mrcheck imports the
  scene generator (factory_scenes) only from the command line;
* no module uses another module's private (underscore) names, by import or as an attribute
  (of anything but self/cls; a name the module defines itself is not told apart from another's
  of the same name: bench's own ``_timed`` hides its ``renderer._timed(...)``);
* nothing below ``mrcheck/cli/`` prints: code returns results, warns through
  ``mrcheck.core.errors.warn`` and reports progress through a callback.

The KNOWN_* sets are empty since phase B of issue 18 landed: an exception to a rule would be
named there, with its reason. A new offender fails the test, and so does a listed one that is
gone (take it off the list).
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PACKAGES = ("mrcheck", "factory_scenes")
PRINTING = {"print", "click.echo", "click.secho", "tqdm.write", "sys.stdout.write", "sys.stderr.write"}

# (module file, the private name it uses from another module)
KNOWN_PRIVATE_USES: set = set()
# (module file, function it prints in, what prints)
KNOWN_PRINTING: set = set()


def _modules():
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            yield path.relative_to(REPO).as_posix(), ast.parse(path.read_text(encoding="utf-8"), str(path))


MODULES = dict(_modules())


def _module_name(path: str) -> str:
    name = path[: -len(".py")].replace("/", ".")
    return name[: -len(".__init__")] if name.endswith(".__init__") else name


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _defined_private(tree: ast.AST) -> set:
    """Private names a module defines: functions, classes, methods, module and class
    attributes, and attributes it sets on self."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                for leaf in ast.walk(target):
                    if isinstance(leaf, ast.Name):
                        names.add(leaf.id)
                    elif (
                        isinstance(leaf, ast.Attribute) and isinstance(leaf.value, ast.Name) and leaf.value.id == "self"
                    ):
                        names.add(leaf.attr)
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "attr", "") == "__setattr__"
            and node.args[1:]
            and isinstance(node.args[1], ast.Constant)
            and isinstance(node.args[1].value, str)
        ):
            names.add(node.args[1].value)  # object.__setattr__(self, "_charuco", ...) of a frozen dataclass
    return {name for name in names if _private(name)}


DEFINED = {path: _defined_private(tree) for path, tree in MODULES.items()}


def _private_uses(path: str, tree: ast.AST) -> set:
    """(path, name) for each private name of another mrcheck/factory_scenes module that ``path``
    imports, or reads as an attribute of anything but self/cls."""
    own = DEFINED[path]
    elsewhere = set().union(*(names for other, names in DEFINED.items() if other != path)) - own
    uses = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in PACKAGES:
            if node.module != _module_name(path):
                uses |= {(path, alias.name) for alias in node.names if _private(alias.name)}
        elif isinstance(node, ast.Attribute) and node.attr in elsewhere:
            if not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
                uses.add((path, node.attr))
    return uses


def _dotted(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return f"{_dotted(node.value)}.{node.attr}"
    return ""


def _printing(path: str, tree: ast.AST) -> set:
    """(path, enclosing function, callee) for each call that prints."""
    found = set()

    def visit(node, function):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                visit(child, child.name)
                continue
            if isinstance(child, ast.Call) and _dotted(child.func) in PRINTING:
                found.add((path, function, _dotted(child.func)))
            visit(child, function)

    visit(tree, "<module>")
    return found


def _compare(found: set, known: set, what: str) -> None:
    new, gone = sorted(found - known), sorted(known - found)
    assert not new, f"{what} (not allowed): {new}"
    assert not gone, f"no longer {what}, take them off the known list in tests/test_architecture.py: {gone}"


def test_lint_imports_keeps_the_contracts():
    lint = shutil.which("lint-imports") or str(Path(sys.executable).with_name("lint-imports"))
    if not Path(lint).exists():
        pytest.fail("lint-imports not found: install the test extra (pip install -e '.[test]')")
    run = subprocess.run([lint, "--no-cache"], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert "Contracts: 3 kept, 0 broken" in run.stdout


def test_no_module_uses_another_modules_private_names():
    found = set().union(*(_private_uses(path, tree) for path, tree in MODULES.items()))
    _compare(found, KNOWN_PRIVATE_USES, "private names used across modules")


def test_nothing_below_the_command_line_prints():
    found = set().union(
        *(
            _printing(path, tree)
            for path, tree in MODULES.items()
            if path.startswith("mrcheck/") and not path.startswith("mrcheck/cli/")
        )
    )
    _compare(found, KNOWN_PRINTING, "printing below mrcheck/cli/")


def test_the_checks_see_what_they_look_for():
    """Not vacuous: each check finds its offence in a module written to break it."""
    bad = ast.parse(
        "from mrcheck.render.renderer import _helper\nimport click\n"
        "def f(r):\n    r._timed()\n    click.echo('x')\n    print('y')\n"
    )
    DEFINED["x.py"] = set()
    try:
        assert _private_uses("x.py", bad) == {("x.py", "_helper"), ("x.py", "_timed")}
    finally:
        del DEFINED["x.py"]
    assert _printing("x.py", bad) == {("x.py", "f", "click.echo"), ("x.py", "f", "print")}
