# SPDX-License-Identifier: Apache-2.0
"""Shared fixtures of the hapticopt Python tests: repository paths, the C++ CLI, the Agg backend."""
from __future__ import annotations

import os
import pathlib
import shutil

import pytest

REPOSITORY = pathlib.Path(__file__).resolve().parents[2]
PAPER_TABLES = REPOSITORY / "tests" / "data" / "paper_tables.csv"
VERSION_HEADER = REPOSITORY / "include" / "hapticopt" / "version.hpp"


@pytest.fixture(scope="session")
def cli() -> str:
    """The C++ CLI `hapticopt` (apps/hapticopt): $HAPTICOPT_CLI, else build/release's, else PATH.
    Missing is a failure, not a skip: these tests are the check that both languages agree."""
    candidates = [os.environ.get("HAPTICOPT_CLI"), str(REPOSITORY / "build/release/apps/hapticopt/hapticopt"),
                  shutil.which("hapticopt")]
    for c in candidates:
        if c and os.access(c, os.X_OK):
            return c
    pytest.fail("the C++ CLI `hapticopt` was not found: build the target hapticopt_cli and set HAPTICOPT_CLI")


@pytest.fixture(autouse=True, scope="session")
def agg_backend():
    import matplotlib

    matplotlib.use("Agg")
