"""Helpers shared by the studies: figure saving. (The metrics document and the claims are the
results schema, :mod:`mwip.schema`.)"""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from mwip.io import write_atomic

__all__ = ["save_figure"]

#: The widest a study figure is drawn (px): the report shows figures at most about 1200 px
#: wide at a 1280 px window (:data:`SHOWN_PX`), so none is shrunk by more than about 1.2x.
MAX_FIGURE_PX = 1440
SHOWN_PX = 1200
#: The smallest text (px) a figure may show where the report displays it.
MIN_TEXT_PX = 10.0


def _readable_text(fig: Figure, dpi: float) -> None:
    """Raise every text of ``fig`` smaller than :data:`MIN_TEXT_PX` at its displayed size
    (the figure shrunk to :data:`SHOWN_PX` wide if it is wider) to that size."""
    from matplotlib.text import Text

    shrink = max(1.0, fig.get_figwidth() * dpi / SHOWN_PX)
    min_pt = MIN_TEXT_PX * shrink * 72.0 / dpi
    for ax in fig.axes:
        for axis, which in ((ax.xaxis, "x"), (ax.yaxis, "y")):
            labels = axis.get_ticklabels()
            if labels and float(labels[0].get_fontsize()) < min_pt:
                ax.tick_params(axis=which, labelsize=min_pt)  # type: ignore[arg-type]
    for text in fig.findobj(Text):
        if isinstance(text, Text) and text.get_text() and float(text.get_fontsize()) < min_pt:
            text.set_fontsize(min_pt)


def save_figure(fig: Figure, path: Path) -> Path:
    """Save a matplotlib figure as PNG atomically (no pyplot, no global backend), at 120 dpi
    or, for a figure wider than 12 in, at the dpi that makes it :data:`MAX_FIGURE_PX` wide;
    text too small to read where the report shows the figure is enlarged first."""
    dpi = min(120.0, MAX_FIGURE_PX / float(fig.get_figwidth()))
    _readable_text(fig, dpi)
    return write_atomic(path, lambda fh: fig.savefig(fh, format="png", dpi=dpi))
