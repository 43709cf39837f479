"""Identification of a user's robot twin from logs (``mwip twin fit``, docs/twin_fit.md).

- :mod:`mwip.identify.bounds`: the fitted parameters, their bounds and prior centre;
- :mod:`mwip.identify.logs`: reading and validating logs (:class:`~mwip.identify.logs.LogError`);
- :mod:`mwip.identify.model`: the batched prediction models (wheels-off-ground drive model);
- :mod:`mwip.identify.identifiability`: what the logs inform, checked before the fit;
- :mod:`mwip.identify.fit`: multiple-shooting prediction-error fit and its statistics;
- :mod:`mwip.identify.report`: ``robot.toml``, ``fit.json``, ``fit.png``, ``index.html``;
- :mod:`mwip.identify.torque_map`: the firmware's torque gain from logs of torques and duties;
- :mod:`mwip.identify.excite`: the excitation schedule (``mwip twin excite``);
- :mod:`mwip.identify.synth`: synthetic logs from the twin's own elements (``mwip twin log``,
  tests, benchmarks).
"""
