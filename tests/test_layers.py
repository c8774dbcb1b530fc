"""The package's folders are its layers, and the imports keep them so (read from the source
with ``ast``, nothing imported).

Layers, from the bottom: the shared leaves (``errors``, ``files``, ``parameters``, ``theory``),
``problem`` (the interface and its assembly), ``geometry``, the two models (``surface``,
``axisym``), ``algorithms``, ``analyses``, ``api`` (the public Python API), ``cli``. A module
imports only from its own layer or the layers below; the algorithms import nothing above the problem
interface (they run on any ``Problem``), and the two models do not import each other. No import
loop, and no private name (``_x``) of one module is imported or used by another, in the package, its
tests and its benchmarks. The package root (``shells/__init__.py``, the public API) may import from
every layer.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "shells"

#: the layers from the bottom up: a module's layer is the first whose prefix names it
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    ("leaves", ("shells.errors", "shells.files", "shells.parameters", "shells.progress",
                "shells.layers", "shells.theory", "shells.units")),
    ("problem", ("shells.problem",)),
    ("geometry", ("shells.geometry",)),
    ("models", ("shells.surface", "shells.axisym")),
    ("algorithms", ("shells.algorithms",)),
    ("analyses", ("shells.analyses",)),
    ("api", ("shells.api",)),
    ("cli", ("shells.cli", "shells.__main__")),
]
#: what each layer may import besides its own layer and the ones below it: the algorithms
#: only the leaves and the problem interface
ALLOWED_BELOW = {"algorithms": {"leaves", "problem"}}


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def layer_of(module: str) -> tuple[int, str, str] | None:
    """(rank, layer, group) of a package module; None for the package root."""
    for rank, (name, prefixes) in enumerate(LAYERS):
        for prefix in prefixes:
            if module == prefix or module.startswith(prefix + "."):
                return rank, name, prefix
    return None


def package_modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports_of(path: Path, modules: dict[str, Path]) -> list[tuple[str, int, list[str]]]:
    """(imported module, line, names taken from it) of every ``shells`` import in the file,
    at module level or inside functions; ``from shells.x import y`` where ``y`` is a module
    counts as importing ``shells.x.y``."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "shells" or a.name.startswith("shells."):
                    out.append((a.name, node.lineno, []))
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                and (node.module == "shells" or node.module.startswith("shells.")):
            plain = []
            for a in node.names:
                sub = f"{node.module}.{a.name}"
                if sub in modules:
                    out.append((sub, node.lineno, []))
                else:
                    plain.append(a.name)
            if plain:
                out.append((node.module, node.lineno, plain))
    return out


def test_every_module_has_a_layer():
    unplaced = [m for m in package_modules() if m != "shells" and layer_of(m) is None]
    assert not unplaced, f"modules outside every layer: {unplaced}"


def test_imports_run_downwards_only():
    modules = package_modules()
    wrong = []
    for mod, path in modules.items():
        own = layer_of(mod)
        if own is None:
            continue  # the package root: the public API
        rank, name, group = own
        for target, line, _ in imports_of(path, modules):
            theirs = layer_of(target)
            where = f"{path.relative_to(ROOT)}:{line} ({name}) imports {target}"
            if theirs is None:
                if target == "shells":
                    continue  # ``from shells import __version__``
                wrong.append(where + " (not a module of the package)")
                continue
            t_rank, t_name, t_group = theirs
            if t_rank > rank:
                wrong.append(where + f" ({t_name}: a layer above)")
            elif t_name == name == "models" and t_group != group:
                wrong.append(where + " (the two models do not import each other)")
            elif name in ALLOWED_BELOW and t_rank < rank and t_name not in ALLOWED_BELOW[name]:
                wrong.append(where + f" ({t_name}: the algorithms take the problem interface "
                                     "only)")
    assert not wrong, "imports against the layers:\n" + "\n".join(wrong)


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if m not in state:
                found = visit(m)
                if found:
                    return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state:
            found = visit(n)
            if found:
                return found
    return None


def test_no_import_loop():
    """Between modules (a package's ``__init__`` re-exporting its submodules is not a loop of
    theirs), lazy imports inside functions included."""
    modules = package_modules()
    graph: dict[str, set[str]] = defaultdict(set)
    for mod, path in modules.items():
        if mod == "shells":
            continue
        for target, _, _ in imports_of(path, modules):
            if target in modules and target != mod and not mod.startswith(target + ".") \
                    and modules[target].name != "__init__.py":
                graph[mod].add(target)
    assert _cycle(graph) is None, f"import loop: {' -> '.join(_cycle(graph))}"


def _private_definitions(*folders: Path) -> dict[str, set[Path]]:
    """Each private name (``_x``, not dunder) defined in the files of ``folders``: functions,
    classes, methods, module variables and attributes assigned, with the files defining it."""
    defined: dict[str, set[Path]] = defaultdict(set)
    for path in (p for folder in folders for p in folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names: list[str] = []
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names = [node.name]
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                for t in targets:
                    for sub in ast.walk(t):
                        if isinstance(sub, ast.Name):
                            names.append(sub.id)
                        elif isinstance(sub, ast.Attribute):
                            names.append(sub.attr)
            for n in names:
                if n.startswith("_") and not n.startswith("__"):
                    defined[n].add(path)
    return defined


def private_uses(folder: Path, defined: dict[str, set[Path]]) -> list[str]:
    """Uses in ``folder``'s files of private names that only other files define: ``from
    shells.x import _y`` and ``obj._y`` (``self._y`` and ``cls._y`` are the object's own)."""
    found = []
    for path in sorted(folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("shells"):
                for a in node.names:
                    if a.name.startswith("_") and not a.name.startswith("__"):
                        found.append(f"{path.relative_to(ROOT)}:{node.lineno} imports {a.name}")
            elif isinstance(node, ast.Attribute) and node.attr.startswith("_") \
                    and not node.attr.startswith("__"):
                if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                    continue
                owners = defined.get(node.attr)
                if owners and path not in owners and any(PACKAGE in o.parents for o in owners):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno} uses .{node.attr}")
    return found


@pytest.mark.parametrize("folder", ["shells", "tests", "benchmarks", "demos"])
def test_no_private_name_across_modules(folder):
    uses = private_uses(ROOT / folder, _private_definitions(PACKAGE, ROOT / folder))
    assert not uses, "private names used outside their module:\n" + "\n".join(uses)
