"""The report of a results table: how the strategies fare as delays grow.

Charts (each keeps the numbers it plots in `Chart.data`):

    makespan_ratio   executed / planned makespan against the delay probability p,
                     per plan and strategy, mean with a 95 % confidence interval
                     (normal approximation, 1.96 standard errors)
    wait_per_robot   mean wait of each robot (by agent index), per plan and strategy
    distribution     box plots of the makespan ratio per strategy and delay
    disabled         with robots disabled: robots at their goals and makespan ratio,
                     without and with replanning

and a summary table, one line per plan, strategy, delay, disabled robot and recovery.
"""
from __future__ import annotations

import json
import math
from collections import OrderedDict
from typing import Any, Callable, Dict, List, Sequence, Tuple

import numpy as np

from .figures import Chart, new_figure, to_png
from .html import Page, Table

Row = Dict[str, Any]


def mean_ci(values: Sequence[float]) -> Tuple[float, float]:
    """Mean and half-width of its 95 % confidence interval (0 for one value)."""
    a = np.asarray(values, dtype=float)
    if a.size < 2:
        return float(a.mean()) if a.size else math.nan, 0.0
    return float(a.mean()), float(1.96 * a.std(ddof=1) / math.sqrt(a.size))


def _groups(rows: List[Row], keys: Sequence[str]) -> "OrderedDict[tuple, List[Row]]":
    out: "OrderedDict[tuple, List[Row]]" = OrderedDict()
    for r in rows:
        out.setdefault(tuple(r[k] for k in keys), []).append(r)
    return out


def _plans(rows: List[Row]) -> List[str]:
    return list(OrderedDict.fromkeys(r["plan"] for r in rows))


def _delay_label(r: Row) -> str:
    return "p={:g}".format(r["p"]) if r["p"] is not None else r["delay"]


def _per_plan(rows: List[Row], height: float, draw: Callable[[Any, List[Row]], Any], xlabel: str,
              ylabel: str, legend: bool = True) -> Tuple[Any, Dict[str, Any]]:
    """One panel per plan (robots not disabled); `draw(ax, rows of the plan)` returns its data."""
    plain = [r for r in rows if r["disable"] == "none"]
    plans = _plans(plain)
    fig = new_figure((4.2 * max(1, len(plans)), height))
    data: Dict[str, Any] = {}
    for i, plan in enumerate(plans):
        ax = fig.add_subplot(1, len(plans), i + 1)
        data[plan] = draw(ax, [r for r in plain if r["plan"] == plan])
        ax.set_title(plan, fontsize=9)
        ax.set_xlabel(xlabel)
        if i == 0:
            ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if legend:
            ax.legend(fontsize=8)
    return fig, data


def makespan_chart(rows: List[Row]) -> Chart:
    def draw(ax: Any, mine: List[Row]) -> Dict[str, Any]:
        data = {}
        for strategy, group in _groups([r for r in mine if r["p"] is not None], ["strategy"]).items():
            by_p = _groups(sorted(group, key=lambda r: r["p"]), ["p"])
            ps = [k[0] for k in by_p]
            stats = [mean_ci([r["makespan_ratio"] for r in g]) for g in by_p.values()]
            means, cis = [s[0] for s in stats], [s[1] for s in stats]
            ax.errorbar(ps, means, yerr=cis, marker="o", capsize=3, label=strategy[0])
            data[strategy[0]] = {"p": ps, "mean": means, "ci": cis, "n": [len(g) for g in by_p.values()]}
        return data
    fig, data = _per_plan(rows, 3.6, draw, "delay probability p", "executed / planned makespan")
    return Chart("makespan_ratio", "Executed over planned makespan against the delay probability", to_png(fig),
                 data, "Mean over seeds with 95 % confidence intervals; the same delays for both strategies.")


def wait_chart(rows: List[Row]) -> Chart:
    def draw(ax: Any, mine: List[Row]) -> Dict[str, Any]:
        data = {}
        for strategy, group in _groups(mine, ["strategy"]).items():
            mean = np.array([json.loads(r["wait_by_robot"]) for r in group], dtype=float).mean(axis=0).tolist()
            ax.plot(range(len(mean)), mean, marker="." if len(mean) < 40 else None, label=strategy[0])
            data[strategy[0]] = mean
        return data
    fig, data = _per_plan(rows, 3.4, draw, "robot (agent index)", "mean wait (time units)")
    return Chart("wait_per_robot", "Wait time per robot", to_png(fig), data,
                 "Mean over every delay model and seed of the plan (robots not disabled).")


def distribution_chart(rows: List[Row]) -> Chart:
    def draw(ax: Any, mine: List[Row]) -> Dict[str, Any]:
        groups = _groups(sorted(mine, key=lambda r: (r["p"] is None, r["p"] or 0, r["delay"], r["strategy"])),
                         ["strategy", "delay"])
        labels = ["{} {}".format(g[0][0:4], _delay_label(rs[0])) for g, rs in groups.items()]
        values = [[r["makespan_ratio"] for r in rs] for rs in groups.values()]
        ax.boxplot(values, showfliers=True)
        ax.set_xticks(range(1, len(labels) + 1), labels)
        ax.tick_params(axis="x", labelrotation=70, labelsize=7)
        return dict(zip(labels, values))
    fig, data = _per_plan(rows, 3.8, draw, "", "executed / planned makespan", legend=False)
    return Chart("distribution", "Distribution of the makespan ratio", to_png(fig), data,
                 "Box: quartiles; whiskers: 1.5 interquartile ranges; circles: runs beyond them.")


def disabled_chart(rows: List[Row]) -> Chart:
    out = [r for r in rows if r["disable"] != "none"]
    groups = _groups(out, ["plan", "strategy", "recover"])
    fig = new_figure((7.5, 3.4))
    left, right = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    labels = ["{} {} {}".format(*k) for k in groups]
    reached = [float(np.mean([r["reached"] / r["agents"] for r in g])) for g in groups.values()]
    ratio = [float(np.mean([r["makespan_ratio"] for r in g])) for g in groups.values()]
    ys = range(len(labels))
    left.barh(ys, reached)
    left.set_yticks(list(ys), labels, fontsize=7)
    left.set_xlabel("robots at their goals (share)")
    right.barh(ys, ratio)
    right.set_yticks(list(ys), [""] * len(labels))
    right.set_xlabel("executed / planned makespan")
    data = {label: {"reached": a, "makespan_ratio": b} for label, a, b in zip(labels, reached, ratio)}
    return Chart("disabled", "One robot disabled: without and with replanning", to_png(fig), data,
                 "Means over the delay models and seeds; makespan over the robots that arrived.")


def summary_table(rows: List[Row]) -> Table:
    keys = ["plan", "strategy", "delay", "disable", "recover"]
    out = []
    for key, g in _groups(rows, keys).items():
        m, ci = mean_ci([r["makespan_ratio"] for r in g])
        out.append(list(key) + [len(g), "{:.3f} ± {:.3f}".format(m, ci),
                                float(np.mean([r["soc_ratio"] for r in g])),
                                float(np.mean([r["wait_mean"] for r in g])),
                                "{:.1f}/{}".format(float(np.mean([r["reached"] for r in g])), g[0]["agents"]),
                                sum(r["collisions"] for r in g), float(np.mean([r["wall_s"] for r in g]))])
    return Table(keys + ["runs", "makespan ratio", "soc ratio", "wait/robot", "at goal", "collisions",
                         "wall s"], out, left=len(keys))


def sweep_page(rows: List[Row], name: str) -> Page:
    page = Page("Sweep report: {}".format(name))
    plans = _plans(rows)
    page.meta.append("{} runs; plans: {}; strategies: {}; seeds: {}".format(
        len(rows), ", ".join(plans), ", ".join(OrderedDict.fromkeys(r["strategy"] for r in rows)),
        len({r["seed"] for r in rows})))
    page.meta.append("collisions in all runs: {}".format(sum(r["collisions"] for r in rows)))
    if any(r["p"] is not None and r["disable"] == "none" for r in rows):
        page.add("Makespan against delay probability", makespan_chart(rows))
    if any(r["disable"] == "none" for r in rows):
        page.add("Waits", wait_chart(rows))
        page.add("Distributions", distribution_chart(rows))
    if any(r["disable"] != "none" for r in rows):
        page.add("Disabled robots and replanning", disabled_chart(rows))
    page.add("Summary", summary_table(rows))
    return page
