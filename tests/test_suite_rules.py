"""The test suite's own rules: a test's outcome depends on the code, not on the machine's
speed nor on what ``results/`` holds.

1. **No assertion on a clock.** A bound on a wall time fails on a busy machine and proves
   nothing on a fast one: speed is measured in ``make bench``. A test states the behaviour
   instead (the refusal came before Festival started; the child is gone). A poll that waits
   for a condition under a generous deadline ends the test with :func:`pytest.fail` when
   the deadline passes: that is no assertion on the time.
2. **No reading of the checkout's results folder.** ``make run`` fills ``results/`` and
   ``make test`` comes after it (the README's order); a test that reads it passes or fails
   by what ran before. The product's own default look-ups (the default model, the page's
   workflow models) are pointed at an empty folder for the whole session by
   ``tests/conftest.py`` (``$MIKETALK_RESULTS``), and a test that needs a model builds or
   names its own.

Rule 1 is read from the source (:func:`clock_assertions`): a name bound from a clock
(``time.monotonic()``, ``perf_counter()``, ``time.time()``, a page's ``performance.now()``)
or from a function of the file that returns one is a clock name, and an ``assert`` that
uses a clock or a clock name is refused. Rule 2 likewise (:func:`checkout_results`): a path
made from the checkout's root (a name bound from ``__file__``) joined with ``results``.
"""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path

TESTS = Path(__file__).resolve().parent

#: The clocks: ``module.function`` or a bare function name imported from ``time``.
CLOCKS = {"monotonic", "perf_counter", "time", "monotonic_ns", "perf_counter_ns", "time_ns"}
#: Clocks read in a page, inside the JavaScript a test hands to the browser.
PAGE_CLOCKS = ("performance.now", "Date.now")
#: The calls that hand JavaScript to the browser (Playwright's).
PAGE_CALLS = {"evaluate", "evaluate_all", "evaluate_handle", "wait_for_function"}


def _is_clock_call(node: ast.AST) -> bool:
    if not isinstance(node, ast.Call):
        return False
    func = node.func
    if isinstance(func, ast.Attribute) and func.attr in CLOCKS:
        return isinstance(func.value, ast.Name) and func.value.id == "time"
    if isinstance(func, ast.Name) and func.id in CLOCKS - {"time"}:
        return True
    page_call = isinstance(func, ast.Attribute) and func.attr in PAGE_CALLS
    return page_call and any(
        isinstance(arg, ast.Constant)
        and isinstance(arg.value, str)
        and any(clock in arg.value for clock in PAGE_CLOCKS)
        for arg in node.args
    )


def _names(target: ast.AST) -> list[str]:
    if isinstance(target, ast.Name):
        return [target.id]
    if isinstance(target, ast.Tuple | ast.List):
        return [name for element in target.elts for name in _names(element)]
    return []


class _Clocks:
    """What in one file reads a clock: names bound from one, functions that return one."""

    def __init__(self, tree: ast.Module) -> None:
        self.functions: set[str] = set()
        self.names: set[str] = set()
        changed = True
        while changed:  # to a fixed point: a function returning a clock name is a clock too
            before = (len(self.functions), len(self.names))
            for node in ast.walk(tree):
                if isinstance(node, ast.Assign | ast.AnnAssign | ast.AugAssign) and node.value:
                    if self.reads(node.value):
                        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                        self.names.update(n for t in targets for n in _names(t))
                elif isinstance(node, ast.FunctionDef) and any(
                    isinstance(inner, ast.Return) and inner.value and self.reads(inner.value)
                    for inner in ast.walk(node)
                ):
                    self.functions.add(node.name)
            changed = (len(self.functions), len(self.names)) != before

    def reads(self, expr: ast.AST) -> bool:
        for node in ast.walk(expr):
            if _is_clock_call(node):
                return True
            if isinstance(node, ast.Name) and node.id in self.names:
                return True
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id in self.functions
            ):
                return True
        return False


def clock_assertions(source: str) -> list[int]:
    """The lines of ``source`` whose ``assert`` reads a clock (rule 1)."""
    tree = ast.parse(source)
    clocks = _Clocks(tree)
    return [
        node.lineno
        for node in ast.walk(tree)
        if isinstance(node, ast.Assert) and clocks.reads(node.test)
    ]


def checkout_results(source: str) -> list[int]:
    """The lines of ``source`` that join the checkout's root with ``results`` (rule 2)."""
    tree = ast.parse(source)
    roots = {
        name
        for node in tree.body
        if isinstance(node, ast.Assign)
        and any(isinstance(n, ast.Name) and n.id == "__file__" for n in ast.walk(node.value))
        for target in node.targets
        for name in _names(target)
    }
    lines = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div)):
            continue
        left, right = node.left, node.right
        while isinstance(left, ast.BinOp) and isinstance(left.op, ast.Div):
            left = left.left
        if (
            isinstance(left, ast.Name)
            and left.id in roots
            and isinstance(right, ast.Constant)
            and isinstance(right.value, str)
            and right.value.split("/")[0] == "results"
        ):
            lines.append(node.lineno)
    return lines


def _test_files() -> list[Path]:
    return sorted(TESTS.rglob("*.py"))


def test_no_assertion_reads_a_clock() -> None:
    found = [
        f"{path.relative_to(TESTS)}:{line}"
        for path in _test_files()
        for line in clock_assertions(path.read_text(encoding="utf-8"))
    ]
    assert found == [], "assertions on a wall time (speed belongs in make bench): " + ", ".join(
        found
    )


def test_no_test_reads_the_checkouts_results() -> None:
    found = [
        f"{path.relative_to(TESTS)}:{line}"
        for path in _test_files()
        for line in checkout_results(path.read_text(encoding="utf-8"))
    ]
    assert found == [], "tests reading the checkout's results/: " + ", ".join(found)


def test_the_rules_catch_what_they_name() -> None:
    """Each rule on a deliberate violation, and on the allowed form beside it (an assertion
    of the sample spread over lines is still one assertion: its first line is reported)."""
    timed = textwrap.dedent(
        """
        import time
        from time import perf_counter

        def _open(page):
            started = time.perf_counter()
            page.goto("/")
            return time.perf_counter() - started

        def test_fast(page):
            start = time.monotonic()
            run()
            assert (
                time.monotonic() - start < 30
            )
            took, starved = time.monotonic() - start, 0.0
            assert took - starved < 2.0
            seconds = _open(page)
            assert seconds <= 1.0
            seen = page.evaluate("() => performance.now() - t0")
            assert seen <= 3.0
            assert (
                perf_counter() > 0
            )

        def test_allowed(proc):
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.1)
            assert proc.returncode == 0
        """
    )
    assert clock_assertions(timed) == [13, 17, 19, 21, 22]
    reads = textwrap.dedent(
        """
        from pathlib import Path

        ROOT = Path(__file__).resolve().parents[1]
        MODEL = ROOT / "results/model/s1"

        def test_model(tmp_path):
            assert (ROOT / "results" / "model").exists()
            assert (tmp_path / "results").exists()
            assert (ROOT / "data" / "grid_s1").exists()
        """
    )
    assert checkout_results(reads) == [5, 8]


def test_the_session_looks_for_models_in_an_empty_results_folder() -> None:
    """Rule 2's other half: whatever the checkout's ``results/`` holds (and whatever
    ``$MIKETALK_MODEL`` said when ``make test`` started), the product's default model and
    the page's workflow models are looked for in the session's empty folder."""
    import os

    from miketalk.model.parts import default_model_dir, workflow_results
    from miketalk.serve.catalog import workflow_models

    assert "MIKETALK_MODEL" not in os.environ
    empty = Path(os.environ["MIKETALK_RESULTS"])
    assert workflow_results() == [empty]
    assert default_model_dir().is_relative_to(empty) and not default_model_dir().exists()
    assert workflow_models() == []
