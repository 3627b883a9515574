"""The CLI users extend: ``--plugin`` modules and files that register controllers or scenarios,
one-line errors for broken plug-ins and empty selections, ``reproduce --list`` with citations,
and no BrokenPipe traceback when the reader closes early (``--list | head``)."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

from benchmarks import cli
from benchmarks.controllers import CONTROLLERS, unregister
from benchmarks.reproductions import REPRODUCTIONS, load

PLUGIN_PD = textwrap.dedent('''
    """A user's tiny PD, registered from a plug-in file."""
    import numpy as np

    from benchmarks.controllers import register
    from liecontrol.control import AttitudeController
    from liecontrol.lie import so3


    class TinyPD(AttitudeController):
        batched = True

        def __init__(self, J, k_p, k_d):
            self.J, self.k_p, self.k_d = J, k_p, k_d

        def reset(self, t0, batch_size):
            pass

        def command(self, t, state, reference):
            R_e = np.swapaxes(reference.R_d, -1, -2) @ state.R
            e_R = so3.log(R_e)
            e_w = state.omega - np.einsum("bji,bj->bi", R_e, reference.omega_d)
            return -(self.k_p * e_R + self.k_d * e_w) @ self.J.T


    def factory(ctx):
        w, z = 0.05, 0.9
        return TinyPD(np.asarray(ctx.J, dtype=float), w * w, 2 * z * w)


    register("{name}", factory, description="tiny plug-in PD", quick=False)
''')


@pytest.fixture
def plugin_file(tmp_path):
    name = "tiny-plugin-pd"
    path = tmp_path / "my_tiny_pd.py"
    path.write_text(PLUGIN_PD.replace("{name}", name), encoding="utf-8")
    yield path, name
    if name in CONTROLLERS:
        unregister(name)


def test_plugin_file_registers_a_controller_that_runs(plugin_file, tmp_path, capsys):
    path, name = plugin_file
    out = tmp_path / "rep"
    code = cli.main(["run", "--plugin", str(path), "--controllers", name, "--scenarios",
                     "stabilisation", "--t-final", "20", "--out", str(out), "--no-progress",
                     "--no-figures", "--executor", "serial"])
    assert code == 0, capsys.readouterr().err
    doc = json.loads((out / "metrics.json").read_text(encoding="utf-8"))
    (res,) = [r for r in doc["results"] if r["controller"] == name]
    assert res["status"] == "ok"
    # loading the same file again in this process is a no-op, not a duplicate registration
    assert cli.main(["run", "--plugin", str(path), "--list"]) == 0
    assert name in capsys.readouterr().out


def test_plugin_errors_are_one_line(plugin_file, tmp_path, capsys):
    path, name = plugin_file
    # a second file registering the same name: duplicate
    dup = tmp_path / "dup_pd.py"
    dup.write_text(PLUGIN_PD.replace("{name}", "geometric-pd-log"), encoding="utf-8")
    assert cli.main(["run", "--plugin", str(dup), "--list"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert err.startswith(f"error: plugin {dup}: ValueError: name: controller "
                          "'geometric-pd-log' is already registered")
    assert cli.main(["run", "--plugin", str(tmp_path / "missing.py"), "--list"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "missing.py" in err and "FileNotFoundError" in err
    broken = tmp_path / "broken.py"
    broken.write_text("def f(:\n", encoding="utf-8")
    assert cli.main(["reproduce", "--plugin", str(broken), "--list"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "SyntaxError" in err and "broken.py" in err
    assert cli.main(["run", "--plugin", "no_such_module_xyz", "--list"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("error: plugin no_such_module_xyz: ModuleNotFoundError: No module named "
                   "'no_such_module_xyz'")


def test_plugin_by_module_name(tmp_path, monkeypatch, capsys):
    (tmp_path / "user_scenarios_mod.py").write_text(textwrap.dedent('''
        import dataclasses

        from benchmarks.scenarios import get_scenario, register_scenario

        register_scenario(dataclasses.replace(get_scenario("slew-90"), name="my-slew"))
    '''), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    from benchmarks.scenarios import SCENARIOS, unregister_scenario

    try:
        assert cli.main(["run", "--plugin", "user_scenarios_mod", "--list"]) == 0
        assert "my-slew" in capsys.readouterr().out
    finally:
        if "my-slew" in SCENARIOS:
            unregister_scenario("my-slew")
        sys.modules.pop("user_scenarios_mod", None)


def test_empty_selection_exits_2_saying_why(capsys):
    assert cli.main(["run", "--controllers", "bullo-murray-pd", "--scenarios", "slew-90",
                     "--out", "x"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert err.startswith("error: nothing to run: no selected controller applies")
    assert "bullo-murray-pd" in err and "slew-90" in err and "SE(3) controller" in err
    assert cli.main(["run", "--scenarios", ",", "--out", "x"]) == 2
    assert "nothing to run: the selection has no scenario" in capsys.readouterr().err


def test_reproduce_list_names_and_citations(capsys):
    assert cli.main(["reproduce", "--list"]) == 0
    out = capsys.readouterr().out
    assert list(REPRODUCTIONS) == ["adrc-sgcmg", "strong-tracking-ukf",
                                   "geometric-survey-lemmas", "rotating-payload",
                                   "terminal-sliding-mode-rvd"]
    for name in REPRODUCTIONS:
        mod = load(name)
        assert mod.NAME == name and callable(mod.main)
        assert name in out and str(mod.CITATION) in out and mod.SUMMARY in out
    for authors in ("Wu, Huang, Wei & Guo", "Wang, Li, Zhang, Zhu & Li", "Jiang, Meng & Yang",
                    "Wang, Chu, Zhang & Yuan", "Liu, Tang & Yu"):
        assert authors in out
    assert "seed" not in out.lower()
    assert cli.main(["reproduce", "seed000"]) == 2
    assert "valid reproductions: adrc-sgcmg" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["run", "--list"], ["reproduce", "--list"]])
def test_listing_into_a_closed_pipe_has_no_traceback(argv):
    """The reader takes one line and closes the pipe (what ``| head -1`` does)."""
    proc = subprocess.Popen([sys.executable, "-m", "benchmarks", *argv],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    first = proc.stdout.readline()
    proc.stdout.close()
    err = proc.stderr.read().decode()
    proc.stderr.close()
    code = proc.wait(timeout=120)
    assert first
    assert "Traceback" not in err and "BrokenPipeError" not in err, err
    assert code == 0
