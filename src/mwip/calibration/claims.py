"""The held-out Chapter 6 claims, judged on every twin of the posterior.

Each claim is the study's own (same id, same test, :mod:`mwip.studies.exp_hodosmc`,
:mod:`mwip.studies.exp_asta`, :mod:`mwip.studies.exp_it2`), evaluated per twin from the
measured-signal metrics of :mod:`mwip.calibration.runs`:

- ``exp-hodosmc-balance``: ``order.rms_theta.case{1,2}``, ``order.rms_speed_err.case{1,2}``
  (DO4SMC < DO1SMC < SMC, Table 6.4);
- ``exp-hodosmc-speed``: ``order.rms_speed_err.case{1,2}`` (Table 6.5), ``track.case{1,2}``
  (all three at -7 rad/s: mean over the last 2 s within 5 %);
- ``exp-hodosmc-obstacle``: ``order.case3.settling_time`` (Table 6.6), ``settle.case3``;
- ``exp-asta``: ``order.rms_theta.case{1,2}``, ``order.rms_s1.case{1,2}`` (ASTA < ASMC,
  Tables 6.7-6.8);
- ``exp-it2``: ``exp{1,2,3}`` (T1 oscillates or keeps an error; IT2 stable and accurate).

The ``up.*`` claims are calibration evidence (the posterior stands by construction) and are
not judged here. Across the posterior: the fraction of twins where the claim holds with a
Wilson 95 % interval; *holds* at or above the declared ``decided`` fraction, *fails* at or
below ``1 - decided``, *undecided* between, with the unknown that best separates the twins
where it holds from those where it fails (the largest ``|AUC - 1/2|``, Mann-Whitney).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["HeldOutClaim", "CLAIMS", "judge", "auc", "claim_rows"]

Cols = Mapping[str, NDArray[np.float64]]


@dataclass(frozen=True)
class HeldOutClaim:
    """A book claim: ``study``/``id``, its text and its per-twin test over the columns."""

    study: str
    id: str
    text: str
    test: Callable[[Cols], NDArray[np.bool_]]
    runs: tuple[str, ...] = ()  # the runs it compares (their study/run names)

    @property
    def needs(self) -> tuple[str, ...]:
        """The calibration facts it rests on: each compared run stood (``up:<run>``)."""
        return tuple(f"up:{r}" for r in self.runs)

    @property
    def key(self) -> str:
        return f"{self.study}/{self.id}"


def _col(c: Cols, study: str, run: str, q: str) -> NDArray[np.float64]:
    return np.asarray(c[f"{study}/{run}.{q}"], dtype=float)


def _ordered(*vals: NDArray[np.float64]) -> NDArray[np.bool_]:
    ok = np.all([np.isfinite(v) for v in vals], axis=0)
    inc = np.all([a < b for a, b in zip(vals[:-1], vals[1:], strict=True)], axis=0)
    return np.asarray(ok & inc, dtype=bool)


def _order3(study: str, case: str, q: str) -> Callable[[Cols], NDArray[np.bool_]]:
    kinds = ("do4smc", "do1smc", "smc")
    return lambda c: _ordered(*(_col(c, study, f"{k}.{case}", q) for k in kinds))


def _track(study: str, case: str, target: float, tol: float) -> Callable[[Cols], NDArray[np.bool_]]:
    def test(c: Cols) -> NDArray[np.bool_]:
        v = [_col(c, study, f"{k}.{case}", "final_speed") for k in ("smc", "do1smc", "do4smc")]
        return np.all([np.isfinite(x) & (np.abs(x - target) <= tol * abs(target)) for x in v],
                      axis=0)  # fmt: skip

    return test


def _settle(c: Cols) -> NDArray[np.bool_]:
    return np.all([np.isfinite(_col(c, "exp-hodosmc-obstacle", f"{k}.case3", "settling_time"))
                   for k in ("smc", "do1smc", "do4smc")], axis=0)  # fmt: skip


def _asta(case: int, q: str) -> Callable[[Cols], NDArray[np.bool_]]:
    return lambda c: _ordered(_col(c, "exp-asta", f"asta.case{case}", q),
                              _col(c, "exp-asta", f"asmc.case{case}", q))  # fmt: skip


def _fuzzy(e: int) -> Callable[[Cols], NDArray[np.bool_]]:
    from mwip.studies import exp_it2

    def test(c: Cols) -> NDArray[np.bool_]:
        n = len(next(iter(c.values())))
        out = np.zeros(n, dtype=bool)
        prefix = "exp-it2/"
        keys = [k for k in c if k.startswith(prefix) and f".exp{e}." in k]
        for i in range(n):
            m = {k[len(prefix):]: float(c[k][i]) for k in keys}
            t1 = exp_it2.fails(m, f"t1.exp{e}")
            out[i] = t1 and exp_it2.stable_and_accurate(m, f"it2.exp{e}")
        return out

    return test


def _three(study: str, case: str) -> tuple[str, ...]:
    return tuple(f"{study}/{k}.{case}" for k in ("smc", "do1smc", "do4smc"))


def _claims() -> tuple[HeldOutClaim, ...]:
    from mwip.studies.exp_hodosmc import TRACK_TOL
    from mwip.studies.settings import defaults

    speed = float(defaults("exp-hodosmc-speed")["speed"])
    out: list[HeldOutClaim] = []
    for study, qs, table in (("exp-hodosmc-balance", ("rms_theta", "rms_speed_err"), "Table 6.4"),
                             ("exp-hodosmc-speed", ("rms_speed_err",), "Table 6.5")):  # fmt: skip
        for c in (1, 2):
            for q in qs:
                out.append(HeldOutClaim(study, f"order.{q}.case{c}",
                                        f"DO4SMC < DO1SMC < SMC in {q}, Case {c} ({table})",
                                        _order3(study, f"case{c}", q),
                                        _three(study, f"case{c}")))  # fmt: skip
            if study == "exp-hodosmc-speed":
                out.append(HeldOutClaim(study, f"track.case{c}",
                                        f"all three move at {speed:g} rad/s, Case {c}",
                                        _track(study, f"case{c}", speed, TRACK_TOL),
                                        _three(study, f"case{c}")))  # fmt: skip
    out.append(HeldOutClaim("exp-hodosmc-obstacle", "order.case3.settling_time",
                            "settling time DO4SMC < DO1SMC < SMC, Case 3 (Table 6.6)",
                            _order3("exp-hodosmc-obstacle", "case3", "settling_time"),
                            _three("exp-hodosmc-obstacle", "case3")))  # fmt: skip
    out.append(HeldOutClaim("exp-hodosmc-obstacle", "settle.case3",
                            "all three cross the stick and settle in (-9, -5) rad/s, Case 3",
                            _settle, _three("exp-hodosmc-obstacle", "case3")))  # fmt: skip
    for c in (1, 2):
        for q in ("rms_theta", "rms_s1"):
            out.append(HeldOutClaim("exp-asta", f"order.{q}.case{c}",
                                    f"ASTA < ASMC in {q}, Case {c} (Table 6.{6 + c})",
                                    _asta(c, q),
                                    (f"exp-asta/asta.case{c}", f"exp-asta/asmc.case{c}")))
    for e in (1, 2, 3):
        out.append(HeldOutClaim("exp-it2", f"exp{e}",
                                f"Exp {e}: T1 oscillates persistently or keeps a steady-state "
                                "error; IT2 stable and accurate (Figs. 6.17-6.19)", _fuzzy(e),
                                (f"exp-it2/it2.exp{e}", f"exp-it2/t1.exp{e}")))
    return tuple(out)


#: The held-out book claims of Chapter 6.
CLAIMS: tuple[HeldOutClaim, ...] = _claims()


def claim_rows(cols: Cols) -> dict[str, NDArray[np.bool_]]:
    """Each claim's per-twin verdict (claim key -> (N,) bool)."""
    return {c.key: c.test(cols) for c in CLAIMS}


def auc(x: NDArray[np.float64], y: NDArray[np.bool_]) -> float:
    """Mann-Whitney AUC of ``x`` separating ``y`` true from false (ties count half)."""
    a, b = x[y], x[~y]
    if a.size == 0 or b.size == 0:
        return 0.5
    from scipy.stats import rankdata

    r = rankdata(np.concatenate([a, b]))
    return float((r[: a.size].sum() - a.size * (a.size + 1) / 2) / (a.size * b.size))


def judge(
    verdicts: Mapping[str, NDArray[np.bool_]],
    accepted: NDArray[np.bool_],
    params: Mapping[str, NDArray[np.float64]],
    map_index: int,
    decided: float,
    weights: NDArray[np.float64] | None = None,
    ess: Mapping[str, float] | None = None,
) -> list[dict[str, Any]]:
    """Each claim across the posterior (``accepted`` draws, importance ``weights`` against the
    prior, default 1): its weighted fraction and the Wilson 95 % interval at Kish's
    effective size ``n_eff = (sum w)^2 / sum w^2`` (rounded; ``k = fraction n_eff``), verdict
    (holds / fails / undecided by ``decided``), the deciding unknown of an undecided claim, and
    the verdict on the most probable member ``map_index``. ``ess``: each claim's effective
    size where the draws are a Markov chain sample (:mod:`mwip.calibration.diagnostics`),
    used instead of Kish's."""
    from mwip.campaign.stats import wilson

    w_all = np.ones(len(accepted)) if weights is None else np.asarray(weights, dtype=float)
    wa = w_all[accepted]
    kish = int(round(wa.sum() ** 2 / np.sum(wa * wa))) if wa.size else 0
    out = []
    for c in CLAIMS:
        v = np.asarray(verdicts[c.key], dtype=bool)
        va = v[accepted]
        n = int(va.size)
        k = int(va.sum())
        n_eff = kish if ess is None else int(round(ess[c.key]))
        entry: dict[str, Any] = {"study": c.study, "id": c.id, "text": c.text, "n": n,
                                 "holds_in": k, "effective_n": n_eff}  # fmt: skip
        if n == 0:
            entry.update(verdict="no posterior", fraction=None, interval=None)
        else:
            frac = float(np.sum(wa * va) / np.sum(wa))
            ne = max(n_eff, 1)
            lo, hi = wilson(min(ne, max(0, int(round(frac * ne)))), ne)
            entry.update(fraction=frac, interval=[float(lo), float(hi)])
            if frac >= decided:
                entry["verdict"] = "holds"
            elif frac <= 1.0 - decided:
                entry["verdict"] = "fails"
            else:
                entry["verdict"] = "undecided"
                scores = {name: auc(np.asarray(x, dtype=float)[accepted], va)
                          for name, x in params.items()}  # fmt: skip
                name = max(sorted(scores), key=lambda s: abs(scores[s] - 0.5))
                a = scores[name]
                x = np.asarray(params[name], dtype=float)[accepted]
                entry["decided_by"] = {
                    "parameter": name, "auc": a,
                    "holds_when": "larger" if a > 0.5 else "smaller",
                    "median_where_holds": float(np.median(x[va])),
                    "median_where_fails": float(np.median(x[~va])),
                }  # fmt: skip
        entry["default_twin"] = bool(v[map_index]) if map_index >= 0 else None
        out.append(entry)
    return out
