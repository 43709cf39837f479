"""Results of the studies for people: the one-screen summary, the HTML report, and the safe
output folder they are written to."""

from mwip.report.html import render_html, write_report
from mwip.report.results import StudyResult, load_results, load_run_record
from mwip.report.staging import Staging
from mwip.report.summary import summary_lines

__all__ = [
    "Staging",
    "StudyResult",
    "load_results",
    "load_run_record",
    "render_html",
    "summary_lines",
    "write_report",
]
