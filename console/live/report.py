"""The run's report as the console saw it: one HTML file a person reads (File -> Save the run's report).

The console may run far from the manager and its run folder, so this report
is made of what the console itself knows: the plan and the fleet (the run
setup), the run's figures from the newest State (clock, arrivals,
collisions, the closest two robots came), each robot's last state, and the
event list in words (the manager's notices, the run's story, the answers),
as a table filterable by a word or a robot; the window's picture beside it.
`fleetctl report RUNDIR` writes the full report (plots of each robot's
moves and waits) from the manager's run folder. Pure: values in, HTML out.
"""
from __future__ import annotations

import html
import time
from pathlib import PurePath
from typing import Iterable, Optional

from .describe import action_text
from .model import Line, LiveModel

__all__ = ["report_html"]

_STYLE = """
body { font-family: DejaVu Sans, Arial, sans-serif; margin: 24px; color: #1c1c1c; }
table { border-collapse: collapse; font-size: 13px; }
td, th { border-bottom: 1px solid #ddd; padding: 3px 8px; text-align: left; }
tr.warn td { color: #b35c00; } tr.error td { color: #c8101a; } tr.story td { font-weight: bold; }
.swatch { display: inline-block; width: 12px; height: 12px; border-radius: 6px; border: 1px solid #333; }
"""

_FILTER = """
<script>
function filterEvents() {
  var word = document.getElementById('word').value.toLowerCase();
  var robot = document.getElementById('robot').value;
  var kind = document.getElementById('kind').value;
  var rows = document.querySelectorAll('#events tbody tr');
  for (var i = 0; i < rows.length; i++) {
    var r = rows[i];
    var ok = (!word || r.textContent.toLowerCase().indexOf(word) >= 0)
      && (!robot || r.dataset.robot === robot) && (!kind || r.dataset.kind === kind);
    r.style.display = ok ? '' : 'none';
  }
}
</script>
"""


def _e(value: object) -> str:
    return html.escape(str(value))


def report_html(model: LiveModel, picture: Optional[str] = None, saved_at: Optional[float] = None) -> str:
    """The report of what `model` holds; `picture`: the window's PNG, a file name beside the report."""
    setup, state = model.setup, model.state
    run = state.run if state is not None else None
    title = PurePath(setup.plan.name).name if setup is not None and setup.plan.name else "a FleetControl run"
    out = ["<!DOCTYPE html><html><head><meta charset='utf-8'><title>{}</title><style>{}</style>{}</head><body>".format(
        _e(title), _STYLE, _FILTER)]
    out.append("<h1>{}</h1>".format(_e(title)))
    out.append("<p>Manager {}; saved {} by the console.</p>".format(
        _e(model.endpoint), _e(time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(saved_at or time.time())))))
    if run is not None:
        out.append("<h2>The run</h2><table>")
        for label, value in (
                ("state", run.state + (": " + run.reason if run.reason else "")),
                ("what for", "the plan" if run.purpose == "plan" else "driving to the plan's starts"),
                ("clock", "{:.1f} s (plan step {:.1f})".format(run.clock, run.run_steps)),
                ("at their goals", "{} of {}".format(run.arrived, run.robots)),
                ("collisions", run.collisions),
                ("closest two robots", "-" if run.min_distance is None else "{:.2f} cells".format(run.min_distance)),
                ("strategy", run.strategy), ("plan", "plan {}".format(run.plan_id))):
            out.append("<tr><th>{}</th><td>{}</td></tr>".format(_e(label), _e(value)))
        out.append("</table>")
    if picture:
        out.append("<p><img src='{}' alt='the console window' style='max-width: 100%'></p>".format(_e(picture)))
    if state is not None and model.scene is not None:
        out.append("<h2>Robots</h2><table><tr><th>robot</th><th>link</th><th>moves</th><th>state</th>"
                   "<th>doing</th></tr>")
        colours = dict(zip(model.robot_ids(), model.scene.colours))
        for r in state.robots:
            out.append("<tr><td><span class='swatch' style='background:{}'></span> {}</td><td>{}</td>"
                       "<td>{} of {}</td><td>{}</td><td>{}</td></tr>".format(
                           _e(colours.get(r.id, "#999")), r.id, _e(r.link), r.done, r.total,
                           _e(r.out or "enabled"), _e(action_text(r))))
        out.append("</table>")
    out.append(_events(model.lines))
    out.append("</body></html>")
    return "\n".join(out)


def _events(lines: Iterable[Line]) -> str:
    lines = list(lines)
    robots = sorted({line.robot for line in lines if line.robot is not None})
    kinds = sorted({line.kind for line in lines})
    head = ("<h2>What happened</h2><p>Filter: <input id='word' oninput='filterEvents()' placeholder='a word'> "
            "<select id='robot' onchange='filterEvents()'><option value=''>every robot</option>{}</select> "
            "<select id='kind' onchange='filterEvents()'><option value=''>every kind</option>{}</select></p>").format(
        "".join("<option value='{0}'>robot {0}</option>".format(r) for r in robots),
        "".join("<option value='{0}'>{0}</option>".format(_e(k)) for k in kinds))
    rows = ["<table id='events'><thead><tr><th>time</th><th>robot</th><th>kind</th><th>what</th></tr></thead><tbody>"]
    for line in lines:
        level = "story" if line.kind == "story" else line.level
        rows.append("<tr class='{}' data-robot='{}' data-kind='{}'><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
                    "</tr>".format(level, "" if line.robot is None else line.robot, _e(line.kind), _e(line.clock),
                                   "" if line.robot is None else line.robot, _e(line.kind), _e(line.text)))
    rows.append("</tbody></table>")
    return head + "\n".join(rows)
