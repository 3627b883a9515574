"""Packaging (issue 27): the wheel ships ``py.typed`` for every package and the licence file, and
building it prints no deprecation warning from the project's metadata (PEP 639: an SPDX
``license`` string plus ``license-files``, which needs setuptools >= 77).

The wheel is built from a copy of the sources in a temporary folder (the working tree gets no
``build/`` or ``*.egg-info``), without build isolation, so no network is needed.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("liecontrol", "spacecraft", "benchmarks")


@pytest.fixture(scope="module")
def built_wheel(tmp_path_factory) -> tuple[Path, str]:
    setuptools = pytest.importorskip("setuptools")
    major = int(setuptools.__version__.split(".")[0])
    assert major >= 77, (
        f"setuptools {setuptools.__version__} cannot read the PEP 639 licence metadata; "
        "pip install -e '.[dev]' installs setuptools >= 77"
    )
    src = tmp_path_factory.mktemp("src")
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, src / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for pkg in PACKAGES:
        shutil.copytree(ROOT / pkg, src / pkg, ignore=ignore)
    out = tmp_path_factory.mktemp("wheel")
    # the PEP 517 hook itself, with every warning shown (pip would hide the backend's output)
    code = (
        "import sys; from setuptools import build_meta; "
        "print(build_meta.build_wheel(sys.argv[1]))"
    )
    proc = subprocess.run(
        [sys.executable, "-W", "always", "-c", code, str(out)],
        cwd=src, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-3000:]
    wheels = list(out.glob("liecontrol-*.whl"))
    assert len(wheels) == 1, log[-3000:]
    return wheels[0], log


def test_wheel_ships_py_typed_and_the_licence(built_wheel):
    wheel, _ = built_wheel
    names = set(zipfile.ZipFile(wheel).namelist())
    for pkg in PACKAGES:
        assert f"{pkg}/py.typed" in names, f"{pkg}/py.typed missing from {wheel.name}"
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), sorted(names)[-10:]
    meta = next(n for n in names if n.endswith(".dist-info/METADATA"))
    text = zipfile.ZipFile(wheel).read(meta).decode()
    assert "License-Expression: MIT" in text and "License-File: LICENSE" in text


def test_building_prints_no_deprecation_warning(built_wheel):
    _, log = built_wheel
    bad = [ln for ln in log.splitlines() if "deprecat" in ln.lower()]
    assert not bad, "\n".join(bad[:10])


def test_licence_file_is_mit_by_the_liecontrol_developers():
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License") and "The liecontrol developers" in text
