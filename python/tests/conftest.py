"""Shared fixtures: the repository's paths, the `tetsim` binary, scenes written to a temp dir."""

import os
import pathlib
import re
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCENES = ROOT / "scenes"
FIXTURES = ROOT / "tests" / "fixtures"


def cli_binary():
    """The `tetsim` command: $TETSIM_BIN (CI sets it; it must then exist), else a build in
    target/, else `tetsim` on PATH; None when there is none."""
    given = os.environ.get("TETSIM_BIN")
    if given:
        path = pathlib.Path(given)
        if not path.is_absolute():
            path = ROOT / path
        assert path.exists(), f"TETSIM_BIN={given} does not exist"
        return path
    for profile in ("release", "debug"):
        path = ROOT / "target" / profile / "tetsim"
        if path.exists():
            return path
    found = shutil.which("tetsim")
    return pathlib.Path(found) if found else None


@pytest.fixture
def tetsim_bin():
    path = cli_binary()
    if path is None:
        pytest.skip("no tetsim binary: build it with `cargo build --release` or set TETSIM_BIN")
    return path


def run_cli(binary, *args, cwd=None):
    """Run the command line; returns (exit code, stdout, stderr)."""
    done = subprocess.run(
        [str(binary), *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=600
    )
    return done.returncode, done.stdout, done.stderr


def scene_copy(tmp_path, name, frames, extra=""):
    """scenes/NAME with `frames` frames, written into tmp_path with its mesh paths made
    absolute, so the command line and Python read the very same file."""
    text = (SCENES / name).read_text()
    text = re.sub(r"(?m)^frames = \d+", f"frames = {frames}", text)
    text = re.sub(
        r'(?m)^(file|positions) = "([^"]+)"',
        lambda m: f'{m.group(1)} = "{(SCENES / m.group(2)).as_posix()}"',
        text,
    )
    path = tmp_path / name
    path.write_text(text + extra)
    return path
