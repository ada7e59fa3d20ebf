"""The house's rules over the whole tree (docs/ARCHITECTURE.md, issue #35).

Four packages, imports pointing one way: ``bubblerob_cli`` -> ``train`` -> ``policies`` ->
``bubblerob_env``, with ``bubblerob_env.ros`` on top inside ``bubblerob_env``. Every import counts,
top-level or inside a function, and so does a string that names a module (``"policies.residual"``
in an entry point, a registry or ``importlib.import_module``). A ``__main__.py`` is a command
shim: it may import the commands, and nothing imports it. Below the commands no code parses argv,
exits or prints; no ``_private`` name leaves its file; ``core/`` and the config know no Gym.

Each rule is checked by walking the source with ``ast``; each also has a test that feeds it a
made-up violation, so that a rule that can no longer fail is noticed.
"""

from __future__ import annotations

import ast
import re
from collections import defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# Highest first: a package may import only those after it (and itself).
PACKAGES = ("bubblerob_cli", "train", "policies", "bubblerob_env")
# Inside bubblerob_env: a layer may not import these (its higher neighbours).
INNER_FORBIDDEN = {
    "bubblerob_env": ("bubblerob_env.ros",),
    "bubblerob_env.ros": (),  # the top of bubblerob_env
    "bubblerob_env.core": ("bubblerob_env.ros",),
    "bubblerob_env.ros.messages": (
        "bubblerob_env.ros.fastpath", "bubblerob_env.ros.bags", "bubblerob_env.ros.readback",
        "bubblerob_env.ros.live", "bubblerob_env.ros.recorder", "bubblerob_env.ros.episodes",
    ),
    "bubblerob_env.ros.fastpath": (
        "bubblerob_env.ros.bags", "bubblerob_env.ros.live", "bubblerob_env.ros.readback",
    ),
    "bubblerob_env.ros.bags": ("bubblerob_env.ros.live", "bubblerob_env.ros.readback"),
    # The Sink protocol and the fan-out sit below every sink: bags and live backends.
    "bubblerob_env.ros.sink": ("bubblerob_env.ros.bags", "bubblerob_env.ros.live"),
    "bubblerob_env.ros.fanout": ("bubblerob_env.ros.bags", "bubblerob_env.ros.live"),
}  # fmt: skip
# Modules that know no Gym class.
NO_GYM = ("bubblerob_env.core", "bubblerob_env.config")
DOTTED = re.compile(r"^[a-z_][a-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)+(:[A-Za-z_][A-Za-z0-9_]*)?$")


@dataclass
class Module:
    """One source file: its dotted name, path and parsed tree."""

    name: str
    path: Path
    tree: ast.Module
    is_package: bool = False
    is_main: bool = False
    imports: dict[str, int] = field(default_factory=dict)  # imported name -> line
    strings: dict[str, int] = field(default_factory=dict)  # dotted-name strings -> line


def parse(name: str, path: Path, source: str) -> Module:
    """``source`` as a :class:`Module` named ``name`` with its imports and dotted strings."""
    tree = ast.parse(source)
    module = Module(name, path, tree, path.name == "__init__.py", path.name == "__main__.py")
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                module.imports.setdefault(alias.name, node.lineno)
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"{path}: relative import (the walk reads absolute ones)"
            assert node.module is not None
            # `from pkg import sub` uses pkg.sub (resolved to pkg itself where sub is a name).
            for alias in node.names:
                module.imports.setdefault(f"{node.module}.{alias.name}", node.lineno)
        elif (
            isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and id(node) not in docstrings
            and DOTTED.match(node.value)
        ):
            module.strings.setdefault(node.value.partition(":")[0], node.lineno)
    return module


def load_tree(root: Path = ROOT) -> dict[str, Module]:
    """Every module of the four packages under ``root``, by dotted name."""
    modules = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            name = ".".join(parts)
            modules[name] = parse(name, path, path.read_text(encoding="utf-8"))
    return modules


def resolve(name: str, modules: dict[str, Module]) -> str | None:
    """The module of ours that ``name`` (a module or a name in one) refers to, or None."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def edges(modules: dict[str, Module]) -> dict[str, dict[str, tuple[int, str]]]:
    """module -> {module it uses: (line, how)}: imports and dotted strings, self excluded."""
    graph: dict[str, dict[str, tuple[int, str]]] = {}
    for module in modules.values():
        out: dict[str, tuple[int, str]] = {}
        for kind, names in (("imports", module.imports), ("names", module.strings)):
            for name, line in names.items():
                target = resolve(name, modules)
                # `from pkg import sub` inside pkg's own __init__ is the package's own part.
                if target and target != module.name:
                    out.setdefault(target, (line, kind))
        graph[module.name] = out
    return graph


def rank(name: str) -> int:
    """The package's height: 0 for the commands, 3 for bubblerob_env."""
    return PACKAGES.index(name.split(".")[0])


def in_layer(name: str, layer: str) -> bool:
    return name == layer or name.startswith(layer + ".")


def against_direction(modules: dict[str, Module]) -> Iterator[str]:
    """Every use of a module against the direction rule, one line each."""
    for source, targets in edges(modules).items():
        module = modules[source]
        for target, (line, kind) in sorted(targets.items()):
            where = f"{source}:{line} {kind} {target}"
            if modules[target].is_main:
                yield f"{where}: nothing may use a __main__ shim"
            elif module.is_main:
                continue  # a shim: a command by definition
            elif rank(target) < rank(source):
                yield f"{where}: {source.split('.')[0]} may not use {target.split('.')[0]}"
            else:
                layer = max(
                    (lay for lay in INNER_FORBIDDEN if in_layer(source, lay)), key=len, default=None
                )
                if layer and any(in_layer(target, bad) for bad in INNER_FORBIDDEN[layer]):
                    yield f"{where}: {layer} may not use {target}"


def circles(modules: dict[str, Module]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    graph = {name: sorted(targets) for name, targets in edges(modules).items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(graph[start]))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(graph[child])))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def _defined_names(tree: ast.AST) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
    return names


def private_leaks(modules: dict[str, Module]) -> Iterator[str]:
    """``_name`` of one of our files used in another: imported, or read as an attribute."""
    defined_in: dict[str, set[str]] = defaultdict(set)
    own: dict[str, set[str]] = {}
    for module in modules.values():
        own[module.name] = _defined_names(module.tree)
        for name in own[module.name]:
            defined_in[name].add(module.name)
    for module in modules.values():
        for node in ast.walk(module.tree):
            if isinstance(node, ast.ImportFrom):
                used = [(alias.name, node.lineno) for alias in node.names]
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Load):
                used = [(node.attr, node.lineno)]
            else:
                continue
            for name, line in used:
                private = name.startswith("_") and not name.startswith("__")
                if private and defined_in.get(name) and name not in own[module.name]:
                    yield f"{module.name}:{line} uses {name} of {sorted(defined_in[name])}"


def command_work_below(modules: dict[str, Module]) -> Iterator[str]:
    """argv parsing, exits and printing outside the commands and their shims."""
    for module in modules.values():
        if rank(module.name) == 0 or module.is_main:
            continue
        for name, line in module.imports.items():
            if in_layer(name, "argparse"):
                yield f"{module.name}:{line} imports argparse"
        for node in ast.walk(module.tree):
            if not isinstance(node, ast.Call):
                continue
            func = node.func
            called = (
                func.id
                if isinstance(func, ast.Name)
                else f"{getattr(func.value, 'id', '?')}.{func.attr}"
                if isinstance(func, ast.Attribute)
                else ""
            )
            if called in ("print", "sys.exit", "exit", "quit", "SystemExit", "os._exit"):
                yield f"{module.name}:{node.lineno} calls {called}"


def gym_below(modules: dict[str, Module]) -> Iterator[str]:
    for module in modules.values():
        if any(in_layer(module.name, layer) for layer in NO_GYM):
            for name, line in module.imports.items():
                if in_layer(name, "gymnasium"):
                    yield f"{module.name}:{line} imports {name}"


RULES = {
    "direction": against_direction,
    "private": private_leaks,
    "commands": command_work_below,
    "gym": gym_below,
}


def _listed(found: Iterable[str]) -> list[str]:
    return sorted(set(found))


@pytest.fixture(scope="module")
def tree() -> dict[str, Module]:
    return load_tree()


def test_the_tree_has_the_four_packages(tree):
    for package in PACKAGES:
        assert package in tree, package
    assert len(tree) > 100


def test_no_import_circles(tree):
    assert circles(tree) == []


@pytest.mark.parametrize("rule", sorted(RULES))
def test_rule_holds_over_the_whole_tree(tree, rule):
    assert _listed(RULES[rule](tree)) == []


def _fake(files: dict[str, str]) -> dict[str, Module]:
    modules = {}
    for name, source in files.items():
        main = name.endswith(".__main__")
        path = Path("/x", *name.split(".")).with_suffix(".py")
        modules[name] = parse(name, path, source)
        modules[name].is_main = main
    return modules


def test_each_rule_catches_a_made_up_violation():
    fake = _fake(
        {
            "bubblerob_cli": "",
            "bubblerob_cli.main": "import train.trainer\n",
            "train": "",
            "train.trainer": "import policies.runs\n",
            "train.__main__": "import bubblerob_cli.main\n",  # allowed: a shim
            "policies": "",
            "policies.runs": "def _helper():\n    pass\n",
            "bubblerob_env": "",
            "bubblerob_env.env": "ENTRY = 'policies.runs:Thing'\nimport argparse\n",
            "bubblerob_env.core": "import gymnasium\nimport bubblerob_env.ros.sink\n",
            "bubblerob_env.ros": "",
            "bubblerob_env.ros.sink": "from policies.runs import _helper\nprint('hi')\n",
            "bubblerob_env.a": "import bubblerob_env.b\n",
            "bubblerob_env.b": "def f():\n    import bubblerob_env.a\n",
        }
    )
    direction = _listed(against_direction(fake))
    assert any("bubblerob_env.env" in line and "names policies.runs" in line for line in direction)
    assert any("bubblerob_env.ros.sink" in line and "policies" in line for line in direction)
    assert any("may not use bubblerob_env.ros.sink" in line for line in direction)
    assert not any("train.__main__" in line for line in direction)
    assert circles(fake) == [["bubblerob_env.a", "bubblerob_env.b"]]
    assert _listed(private_leaks(fake)) == [
        "bubblerob_env.ros.sink:1 uses _helper of ['policies.runs']"
    ]
    assert _listed(command_work_below(fake)) == [
        "bubblerob_env.env:2 imports argparse",
        "bubblerob_env.ros.sink:2 calls print",
    ]
    assert _listed(gym_below(fake)) == ["bubblerob_env.core:1 imports gymnasium"]
