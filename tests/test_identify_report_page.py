"""The page of `mwip twin fit` (issue 37, item 5, "output a person reads"): fit.png shows the
measured signals against the fitted twin's predictions for every mode the fitted logs hold
(wheels-off-ground, static, balancing, the fused pitch) and for the validation log, beside the
prior centre's; index.html says what each panel shows.

Logs from `mwip twin log` on the default robot: a short stand log (the excitation schedule)
and two balancing logs (LQR, 1 s)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mwip.cli import main
from mwip.identify.bounds import NAMES, centre
from mwip.identify.logs import read_log


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("report_page")
    sched = d / "sched.csv"
    assert main(["twin", "excite", "--out", str(sched), "--static", "0.3", "--step", "0.06",
                 "--chirp", "0.5"]) == 0  # fmt: skip
    out = {"dir": d}
    for name, args in (("stand", ["--excite", str(sched)]),
                       ("bal", ["--controller", "lqr", "--duration", "1"]),
                       ("bal2", ["--controller", "lqr", "--duration", "1", "--seed", "3",
                                 "--theta0", "0.03"])):  # fmt: skip
        out[name] = d / f"{name}.csv"
        assert main(["twin", "log", *args, "--out", str(out[name])]) == 0
    return out


def _rms(x: Any) -> float:
    return float(np.sqrt(np.mean(np.asarray(x) ** 2)))


def test_the_predicted_traces_are_the_residuals_of_the_reported_errors(
        logs: dict[str, Path]) -> None:  # fmt: skip
    """(a) The traces behind predict_error / balance_error: the RMS of measured minus
    predicted is the reported RMS, and the numbers are those of the functions without traces."""
    from mwip.hardware.twin import Twin
    from mwip.identify.balance import balance_error, balance_prediction
    from mwip.identify.fit import predict, predict_error
    from mwip.identify.model import Known

    values = {n: centre(n) for n in NAMES}
    bal = read_log(logs["bal2"])
    err, tr = balance_prediction(bal, values)
    assert err == balance_error(bal, values)
    S = int(err["balance_segments"])
    assert tr["t"].shape == (S, 10) and tr["enc_pred"].shape == (S, 10, 2)
    assert abs(_rms(tr["enc"] - tr["enc_pred"]) - err["balance_enc_rms"]) < 1e-12
    assert abs(_rms(tr["gyro"] - tr["gyro_pred"]) - err["balance_gyro_rms"]) < 1e-12
    stand = read_log(logs["stand"])
    known = Known.from_twin(Twin(), stand.Ts)
    e2, tr2 = predict(stand, values, known)
    assert e2 == predict_error(stand, values, known)
    wog = tr2["wheels-off-ground"]
    assert abs(_rms(wog["enc"] - wog["pred"]) - e2["enc_rms"]) < 1e-12
    st = tr2["static"]
    assert abs(_rms(st["theta_rate"] - st["theta_rate_pred"]) - e2["theta_rate_rms"]) < 1e-12
    assert "balancing" not in tr2


def test_the_figure_has_a_row_for_every_mode_present(logs: dict[str, Path],
                                                     tmp_path: Path) -> None:  # fmt: skip
    """(b) fit.png: wheels-off-ground (both wheels, residuals, autocorrelation), static (gyro,
    accelerometer), balancing (encoder, gyro) and the fused pitch from the stand and balancing
    logs; a balancing-only fit has no wheels-off-ground, static or fusion panel (its log has
    no accelerometer). The same result writes the same bytes."""
    from mwip.identify.balance import balance_error
    from mwip.identify.fit import fit
    from mwip.identify.report import page_html, write_figure

    read = [read_log(logs["stand"]), read_log(logs["bal"])]
    res = fit(read)
    assert set(res.trace) == {"wheels-off-ground", "static", "balancing", "fusion"}
    bt = res.trace["balancing"]  # the balancing log's predictions with the fitted values
    err = balance_error(read[1], res.estimates)
    assert abs(_rms(bt["enc"] - bt["enc_pred"]) - err["balance_enc_rms"]) < 1e-12
    titles = write_figure(res, tmp_path / "a.png")
    heads = [t.split(" (")[0] for t in titles]
    assert heads == ["wheels-off-ground: right-wheel encoder",
                     "wheels-off-ground: left-wheel encoder",
                     "wheels-off-ground: encoder residuals",
                     "wheels-off-ground: residual autocorrelation",
                     "static: gyro", "static: accelerometer",
                     "balancing: right-wheel encoder", "balancing: gyro",
                     "fusion: pitch, one sample ahead", "fusion: pitch residual"]  # fmt: skip
    write_figure(res, tmp_path / "b.png")
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    page = page_html(res, read)
    for t in titles:
        assert f"<li><b>{t}</b>: " in page, t
    only = fit([read[1]])
    assert [t.split(" (")[0] for t in write_figure(only, tmp_path / "c.png")] == [
        "balancing: right-wheel encoder", "balancing: gyro"]  # fmt: skip


def test_the_validation_log_is_drawn_and_named(logs: dict[str, Path],
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """(c) `--validate LOG`: the validation log's traces with the fitted twin's and the prior
    centre's predictions (the errors of fit.json are their RMS); fit.png has its rows and the
    page names it."""
    import json

    from mwip.identify import report

    seen: dict[str, Any] = {}
    write = report.write_outputs

    def keep(out: Path, result: Any, *args: Any, **kw: Any) -> list[Path]:
        seen["result"] = result
        seen["titles"] = report.write_figure(result, out / "probe.png")
        (out / "probe.png").unlink()
        return write(out, result, *args, **kw)

    monkeypatch.setattr(report, "write_outputs", keep)
    out = logs["dir"] / "fit-val"
    assert main(["twin", "fit", str(logs["bal"]), "--validate", str(logs["bal2"]),
                 "--out", str(out)]) == 0  # fmt: skip
    res = seen["result"]
    vt = res.validation_trace
    assert vt["log"] == str(logs["bal2"])
    doc = json.loads((out / "fit.json").read_text())
    assert "validation_trace" not in doc
    for who in ("fitted", "prior_centre"):
        tr = vt[who]["balancing"]
        got = doc["validation"][who]
        assert abs(_rms(tr["enc"] - tr["enc_pred"]) - got["balance_enc_rms"]) < 1e-12
        assert abs(_rms(tr["gyro"] - tr["gyro_pred"]) - got["balance_gyro_rms"]) < 1e-12
    assert [t.split(" (")[0] for t in seen["titles"]] == [
        "balancing: right-wheel encoder", "balancing: gyro",
        "validation, balancing: right-wheel encoder", "validation, balancing: gyro"]
    page = (out / "index.html").read_text()
    assert "the validation log bal2.csv" in page
    assert "<li><b>validation, balancing: gyro (" in page
    assert (out / "fit.png").stat().st_size > 10_000
