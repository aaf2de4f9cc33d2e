"""`fleetctl report RESULTS|RUNDIR -o report.html`: one self-contained HTML page with plots."""
from __future__ import annotations

import argparse
from pathlib import Path

NAME = "report"
HELP = "an HTML report with plots of a sweep's results table or of one run folder"
DESCRIPTION = (
    "Write one self-contained HTML file (plots embedded, nothing fetched from the network) and each "
    "plot as a PNG beside it. For a results table (results.csv or .parquet from `fleetctl "
    "experiment`, or its folder): makespan ratio against delay probability per strategy with 95 %% "
    "confidence intervals, wait per robot, distributions, disabled robots, a summary table. For a "
    "run folder (the manager's, or `fleetctl simulate --log`'s): what each robot did over time, "
    "planned against executed progress, deviation of the reported poses from the plan, the events.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("source", type=Path, help="results.csv/.parquet, a sweep's folder, or a run folder")
    parser.add_argument("-o", "--out", type=Path, default=Path("report.html"), metavar="HTML",
                        help="the HTML file to write (default report.html); PNGs go beside it")


def run(args: argparse.Namespace) -> int:
    from evaluation.report import write_report
    from evaluation.report.run import run_page
    from evaluation.report.sweep import sweep_page
    from evaluation.table import read_table
    from fleet_common.errors import FleetError
    from fleet_common.runlog import read_run

    source: Path = args.source
    if not source.exists():
        raise FleetError("{}: no such file or folder".format(source))
    if source.is_dir() and (source / "events.jsonl").is_file():
        page = run_page(read_run(source))
    elif source.is_dir() and not any((source / n).is_file() for n in ("results.csv", "results.parquet")):
        raise FleetError("{}: neither a run folder (events.jsonl) nor a sweep's folder (results.csv)".format(source))
    else:
        rows = read_table(source)
        if not rows:
            raise FleetError("{}: the results table has no rows".format(source))
        page = sweep_page(rows, source.stem if source.is_file() else source.name)
    written = write_report(page, args.out)
    print("report: {} ({} plots, also as PNG beside it)".format(written[0], len(written) - 1))
    return 0
