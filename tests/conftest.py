"""Fixtures shared by the driver tests: a fresh plain pyvisa-sim bench and a bus recorder."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import pyvisa

DEFINITIONS = Path(__file__).resolve().parents[1] / "simbench" / "definitions"


@pytest.fixture
def rm(tmp_path):
    """Plain pyvisa-sim over the shipped definitions, each test with its own copy: no shared state."""
    for path in DEFINITIONS.glob("*.yaml"):
        shutil.copy(path, tmp_path)
    manager = pyvisa.ResourceManager(f"{tmp_path / 'bench.yaml'}@sim")
    yield manager
    manager.close()


@pytest.fixture
def sent(resource, monkeypatch):
    """Every message written to the module's `resource` fixture (queries included)."""
    messages: list[str] = []
    write = resource.write

    def recording_write(message, *args, **kwargs):
        messages.append(message)
        return write(message, *args, **kwargs)

    monkeypatch.setattr(resource, "write", recording_write)
    return messages
