"""The compiled-kernel disk cache cannot run stale code (liecontrol._jit).

numba's own ``cache=True`` checks only the source file of the function it loads; a cached caller
keeps the code of the helpers it was compiled with. Here the cache directory is keyed by a hash
of every kernel source, so an edit of a helper in one file reaches its caller in another, and
reverting the edit brings back the original machine code. Each case runs in a subprocess on a
temporary copy of the package (the working tree is never touched).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from liecontrol import _jit

pytestmark = pytest.mark.skipif(not _jit.JIT_ENABLED, reason="numba is not in use")

ROOT = Path(__file__).resolve().parents[1]

# the caller (liecontrol/_kernels/attitude.py) compiles the helper log9 of another file in
_PROBE = textwrap.dedent(
    """
    import json, sys
    import liecontrol
    from liecontrol._kernels import attitude
    from liecontrol.lie import so3
    assert liecontrol.__file__.startswith(sys.argv[1]), liecontrol.__file__
    T = tuple(so3.exp([0.1, -0.2, 0.3]).T.ravel().tolist())
    v = attitude.error_log(T)
    st = attitude.error_log.stats
    print(json.dumps({"v": list(v), "hits": sum(st.cache_hits.values()),
                      "path": st.cache_path}))
    """
)

# a one-character change of the helper: its rotation vector doubled
_HELPER = "liecontrol/_kernels/so3.py"
_OLD = "        return v0 * k, v1 * k, v2 * k\n"
_NEW = "        return 2.0 * v0 * k, v1 * k, v2 * k\n"


@pytest.fixture
def package(tmp_path: Path) -> Path:
    dest = tmp_path / "src"
    shutil.copytree(
        ROOT / "liecontrol", dest / "liecontrol", ignore=shutil.ignore_patterns("__pycache__")
    )
    return dest


def _probe(src: Path, tmp: Path, **env_extra: str) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
    env.pop("LIECONTROL_DISABLE_JIT", None)
    env.update(PYTHONPATH=str(src), XDG_CACHE_HOME=str(tmp / "xdg"), HOME=str(tmp / "home"))
    env.update(env_extra)
    p = subprocess.run(
        [sys.executable, "-c", _PROBE, str(src)], cwd=tmp, env=env, capture_output=True,
        text=True, timeout=300,
    )  # fmt: skip
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_editing_a_helper_recompiles_its_caller_and_reverting_restores_it(package, tmp_path):
    helper = package / _HELPER
    original = helper.read_text(encoding="utf-8")
    assert original.count(_OLD) == 1, "the probe's helper line moved: update _OLD"
    expected = so3_log([0.1, -0.2, 0.3])

    first = _probe(package, tmp_path)
    np.testing.assert_allclose(first["v"], expected, rtol=1e-12)
    again = _probe(package, tmp_path)
    assert again["hits"] >= 1 and again["v"] == first["v"]  # the cache is used

    helper.write_text(original.replace(_OLD, _NEW), encoding="utf-8")
    edited = _probe(package, tmp_path)
    # numba's own cache would load the caller compiled with the old helper here
    np.testing.assert_allclose(edited["v"], [2.0 * expected[0], *expected[1:]], rtol=1e-12)

    helper.write_text(original, encoding="utf-8")
    reverted = _probe(package, tmp_path)
    assert reverted["v"] == first["v"]
    assert reverted["hits"] >= 1  # the original machine code, loaded again
    # where: inside the package, one directory per state of the kernel sources
    assert Path(first["path"]).is_relative_to(package / "liecontrol" / "__pycache__")
    assert edited["path"] != first["path"] and reverted["path"] == first["path"]


def test_read_only_package_falls_back_to_the_user_cache(package, tmp_path):
    # a file where the package's __pycache__ would be: not writable, even for root
    for d in (package / "liecontrol", package / "liecontrol" / "_kernels"):
        (d / "__pycache__").write_text("", encoding="utf-8")
    first = _probe(package, tmp_path)
    assert Path(first["path"]).is_relative_to(tmp_path / "xdg" / "liecontrol")
    again = _probe(package, tmp_path)
    assert again["hits"] >= 1 and again["v"] == first["v"]


def test_an_explicit_numba_cache_dir_is_honoured(package, tmp_path):
    out = _probe(package, tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "nc"))
    assert Path(out["path"]).is_relative_to(tmp_path / "nc")
    assert Path(out["path"]).relative_to(tmp_path / "nc").parts[0].startswith("liecontrol-")


def test_every_kernel_module_is_hashed():
    """The hash covers every module that uses njit or numba (found by reading the sources, not
    from a list), and the modules they import constants from."""
    import spacecraft

    roots = {
        "liecontrol": Path(_jit.__file__).parent,
        "spacecraft": Path(spacecraft.__file__).parent,
    }
    hashed = {label for label, _ in _jit.kernel_sources(roots)}
    users = set()
    for name, root in roots.items():
        for p in root.rglob("*.py"):
            if "__pycache__" in p.parts:
                continue
            text = p.read_text(encoding="utf-8")
            if "@njit" in text or "\nimport numba" in text or "\nfrom numba" in text:
                users.add(f"{name}/{p.relative_to(root).as_posix()}")
    assert users and users <= hashed, sorted(users - hashed)
    assert "liecontrol/_kernels/so3.py" in hashed and "spacecraft/_kernels.py" in hashed


def so3_log(w: list[float]) -> np.ndarray:
    """The rotation vector of exp(w^) for ‖w‖ < π is w (through the numpy API)."""
    from liecontrol.lie import so3

    return so3.log(so3.exp(np.asarray(w)))


def test_the_hash_follows_every_kernel_source_across_packages(tmp_path):
    """spacecraft's kernels call liecontrol's: its hash changes with a liecontrol kernel, and
    with a module a kernel module imports at module level; not with numpy-only code; and it
    comes back when the edit is reverted."""
    import spacecraft

    for name, mod in (("liecontrol", _jit), ("spacecraft", spacecraft)):
        src = Path(mod.__file__).parent
        shutil.copytree(src, tmp_path / name, ignore=shutil.ignore_patterns("__pycache__"))
    roots = {"liecontrol": tmp_path / "liecontrol", "spacecraft": tmp_path / "spacecraft"}
    h0 = _jit.sources_hash(roots)

    def changed(rel: str, text: str) -> bool:
        p = tmp_path / rel
        old = p.read_text(encoding="utf-8")
        p.write_text(old + text, encoding="utf-8")
        h = _jit.sources_hash(roots)
        p.write_text(old, encoding="utf-8")
        assert _jit.sources_hash(roots) == h0  # reverted: the same directory again
        return h != h0

    assert changed("liecontrol/_kernels/so3.py", "\n_EDITED = 1.0\n")  # a helper of spacecraft's
    assert changed("spacecraft/_kernels.py", "\n# edited\n")
    assert changed("spacecraft/_kernels_vscmg.py", "\n# edited\n")
    # a constant module imported by a kernel module (its value is frozen into machine code)
    (tmp_path / "spacecraft/_limits.py").write_text("LIMIT = 1.0\n", encoding="utf-8")
    k = tmp_path / "spacecraft/_kernels.py"
    k.write_text(k.read_text(encoding="utf-8") + "\nfrom ._limits import LIMIT  # noqa\n")
    h0 = _jit.sources_hash(roots)
    assert changed("spacecraft/_limits.py", "LIMIT = 2.0\n")
    # numpy-only code does not invalidate the compiled kernels
    assert not changed("liecontrol/control/adaptive.py", "\n# edited\n")
    assert not changed("spacecraft/plant.py", "\n# edited\n")


def test_old_hash_directories_are_pruned_and_nothing_else(tmp_path, monkeypatch):
    monkeypatch.setattr(_jit, "_PRUNED", set())
    dirs = []
    for i in range(10):
        d = tmp_path / f"numba-{i:016x}"
        d.mkdir()
        os.utime(d, (1e9 + i, 1e9 + i))
        dirs.append(d)
    others = [tmp_path / "numba-notahash", tmp_path / "spacecraft-0123", tmp_path / "keepme"]
    for d in others:
        d.mkdir()
    keep = dirs[0]  # the one in use, even if it is the oldest
    _jit._prune(tmp_path, "numba-", keep)
    left = {p.name for p in tmp_path.iterdir()}
    newest = {d.name for d in dirs[-(_jit.KEEP_CACHES - 1) :]}
    assert left == newest | {keep.name} | {d.name for d in others}
