"""Run folders: the evidence a run leaves, and everything computed from it.

Every run of the manager (and `fleetctl simulate --log`) can write a folder

    DIR/<timestamp>/
        plan-1.txt               the plan as executed (mapf-IR solution format);
        plan-2.txt ...           plans switched to later (replanning)
        robot_definitions.txt    the fleet of the run (a copy)
        events.jsonl             one JSON object a line, append-only (`records`)

Traces, summaries, reports and experiment tables are computed from run
folders, never from a process's memory (ARCHITECTURE.md, "Runs and their
evidence"). `records` names every kind of line and its fields, `writer`
appends them (flushed at least once a second, so a crash loses at most the
last second), `reader` reads a folder back, tolerating the torn last line of
a run that crashed.
"""
from __future__ import annotations

from .reader import RunFolder, read_run
from .records import FORMAT_VERSION, KINDS
from .writer import RunLog, new_run_folder

__all__ = ["RunFolder", "read_run", "FORMAT_VERSION", "KINDS", "RunLog", "new_run_folder"]
