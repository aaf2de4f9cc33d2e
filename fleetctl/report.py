"""Printing validator findings for people, in one place."""
from __future__ import annotations

from fleet_common.validate import Report


def print_findings(name: str, report: Report, infos: bool = False) -> None:
    for f in report.errors:
        print("{}: error: {}".format(name, f.message))
    if infos:
        for f in report.infos:
            print("{}: info: {}".format(name, f.message))
