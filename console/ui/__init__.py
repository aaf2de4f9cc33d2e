"""The Tk views of the console: small classes on one canvas, main thread only.

`MapView` owns the canvas, the viewport and the map picture; layers put their
items on it (`AgentLayer`, `ConflictLayer`, `CellIdLayer`, `AxesLayer`,
`HeaderBand`) and move them when a new fleet state arrives; `ControlsBar`,
`AgentList` and `ConflictList` sit around it; `PlayerApp` wires them to a
source, the keys and the menus. Every layer has the same two methods:
`relayout(view, options)` when the view or the options change (place
everything) and `update(state)` for a new fleet state (move what moved).

The live console (`LiveApp`, a `PlayerApp` on a live source) adds `RobotLayer`
(robots at their reported poses, ghosts, waits, greyed robots),
`ProposalLayer` and `Banner` on the canvas, and `AdminPanel`, `RobotPanel`
and `EventList` around it.
"""
from __future__ import annotations
