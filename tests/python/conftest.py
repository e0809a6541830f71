"""Fixtures of the package's tests: the lamina executable and the repository (set by ctest,
tests/python/CMakeLists.txt), and a runner of the command line."""

import os
import subprocess
from pathlib import Path

import pytest

SOURCE = Path(os.environ.get("LAMINA_SOURCE", Path(__file__).resolve().parents[2]))
EXE = os.environ.get("LAMINA_EXE", str(SOURCE / "build" / "renderer" / "lamina"))


@pytest.fixture
def source() -> Path:
    return SOURCE


def run_cli(*args, check=True):
    """Runs `lamina ARGS`; returns the completed process (stdout, stderr as text)."""
    p = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"lamina {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr}")
    return p


@pytest.fixture
def cli():
    return run_cli
