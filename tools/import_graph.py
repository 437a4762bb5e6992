"""The real imports of JOSHUA's source, read with `ast`: which module imports which, and from which distribution.

Shared by tools/check_architecture.py (the house rules) and docs/architecture_layers.py (the layer picture), so
both read the same graph. Imports under `if TYPE_CHECKING:` are marked type-only: they never run.
"""

from __future__ import annotations

import ast
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORE = "joshua-core"


@dataclass(frozen=True)
class Import:
    """One imported module (or `module.name`) at one line of one source module."""

    module: str  # the importing module, e.g. joshua_core.cli
    target: str  # what it names: a module, or module.attribute for `from module import attribute`
    names: tuple[str, ...]  # the names of `from target import a, b` (empty for `import target`)
    line: int
    type_only: bool  # under `if TYPE_CHECKING:`
    function: str | None  # the enclosing function's name, None at module level


@dataclass(frozen=True)
class Package:
    """A distribution's top-level package in this repository."""

    distribution: str
    name: str
    folder: Path

    def modules(self) -> Iterator[tuple[str, Path]]:
        """(dotted name, file) of each hand-written module (generated `_pb2` modules left out)."""
        for path in sorted(self.folder.rglob("*.py")):
            if path.name.endswith("_pb2.py"):
                continue
            parts = path.relative_to(self.folder.parent).with_suffix("").parts
            yield ".".join(parts).removesuffix(".__init__"), path

    def exported(self) -> set[str]:
        """The names its `__init__.py` lists in `__all__` (what another distribution may import from it)."""
        tree = ast.parse((self.folder / "__init__.py").read_text(encoding="utf-8"))
        for node in tree.body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
                return set(ast.literal_eval(node.value))
        return set()


def packages(root: Path = ROOT) -> dict[str, Package]:
    """The core and every first-party plugin distribution (plugins/*/pyproject.toml), by package name."""
    found = {"joshua_core": Package(CORE, "joshua_core", root / "joshua_core")}
    for pyproject in sorted(root.glob("plugins/*/pyproject.toml")):
        distribution = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]["name"]
        for folder in sorted(pyproject.parent.glob("joshua_*/__init__.py")):
            found[folder.parent.name] = Package(distribution, folder.parent.name, folder.parent)
    return found


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """ids of every node inside an `if TYPE_CHECKING:` body."""
    inside: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            inside |= {id(child) for statement in node.body for child in ast.walk(statement)}
    return inside


def imports_of(module: str, path: Path) -> list[Import]:
    """Every import statement of one module, with its place (type-only, inside which function)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    type_only = _type_checking_nodes(tree)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: list[Import] = []

    def visit(node: ast.AST, function: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            inner = child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef) else function
            if isinstance(child, ast.Import):
                for alias in child.names:
                    found.append(Import(module, alias.name, (), child.lineno, id(child) in type_only, function))
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    parts = package.split(".")[: len(package.split(".")) - child.level + 1]
                    base = ".".join([*parts, base] if base else parts)
                names = tuple(alias.name for alias in child.names)
                found.append(Import(module, base, names, child.lineno, id(child) in type_only, function))
            visit(child, inner)

    visit(tree, None)
    return found


def all_imports(root: Path = ROOT) -> dict[str, tuple[Package, Path, list[Import]]]:
    """Every first-party module: its package, file and imports."""
    return {
        module: (package, path, imports_of(module, path))
        for package in packages(root).values()
        for module, path in package.modules()
    }


def distribution_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """distribution -> the first-party distributions its code imports when it runs (type-only imports left out)."""
    known = packages(root)
    graph: dict[str, set[str]] = {package.distribution: set() for package in known.values()}
    for package, _, imports in all_imports(root).values():
        for item in imports:
            top = known.get(item.target.split(".")[0])
            if top is not None and top.distribution != package.distribution and not item.type_only:
                graph[package.distribution].add(top.distribution)
    return graph


def floors(graph: dict[str, set[str]]) -> dict[str, int]:
    """Each distribution's floor: 0 for one that imports no other, else one above the highest it imports.
    A circle has no floors; check_architecture reports it first."""
    result: dict[str, int] = {}

    def floor(name: str, path: tuple[str, ...]) -> int:
        if name in path:
            raise ValueError(f"import circle between distributions: {' -> '.join((*path, name))}")
        if name not in result:
            result[name] = 1 + max((floor(d, (*path, name)) for d in graph[name]), default=-1)
        return result[name]

    for name in sorted(graph):
        floor(name, ())
    return result


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one node (Tarjan), each sorted: every import circle."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in sorted(graph.get(node, ())):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            group = []
            while True:
                other = stack.pop()
                group.append(other)
                if other == node:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found
