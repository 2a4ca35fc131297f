"""Shared fixtures of the Python tests: the CLI binary (for comparisons with
`phyxel run --json`) and small scenes."""

import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli():
    """The `phyxel` binary: $PHYXEL_BIN, else target/release/phyxel (built by
    `cargo test --release`, which `.ci/run` runs first)."""
    path = pathlib.Path(os.environ.get("PHYXEL_BIN", ROOT / "target" / "release" / "phyxel"))
    assert path.is_file(), f"no phyxel binary at {path}: run `cargo build --release` or set PHYXEL_BIN"
    return str(path)
