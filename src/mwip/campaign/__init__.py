"""Robustness campaigns: Monte Carlo, regions of attraction and claim robustness at scale.

A campaign is data (:mod:`mwip.campaign.spec`, a TOML file): controllers (registry names and
settings) x robot uncertainty x initial states x disturbances x sensors x seeds, N samples.
:mod:`mwip.campaign.sampling` draws sample ``i`` from the campaign seed and ``i`` alone;
:mod:`mwip.campaign.blocks` simulates a block of samples as one batch of the engine and
computes the metrics (:mod:`mwip.campaign.metrics`); :mod:`mwip.campaign.execute` runs the
blocks in chunks (in this process or on Dask), writes each chunk atomically as Parquet and
assembles ``results.parquet``; :mod:`mwip.campaign.report` writes the analysis;
:mod:`mwip.campaign.claims` measures how each book claim depends on its open settings.
"""

from __future__ import annotations

__all__: list[str] = []
