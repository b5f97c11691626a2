"""Shared fixtures: where the repository's data and the `thinshell` binary are."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "data" / "scenes"


def thinshell_bin() -> Path | None:
    """The CLI binary: $THINSHELL_BIN (set by `cargo xtask test`), else the target dir's."""
    env = os.environ.get("THINSHELL_BIN")
    if env:
        return Path(env)
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    p = target / "release" / "thinshell"
    return p if p.exists() else None


@pytest.fixture
def cli() -> Path:
    p = thinshell_bin()
    if p is None or not p.exists():
        pytest.skip("the thinshell binary was not found (set THINSHELL_BIN or build it: cargo build --release)")
    return p


@pytest.fixture
def scenes() -> Path:
    return SCENES
