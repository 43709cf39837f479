"""Calibration of the twin on evidence: the book's robot conditioned on the book's Chapter 6
evidence (:mod:`mwip.calibration.book`, ``mwip twin calibrate book --record``).

- :mod:`~mwip.calibration.evidence`: the declared split (``book-evidence.toml``);
- :mod:`~mwip.calibration.runs`: every Chapter 6 run on a batch of twins;
- :mod:`~mwip.calibration.sample`: prior draws as a campaign (Dask, resumable);
- :mod:`~mwip.calibration.posterior`: facts, acceptance, conflicts, marginals, MAP;
- :mod:`~mwip.calibration.claims`: the held-out claims across the posterior.
"""
