"""The architecture, checked on the source:

* the import-linter contracts in pyproject.toml (``lint-imports``): the layers core <- scene <-
  render <- mr <- apps <- eval <- cli; nothing imports the command line; mrcheck imports the
  scene generator (factory_scenes) only from the command line, and the generator builds on
  mrcheck.core and mrcheck.scene only; no import cycle among the modules of any package
  (imports inside functions count). Each contract is shown to fail on a package tree written to
  break it, checked with the contracts as pyproject.toml states them;
* no module uses another module's private (underscore) names, in mrcheck, factory_scenes and
  the tests: by import, as an attribute of a module, of a class or of a parameter annotated with
  a class of another module, by a ``setattr``/``getattr`` string, or as an attribute of anything
  else that another module defines and this one does not define as a member of its own classes
  (a module's own top-level ``_timed`` does not hide a ``renderer._timed(...)``; a member of the
  same name does, unless the receiver is a module, a class or an annotated parameter);
* nothing below ``mrcheck/cli/`` prints: code returns results, warns through
  ``mrcheck.core.errors.warn`` and reports progress through a callback;
* no module in mrcheck/ or factory_scenes/ is over :data:`MAX_LINES` lines;
* only ``mrcheck/core/resources.py`` spells the ``factory_scenes`` folder: every other module
  asks it for a shipped scene or the robot assets.

An exception to a rule is named in a KNOWN_* set with its reason. A new offender fails the test,
and so does a listed one that is gone (take it off the list).
"""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PACKAGES = ("mrcheck", "factory_scenes")
PRIVATE_CHECKED = (*PACKAGES, "tests")  # the private-name check covers the tests too
PRINTING = {"print", "click.echo", "click.secho", "tqdm.write", "sys.stdout.write", "sys.stderr.write"}
MAX_LINES = 500
RESOURCES = "mrcheck/core/resources.py"  # the one module that knows the factory_scenes folder
SHIPPED_FOLDER = "factory_scenes"
ATTRIBUTE_CALLS = {"setattr", "getattr", "hasattr", "delattr"}  # also monkeypatch.setattr/delattr

# (module file, the private name it uses from another module)
KNOWN_PRIVATE_USES: set = set()
# (module file, function it prints in, what prints)
KNOWN_PRINTING: set = set()
# module files over MAX_LINES lines, with the reason they still are
KNOWN_LONG: dict = {}


def _parse(path: Path):
    return ast.parse(path.read_text(encoding="utf-8"), str(path))


def _modules(packages):
    for package in packages:
        for path in sorted((REPO / package).rglob("*.py")):
            yield path.relative_to(REPO).as_posix(), _parse(path)


MODULES = dict(_modules(PRIVATE_CHECKED))


def _module_name(path: str) -> str:
    name = path[: -len(".py")].replace("/", ".")
    return name[: -len(".__init__")] if name.endswith(".__init__") else name


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


# -- what each module defines ------------------------------------------------------------------
@dataclass
class Defined:
    """A module's private names: ``top`` its module-level functions, classes and variables
    (reached through the module), ``members`` its methods, class attributes and the attributes
    it sets on self (reached through an object)."""

    top: set = field(default_factory=set)
    members: set = field(default_factory=set)


def _assigned(node) -> list:
    targets = node.targets if isinstance(node, ast.Assign) else [node.target]
    return [leaf for target in targets for leaf in ast.walk(target)]


def _defined_private(tree: ast.Module) -> Defined:
    defined = Defined()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            defined.top.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            defined.top |= {leaf.id for leaf in _assigned(node) if isinstance(leaf, ast.Name)}
    for cls in (node for node in ast.walk(tree) if isinstance(node, ast.ClassDef)):
        for node in cls.body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                defined.members.add(node.name)
            elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
                defined.members |= {leaf.id for leaf in _assigned(node) if isinstance(leaf, ast.Name)}
    for node in ast.walk(tree):
        if isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            defined.members |= {
                leaf.attr
                for leaf in _assigned(node)
                if isinstance(leaf, ast.Attribute) and isinstance(leaf.value, ast.Name) and leaf.value.id == "self"
            }
        elif (
            isinstance(node, ast.Call)
            and getattr(node.func, "attr", "") == "__setattr__"
            and node.args[1:]
            and isinstance(node.args[1], ast.Constant)
            and isinstance(node.args[1].value, str)
        ):
            defined.members.add(node.args[1].value)  # object.__setattr__(self, "_charuco", ...) of a frozen dataclass
    defined.top = {name for name in defined.top if _private(name)}
    defined.members = {name for name in defined.members if _private(name)}
    return defined


DEFINED = {path: _defined_private(tree) for path, tree in MODULES.items()}


# -- what a module uses ------------------------------------------------------------------------
def _absolute(path: str, node: ast.ImportFrom) -> str:
    """The module an ``import from`` names, relative ones resolved against ``path``'s package."""
    if not node.level:
        return node.module or ""
    package = _module_name(path).split(".")
    if not path.endswith("__init__.py"):
        package = package[:-1]
    base = package[: len(package) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _bindings(path: str, tree: ast.AST, modules: set) -> tuple[dict, dict]:
    """``(module aliases, imported names)``: local name -> module for every checked module
    ``path`` imports, and local name -> defining module for every name it imports from one."""
    aliases, names = {}, {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                first = alias.name.split(".")[0]
                if first in PRIVATE_CHECKED:  # import a.b.c binds a; import a.b.c as m binds m
                    aliases[alias.asname or first] = alias.name if alias.asname else first
        elif isinstance(node, ast.ImportFrom):
            source = _absolute(path, node)
            if source.split(".")[0] not in PRIVATE_CHECKED:
                continue
            for alias in node.names:
                local = alias.asname or alias.name
                if f"{source}.{alias.name}" in modules:
                    aliases[local] = f"{source}.{alias.name}"
                else:
                    names[local] = source
    return aliases, names


def _annotation_names(annotation: ast.expr) -> set:
    if isinstance(annotation, ast.Constant) and isinstance(annotation.value, str):
        annotation = ast.parse(annotation.value, mode="eval").body
    return {node.id for node in ast.walk(annotation) if isinstance(node, ast.Name)}


def _annotated(tree: ast.AST, names: dict) -> dict:
    """Parameter name -> the module of the class its annotation names, for parameters annotated
    with a class imported from a checked module (``r: Renderer``, ``"Renderer | None"``)."""
    found = {}
    for node in ast.walk(tree):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        arguments = node.args
        for arg in [*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs]:
            if arg.annotation is None:
                continue
            modules = {names[name] for name in _annotation_names(arg.annotation) if name in names}
            if modules:
                found[arg.arg] = sorted(modules)[0]
    return found


def _receiver(node: ast.AST) -> str:
    """``self`` for ``self``/``super()`` (the object's own members), a dotted name
    (``mrcheck.apps.track``, ``r``), or "" for anything else."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "super":
        return "self"
    return _dotted(node)


def _private_uses(path: str, tree: ast.AST, defined: dict) -> set:
    """(path, name) for each private name of another mrcheck, factory_scenes or tests module
    that ``path`` uses (see the module docstring for how a name is told to be another's)."""
    own, here = defined[path], _module_name(path)
    modules = {_module_name(other) for other in defined}
    elsewhere = set().union(*(d.top | d.members for other, d in defined.items() if other != path))
    aliases, names = _bindings(path, tree, modules)
    annotated = _annotated(tree, names)

    def module_of(receiver: str) -> str | None:
        first, _, rest = receiver.partition(".")
        module = aliases.get(first, "") + (f".{rest}" if rest else "")
        return module if first in aliases and module in modules else None

    def foreign(receiver: str, name: str) -> bool:
        if receiver in ("self", "cls"):
            return False
        if module_of(receiver):  # a module: its own top-level names are its business only
            return module_of(receiver) != here
        if receiver in names or receiver in annotated:  # a class, or an instance, of another module
            return (names.get(receiver) or annotated[receiver]) != here
        return name in elsewhere and name not in own.members

    uses = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and _absolute(path, node).split(".")[0] in PRIVATE_CHECKED:
            if _absolute(path, node) != here:
                uses |= {(path, alias.name) for alias in node.names if _private(alias.name)}
        elif isinstance(node, ast.Attribute) and _private(node.attr):
            if foreign(_receiver(node.value), node.attr):
                uses.add((path, node.attr))
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) in ATTRIBUTE_CALLS:
            strings = [arg for arg in node.args[:2] if isinstance(arg, ast.Constant) and isinstance(arg.value, str)]
            for string in strings:
                dotted, _, name = string.value.rpartition(".")
                if not _private(name):
                    continue
                if dotted:  # monkeypatch.setattr("mrcheck.render.renderer._timed", ...)
                    if dotted.split(".")[0] in PRIVATE_CHECKED and dotted != here:
                        uses.add((path, name))
                elif node.args and foreign(_receiver(node.args[0]), name):
                    uses.add((path, name))
    return uses


# -- printing, length, the shipped folder -----------------------------------------------------
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


def _docstrings(tree: ast.AST) -> set:
    holders = (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)
    return {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, holders)
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }


def _spells_shipped_folder(path: str, tree: ast.AST) -> set:
    """(path, line) of each string in code (docstrings are documentation) naming the
    factory_scenes folder."""
    docs = _docstrings(tree)
    return {
        (path, node.lineno)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and SHIPPED_FOLDER in node.value
        and id(node) not in docs
    }


def _compare(found: set, known, what: str) -> None:
    new, gone = sorted(found - set(known)), sorted(set(known) - found)
    assert not new, f"{what} (not allowed): {new}"
    assert not gone, f"no longer {what}, take them off the known list in tests/test_architecture.py: {gone}"


# -- import-linter ----------------------------------------------------------------------------
def _lint_imports() -> str:
    lint = shutil.which("lint-imports") or str(Path(sys.executable).with_name("lint-imports"))
    if not Path(lint).exists():
        pytest.fail("lint-imports not found: install the test extra (pip install -e '.[test]')")
    return lint


def _contracts() -> list:
    with open(REPO / "pyproject.toml", "rb") as file:
        return tomllib.load(file)["tool"]["importlinter"]["contracts"]


def _importlinter_section() -> str:
    """The [tool.importlinter] tables of pyproject.toml, verbatim."""
    text = (REPO / "pyproject.toml").read_text(encoding="utf-8")
    start = text.index("[tool.importlinter]")
    rest = text[start:].split("\n")
    lines = [rest[0]]
    for line in rest[1:]:
        if line.startswith("[") and not line.startswith(("[tool.importlinter", "[[tool.importlinter")):
            break
        lines.append(line)
    return "\n".join(lines)


def _run_lint(lint: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(cwd)}
    return subprocess.run([lint, "--no-cache"], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def test_lint_imports_keeps_the_contracts():
    run = _run_lint(_lint_imports(), REPO)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert f"Contracts: {len(_contracts())} kept, 0 broken" in run.stdout


# the package tree the contracts are checked on, and per contract one import that breaks it
LAYERS = ("core", "scene", "render", "mr", "apps", "eval", "cli")
BREAKS = {
    "layers": {"mrcheck/apps/judged.py": "import mrcheck.eval\n"},  # apps sit below eval now
    "no-cli": {"factory_scenes/tool.py": "import mrcheck.cli\n"},
    "generator-from-cli-only": {"mrcheck/eval/bench.py": "import factory_scenes\n"},
    "generator-on-scene": {"factory_scenes/tool.py": "import mrcheck.render\n"},
    "acyclic": {
        "mrcheck/scene/model.py": "def load():\n    from mrcheck.scene.importers import cache\n",
        "mrcheck/scene/importers/__init__.py": "",
        "mrcheck/scene/importers/cache.py": "def load_model():\n    from mrcheck.scene.model import load\n",
    },
}


def _write_tree(root: Path, files: dict) -> None:
    for package in [f"mrcheck/{layer}" for layer in LAYERS] + ["mrcheck", "factory_scenes"]:
        (root / package).mkdir(parents=True, exist_ok=True)
        (root / package / "__init__.py").write_text("")
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    (root / "pyproject.toml").write_text(_importlinter_section())


def test_every_contract_has_a_breaking_example():
    assert sorted(BREAKS) == sorted(contract["id"] for contract in _contracts())


@pytest.mark.parametrize("contract", sorted(BREAKS))
def test_each_contract_fails_on_a_tree_that_breaks_it(contract, tmp_path):
    """The contracts as pyproject.toml states them, on a tree of empty packages: kept as it is,
    broken by one import (one cycle for ``acyclic``, through imports inside functions)."""
    lint = _lint_imports()
    name = next(c["name"] for c in _contracts() if c["id"] == contract)
    _write_tree(tmp_path / "clean", {})
    clean = _run_lint(lint, tmp_path / "clean")
    assert clean.returncode == 0, clean.stdout[-3000:] + clean.stderr[-2000:]
    _write_tree(tmp_path / "broken", BREAKS[contract])
    broken = _run_lint(lint, tmp_path / "broken")
    assert broken.returncode != 0, broken.stdout[-3000:]
    report = " ".join(broken.stdout.split())  # lint-imports wraps long contract names
    assert f"{' '.join(name.split())} BROKEN" in report, report[-3000:]


# -- the source checks ------------------------------------------------------------------------
def test_no_module_uses_another_modules_private_names():
    found = set().union(*(_private_uses(path, tree, DEFINED) for path, tree in MODULES.items()))
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


def _line_counts(packages=PACKAGES) -> dict:
    return {
        path.relative_to(REPO).as_posix(): len(path.read_text(encoding="utf-8").splitlines())
        for package in packages
        for path in sorted((REPO / package).rglob("*.py"))
    }


def _long(counts: dict) -> set:
    return {path for path, lines in counts.items() if lines > MAX_LINES}


def test_no_module_is_over_the_line_limit():
    _compare(_long(_line_counts()), KNOWN_LONG, f"modules over {MAX_LINES} lines")


def test_only_resources_knows_the_shipped_folder():
    found = set().union(
        *(
            _spells_shipped_folder(path, tree)
            for path, tree in MODULES.items()
            if path.startswith("mrcheck/") and path != RESOURCES
        )
    )
    assert not found, f"find shipped scenes through {RESOURCES} (shipped_scene, robot_assets_dir): {sorted(found)}"
    assert _spells_shipped_folder(RESOURCES, MODULES[RESOURCES]), "the check looks for the wrong name"


def test_the_checks_see_what_they_look_for():
    """Not vacuous: each check finds its offence in a module written to break it, and the
    private-name check tells a module's own names from another's of the same name."""
    source = (
        "from mrcheck.render.renderer import _helper, Renderer\nimport click\n"
        "import mrcheck.apps.track as track\nimport mrcheck.apps\n"
        "def _timed():\n    pass\n"
        "def f(r, s: 'Renderer | None', monkeypatch):\n    r._timed()\n    click.echo('x')\n    print('y')\n"
        "    s._own()\n    track._Loop\n    Renderer._blur\n    mrcheck.apps.track._frames\n"
        "    monkeypatch.setattr(track, '_Reader', None)\n"
        "    monkeypatch.setattr('mrcheck.render.renderer._ao', None)\n"
        "class Mine:\n    def _Loop(self):\n        super()._timed()\n"
        "ROOT = __file__ + '/factory_scenes/cell'\n"
    )
    bad = ast.parse(source)
    defined = {
        "x.py": _defined_private(bad),
        "mrcheck/render/renderer.py": Defined(top={"_helper"}, members={"_timed", "_blur", "_ao", "_own"}),
        "mrcheck/apps/track.py": Defined(top={"_Loop", "_Reader", "_frames"}),
    }
    assert defined["x.py"] == Defined(top={"_timed"}, members={"_Loop"})
    assert _private_uses("x.py", bad, defined) == {
        ("x.py", name) for name in ("_helper", "_timed", "_own", "_Loop", "_blur", "_Reader", "_ao", "_frames")
    }
    # a member of its own class, on another instance of it: not reported
    mine = ast.parse("class Mine:\n    def _own(self):\n        pass\n    def g(self, other):\n        other._own()\n")
    assert _private_uses("mine.py", mine, {**defined, "mine.py": _defined_private(mine)}) == set()
    assert _printing("x.py", bad) == {("x.py", "f", "click.echo"), ("x.py", "f", "print")}
    assert _spells_shipped_folder("x.py", bad) == {("x.py", source.count("\n"))}
    assert _long({"a.py": MAX_LINES, "b.py": MAX_LINES + 1}) == {"b.py"}
