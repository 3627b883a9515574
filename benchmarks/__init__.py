"""The benchmark suite of liecontrol: every controller on one plant, judged by requirements.

How the package is organised (each module imports only the layers above it in this list):

- **scenario data** — :mod:`~benchmarks.requirements` (ECSS pointing errors, bounds),
  :mod:`~benchmarks.dispersion` (seeded members), :mod:`~benchmarks.scenarios` (the catalogue
  and suites), :mod:`~benchmarks.fault_scenarios` (the fault family, registered on import of
  the package), :mod:`~benchmarks.scenario_files` (TOML/YAML);
- **controllers** — :mod:`~benchmarks.controllers` (the registry and the common tuning);
- **suite engine** — :mod:`~benchmarks.executors`, :mod:`~benchmarks.metrics` (metrics and the
  single-run judge), :mod:`~benchmarks.histories`, :mod:`~benchmarks.ranking` (cell verdicts
  with confidence, ranks, aliases), :mod:`~benchmarks.runner` (``run_suite``);
- **reports** — :mod:`~benchmarks.tuning_report`, :mod:`~benchmarks.ranking_report`,
  :mod:`~benchmarks.report`, :mod:`~benchmarks.results_file`, :mod:`~benchmarks.montecarlo`;
- **studies** built on the engine — :mod:`~benchmarks.unwinding`,
  :mod:`~benchmarks.finite_time_study`, :mod:`~benchmarks.cmg_model_study`,
  :mod:`~benchmarks.singular_transit`, :mod:`~benchmarks.policies`;
- **performance scripts** — ``benchmarks.perf_*`` (``python -m benchmarks.perf_basilisk`` …);
- **reproductions** of published results — :mod:`benchmarks.reproductions`;
- **command line** — :mod:`~benchmarks.cli` (``liecontrol-bench``).

``tests/test_layering.py`` checks that no two modules of the package import each other.
"""

from . import fault_scenarios as _fault_scenarios  # noqa: F401 - registers the fault family
