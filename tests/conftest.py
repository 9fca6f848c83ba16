"""Under ``make test`` (``MIKETALK_NO_SKIP=1``) a skipped test is a failure.

Tests that need Festival or Chromium skip when they are missing, so that a
developer can run the rest without them; ``make test`` and CI install both, and
a skip there would hide a missing install step.
"""

from __future__ import annotations

import os

import pytest


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    outcome = yield
    report = outcome.get_result()
    if report.skipped and os.environ.get("MIKETALK_NO_SKIP") == "1":
        reason = report.longrepr[-1] if isinstance(report.longrepr, tuple) else report.longrepr
        report.outcome = "failed"
        report.longrepr = f"skipped under make test (MIKETALK_NO_SKIP=1): {reason}"
