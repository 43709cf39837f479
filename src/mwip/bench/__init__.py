"""The robustness benchmark, ``mwip bench`` (docs/bench.md): every entrant scored on separate
axes (model parameters, the twin's unknowns, measurement and actuator noise, dead-band,
responsiveness, delay, payload, push), each level a success fraction over a fixed, seeded set
of runs with its Wilson 95 % interval, plus the performance of the successful runs.

- :mod:`mwip.bench.spec` - the definition as data (``bench.toml``: axes, levels, sizes);
- :mod:`mwip.bench.run` - the entrants and the runs as blocks of the campaign engine;
- :mod:`mwip.bench.entrants` - registry names, settings files, scenario files;
- :mod:`mwip.bench.scores` - ``scores.parquet`` and the leaderboard's ranking;
- :mod:`mwip.bench.page` - ``index.html`` and its PNGs;
- :mod:`mwip.bench.finish` - a whole run: the runs, the scores, the page;
- the click command is :mod:`mwip.cli.bench` (``mwip bench``).
"""

from __future__ import annotations

__all__: list[str] = []
