"""Reports a person would rather look at than read: plots and one self-contained HTML file.

    figures   a matplotlib figure -> PNG bytes, kept with the data it shows
    html      the page: sections, embedded PNGs (data: URIs), tables, no network
    sweep     the figures and summary table of a results table
    run       the figures and events list of one run folder (manager or simulator)

`fleetctl report` writes the HTML and each PNG beside it.
"""
from __future__ import annotations

from .figures import Chart
from .html import Page, write_report

__all__ = ["Chart", "Page", "write_report"]
