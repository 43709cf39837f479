"""Hardening round 3 (issue 39, items 3 and 7): a log is checked for physics and size before
any fit. The audit fitted logs with encoders in degrees or mrad, the gyro in deg/s, the
accelerometer in g and Parquet columns stored as text, exit 0; a 0.7 MB Parquet file of 20 M
rows took over 6 GiB; a CSV field over 128 KiB was an internal error.

Each unit mistake is made on a log the twin itself wrote (:mod:`mwip.identify.synth`), which
passes as it is: the mistake, and only it, is named (column, what was expected, the likely
unit), exit 2, nothing written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mwip.cli import main
from mwip.identify import excite, synth
from mwip.identify.logs import LogError, read_log


@pytest.fixture(scope="module")
def stand() -> dict[str, np.ndarray]:
    t, duty, mode = excite.schedule(static=0.3, step=0.06, chirp=0.5)
    return synth.stand_log(synth.draw_truth(3), duty, mode, seed=2)


@pytest.fixture(scope="module")
def balancing() -> dict[str, np.ndarray]:
    return synth.balancing_log(synth.draw_truth(3), duration=3.0, seed=1)


def _write(tmp: Path, cols: dict[str, np.ndarray], name: str = "log.csv") -> Path:
    return synth.write_csv(tmp / name, cols)


def _edit(cols: dict[str, np.ndarray], **over: object) -> dict[str, np.ndarray]:
    out = dict(cols)
    out.update({k: np.asarray(v) for k, v in over.items()})
    return out


def test_the_twins_own_logs_pass(tmp_path, stand, balancing):
    read_log(_write(tmp_path, stand, "a.csv"))
    read_log(_write(tmp_path, balancing, "b.csv"))


UNIT_MISTAKES = [
    # (log, column edited, factor, column named, words of the message)
    ("stand", "enc_r", 180 / np.pi, "enc_r", "degrees instead of rad"),
    ("stand", "enc_l", 1000.0, "enc_l", "mrad"),
    ("stand", "accel_x,accel_y", 1 / 9.81, "accel_x", "in g instead of m/s^2"),
    ("stand", "accel_x,accel_y", 1000 / 9.81, "accel_x", "in mg instead of m/s^2"),
    ("balancing", "theta_rate", 180 / np.pi, "theta_rate", "deg/s instead of rad/s"),
    ("balancing", "theta_rate", 1000.0, "theta_rate", "mrad/s"),
    ("balancing", "theta", 180 / np.pi, "theta", "degrees instead of rad"),
    ("balancing", "enc_r,enc_l", 180 / np.pi, "enc_r", "degrees instead of rad"),
]


@pytest.mark.parametrize(("which", "cols", "factor", "named", "words"), UNIT_MISTAKES)
def test_a_unit_mistake_is_named(tmp_path, capsys, stand, balancing, which, cols, factor,
                                 named, words):  # fmt: skip
    log = stand if which == "stand" else balancing
    bad = _edit(log, **{c: log[c] * factor for c in cols.split(",")})
    path = _write(tmp_path, bad)
    with pytest.raises(LogError) as info:
        read_log(path)
    msg = str(info.value)
    assert f"column {named!r}" in msg and words in msg, msg
    out = tmp_path / "fit"
    assert main(["twin", "fit", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and "Traceback" not in err[0]
    assert not out.exists()


def test_a_gyro_that_follows_the_wheels_is_named(tmp_path, stand):
    """theta_rate holding a wheel speed: on the stand the body is held, the gyro near 0."""
    wheel = np.gradient(stand["enc_r"], stand["t"])
    with pytest.raises(LogError, match="column 'theta_rate'.*wheel speed instead"):
        read_log(_write(tmp_path, _edit(stand, theta_rate=wheel)))


def test_parquet_columns_stored_as_text_are_refused(tmp_path, stand):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    cols = {k: (v if k == "mode" else v.astype(float)) for k, v in stand.items()}
    good = tmp_path / "good.parquet"
    pq.write_table(pa.table(cols), good)
    read_log(good)  # numbers as numbers: fine
    for name in ("theta", "enc_l", "duty_r"):
        bad = dict(cols)
        bad[name] = np.array([repr(x) for x in cols[name]])
        path = tmp_path / f"{name}.parquet"
        pq.write_table(pa.table(bad), path)
        with pytest.raises(LogError, match=f"column '{name}': is stored as string"):
            read_log(path)


def test_rows_are_counted_while_reading(tmp_path, stand):
    """A log over the row limit is refused before it is parsed whole (CSV: row by row;
    Parquet: from its metadata, the rows after decompression); the limit is stated."""
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    n = len(stand["t"])
    path = _write(tmp_path, stand)
    with pytest.raises(LogError, match=f"more than {n - 1} rows.*--max-rows"):
        read_log(path, max_rows=n - 1)
    assert read_log(path, max_rows=n).n == n
    zeros = tmp_path / "zeros.parquet"  # compresses to almost nothing
    rows = 2_000_000
    pq.write_table(pa.table({k: np.zeros(rows) for k in ("t", "theta", "theta_rate", "enc_r",
                                                         "enc_l", "u_r", "u_l")}), zeros,
                   compression="zstd")  # fmt: skip
    assert zeros.stat().st_size < 2_000_000
    with pytest.raises(LogError, match="more than 500000 rows"):
        read_log(zeros)


def test_max_rows_counts_the_logs_together(tmp_path, capsys, stand):
    n = len(stand["t"])
    a, b = _write(tmp_path, stand, "a.csv"), _write(tmp_path, stand, "b.csv")
    out = tmp_path / "fit"
    assert main(["twin", "fit", str(a), str(b), "--out", str(out),
                 "--max-rows", str(2 * n - 1)]) == 2  # fmt: skip
    assert "--max-rows" in capsys.readouterr().err and not out.exists()


def test_a_huge_csv_field_is_one_line(tmp_path, capsys):
    path = tmp_path / "big.csv"
    path.write_text("t,theta\n0," + "1" * 200_000 + "\n")
    with pytest.raises(LogError, match="row 2: not a CSV log"):
        read_log(path)
    assert main(["twin", "fit", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "internal error" not in capsys.readouterr().err


def test_a_log_name_ending_in_a_slash(tmp_path, stand):
    path = _write(tmp_path, stand)
    with pytest.raises(LogError, match="ends in '/'.*is a file"):
        read_log(str(path) + "/")
