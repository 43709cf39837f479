"""Robust gain tuning with Optuna (issue 27): ``mwip tune CONTROLLER --out DIR``.

:mod:`mwip.tune.objective` says what is optimised (a TOML file: success rate first, then RMS
pitch / speed error, chattering, torque within the drive's limit; or a Pareto front);
:mod:`mwip.tune.space` builds the search space from the registry's allowed ranges;
:mod:`mwip.tune.evaluate` runs candidate settings on a set of robots (the campaign's block
runner, on the twin or the plain plant); :mod:`mwip.tune.study` holds the Optuna study
(storage, per-trial seeded samplers, pruning, resuming after ``kill -9``);
:mod:`mwip.tune.validate` compares the tuned settings with the book's on new robots;
:mod:`mwip.tune.page` draws the result page; :mod:`mwip.tune.run` ties them together and
:mod:`mwip.cli.tune` is the command line. Optuna is an optional extra
(``pip install 'mwip[tune]'``).
"""

from __future__ import annotations

__all__: list[str] = []
