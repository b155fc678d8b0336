"""Shared fixtures: one renderer for every test (opening a device costs ~a second), the
repository's assets and the CLI to compare with."""

import os
import pathlib
import shutil
import subprocess

import pytest

import rqr

ROOT = pathlib.Path(__file__).resolve().parents[2]
ASSETS = ROOT / "assets" / "gltf"


@pytest.fixture(scope="package")
def renderer():
    with rqr.Renderer() as r:
        yield r


@pytest.fixture(scope="package")
def builtin(renderer):
    return renderer.load()


def asset(name: str) -> pathlib.Path:
    """A glTF of assets/gltf by directory name, from its INDEX.tsv entry."""
    for line in (ASSETS / "INDEX.tsv").read_text().splitlines()[1:]:
        cols = line.split("\t")
        if cols[0] == name:
            return ASSETS / cols[1]
    raise KeyError(name)


def cli() -> list:
    """The command that runs the CLI: $RQR_CLI, else target/debug/rqr, else `cargo run`."""
    exe = os.environ.get("RQR_CLI") or str(ROOT / "target" / "debug" / "rqr")
    if os.path.isfile(exe) and os.access(exe, os.X_OK):
        return [exe]
    if shutil.which("cargo"):
        return ["cargo", "run", "--quiet", "--manifest-path", str(ROOT / "Cargo.toml"), "--bin", "rqr", "--"]
    pytest.fail("no rqr CLI: set RQR_CLI or build it with `cargo build --bin rqr`")


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(cli() + list(args), check=True, capture_output=True, text=True)
