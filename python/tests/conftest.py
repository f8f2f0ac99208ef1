"""Fixtures: the repository's scenes and the `sism` command line the package is checked against.

The command line is `$SISM_BIN`, else the workspace's `target/debug/sism` or `target/release/sism`;
where there is none and `cargo` is on the PATH, it is built (`cargo build --bin sism`, a few minutes
once). Without one, the tests that compare with it are skipped, unless `CI` is set: then they fail,
as a missing yardstick must not pass silently.
"""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def plate() -> Path:
    return REPO / "scenes" / "plate.toml"


def _find_cli():
    env = os.environ.get("SISM_BIN")
    if env:
        return Path(env)
    for profile in ("debug", "release"):
        p = REPO / "target" / profile / "sism"
        if p.is_file():
            return p
    if shutil.which("cargo") and (REPO / "Cargo.toml").is_file():
        print("building the sism command line the tests compare with (cargo build --bin sism)")
        built = subprocess.run(["cargo", "build", "--bin", "sism"], cwd=REPO, check=False)
        p = REPO / "target" / "debug" / "sism"
        if built.returncode == 0 and p.is_file():
            return p
    return None


@pytest.fixture(scope="session")
def cli():
    """Runs the `sism` command line: cli(args..., cwd=...) -> stdout (str); fails on a non-zero exit."""
    exe = _find_cli()
    if exe is None:
        message = "no sism binary (set SISM_BIN or run `cargo build`)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)

    def run(*args, cwd=None):
        out = subprocess.run(
            [str(exe), *map(str, args)], cwd=cwd, capture_output=True, text=True, check=False
        )
        assert out.returncode == 0, f"sism {' '.join(map(str, args))} failed:\n{out.stderr}"
        return out.stdout

    return run


def read_pfm(path: Path) -> np.ndarray:
    """A one-channel PFM as float32 (height, width), rows top to bottom: an independent reader."""
    data = Path(path).read_bytes()
    magic, dims, scale, rest = data.split(b"\n", 3)
    assert magic == b"Pf"
    width, height = map(int, dims.split())
    dtype = "<f4" if float(scale) < 0 else ">f4"
    return np.frombuffer(rest, dtype=dtype).reshape(height, width)[::-1].astype(np.float32)


def read_stats(path: Path) -> dict:
    return json.loads(Path(path).read_text())
