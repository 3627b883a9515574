"""The CLI's closing line counts verdicts (not the runner's status), names the program the way it
was invoked, and documents that a ``failed`` verdict does not change the exit status."""

from __future__ import annotations

import re

import pytest

from benchmarks import cli
from benchmarks.runner import RunOutcome


def _o(verdict: str, status: str = "ok") -> RunOutcome:
    return RunOutcome("s", "c", status, verdict=verdict)


def test_verdict_summary_counts_every_verdict_and_sets_not_applicable_apart():
    outs = (
        [_o("success")] * 3
        + [_o("degraded")] * 2
        + [_o("failed")] * 4
        + [_o("error", "failed")]
        + [_o("not-applicable", "n/a")] * 5
    )
    # 10 runs judged + 5 not applicable; hand count of the list above
    assert cli._verdict_summary(outs) == (
        "10 runs + 5 not-applicable: 3 success, 2 degraded, 4 failed, 1 error"
    )
    # one run: singular, and no "+ 0 not-applicable"
    assert cli._verdict_summary([_o("success")]) == (
        "1 run: 1 success, 0 degraded, 0 failed, 0 error"
    )
    # unjudged outcomes fall back on their status; a plug-in's own verdict is kept, not lost
    mixed = [_o("", "n/a"), _o("", "failed"), _o("great")]
    assert cli._verdict_summary(mixed) == (
        "2 runs + 1 not-applicable: 0 success, 0 degraded, 0 failed, 1 error, 1 great"
    )


@pytest.mark.parametrize(
    ("argv0", "expected"),
    [
        ("/usr/local/bin/liecontrol-bench", "liecontrol-bench"),
        ("liecontrol-bench", "liecontrol-bench"),
        (r"C:\Python\Scripts\liecontrol-bench.exe", "liecontrol-bench"),
        ("/repo/benchmarks/__main__.py", "python -m benchmarks"),
        ("/usr/lib/python3/site-packages/pytest/__main__.py", "python -m benchmarks"),
        ("", "python -m benchmarks"),
    ],
)
def test_program_name_follows_how_we_were_invoked(argv0, expected):
    if "\\" in argv0:  # a Windows path: basename splits on "\\" only on Windows
        argv0 = argv0.replace("\\", "/")
    assert cli.program_name(argv0) == expected


def test_usage_and_reproduce_list_use_the_program_name(capsys, monkeypatch):
    usage = cli.build_parser(prog="liecontrol-bench").format_usage()
    assert usage.startswith("usage: liecontrol-bench ")
    monkeypatch.setattr("sys.argv", ["/opt/venv/bin/liecontrol-bench"])
    assert cli.build_parser().prog == "liecontrol-bench"
    assert cli.main(["reproduce", "--list"]) == 0
    assert capsys.readouterr().out.startswith("reproductions (liecontrol-bench reproduce NAME")
    monkeypatch.setattr("sys.argv", ["/repo/benchmarks/__main__.py"])
    assert cli.build_parser().prog == "python -m benchmarks"


def test_help_documents_that_a_failed_verdict_is_not_an_error_exit():
    text = " ".join(cli.build_parser(prog="x").format_help().split())
    assert "'failed' verdict" in text and "is a finding, not a crash" in text
    assert "1 when some run raised" in text


def test_a_failed_verdict_exits_0_and_the_closing_line_counts_it(tmp_path, capsys):
    """slew-90 cut to 5 s cannot settle: verdict failed, yet every run completed → exit 0."""
    code = cli.main(
        ["run", "--scenarios", "slew-90", "--controllers", "geometric-pd-log", "--t-final",
         "5", "--out", str(tmp_path), "--no-progress", "--no-figures", "--executor", "serial"]
    )  # fmt: skip
    assert code == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    # the closing time says what it covers (the report header's covers the simulation only)
    assert re.search(r"\(1 run: 0 success, 0 degraded, 1 failed, 0 error; total wall time "
                     r"[\d.]+ s including report and figures, ", line), line  # fmt: skip


def test_program_name_and_parser_reject_a_non_string():
    with pytest.raises(TypeError, match="^argv0:"):
        cli.program_name(3)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="^prog:"):
        cli.build_parser(prog=b"liecontrol-bench")  # type: ignore[arg-type]
