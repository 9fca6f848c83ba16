"""The package's shape: no import cycle, each stage imports only earlier stages, small modules.

The stages, bottom to top (a module may import its own stage's modules and any
earlier stage's, never a later one's):

0. the loose foundation modules (errors, defaults, checks, console, stage, visemes);
1. media: decoding and encoding of images, sound and video;
2. speech: text and recordings to timed phones (Festival, forced alignment);
3. stabilize and mouth: vision on a person's frames;
4. corpus: recordings to the corpus folder;
5. flow: optical flow between visemes;
6. render: images from images and flows (morphs, compositing);
7. talk: lip-sync, models, saying things;
8. evaluation; 9. figures; 10. bench; 11. cli.

Every import counts, also one inside a function: a lazy import hides a
dependency, it does not remove it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import miketalk

PACKAGE = Path(miketalk.__file__).parent

#: The stage of each top-level module or package of miketalk.
STAGES = {
    "errors": 0,
    "defaults": 0,
    "checks": 0,
    "console": 0,
    "stage": 0,
    "visemes": 0,
    "media": 1,
    "speech": 2,
    "stabilize": 3,
    "mouth": 3,
    "corpus": 4,
    "flow": 5,
    "render": 6,
    "talk": 7,
    "evaluation": 8,
    "figures": 9,
    "bench": 10,
    "cli": 11,
}

#: At most this many modules directly under src/miketalk (besides __init__).
MAX_LOOSE_MODULES = 8

#: No module longer than this (lines).
MAX_LINES = 450


def _modules() -> dict[str, Path]:
    """Dotted name -> file, for every module of the package."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that ``name`` imports (anywhere in it)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                if path.name != "__init__.py":
                    base = base[:-1]
                base = base[: len(base) - node.level + 1]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            targets = [module, *(f"{module}.{alias.name}" for alias in node.names)]
        else:
            continue
        found.update(t for t in targets if t in modules and t != name)
    return found


def import_graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports."""
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _stage(module: str) -> int | None:
    parts = module.split(".")
    return STAGES.get(parts[1]) if len(parts) > 1 else 0


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycle() -> None:
    assert cycles(import_graph()) == []


def test_cycle_finder_finds_a_cycle() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]


def test_every_top_level_module_has_a_stage() -> None:
    top = {name.split(".")[1] for name in _modules() if name.count(".") >= 1}
    assert top - set(STAGES) == set()


def test_no_module_imports_a_later_stage() -> None:
    wrong = [
        f"{module} (stage {_stage(module)}) imports {target} (stage {_stage(target)})"
        for module, targets in import_graph().items()
        for target in sorted(targets)
        if _stage(target) > _stage(module)
    ]
    assert wrong == []


def test_few_loose_modules() -> None:
    loose = [p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__"]
    assert len(loose) <= MAX_LOOSE_MODULES, sorted(loose)


def test_no_module_is_too_long() -> None:
    long = {
        name: n
        for name, path in _modules().items()
        if (n := len(path.read_text().splitlines())) > MAX_LINES
    }
    assert long == {}
