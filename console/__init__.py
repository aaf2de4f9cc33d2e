"""The operator console: one Tk window that shows a fleet on its grid map.

It is the live console of a running fleet (`fleetctl console --manager`,
`live_console` and the `live` package) and the offline plan player
(`fleetctl console --replay FILE`, `player`). Both feed the same map views, so
the package is split by what changes together:

- the model, pure Python and tested without a display: `scene` (what is
  shown: map, agents, colours, findings), `fleet_state` (where every agent is
  at one moment), `sources` (where fleet states come from: `PlanClock` for a
  plan and a clock, `QueueSource` for states put on a queue by another
  thread), `viewport` and `orientation` (cells to pixels), `view_options`,
  `conflicts`, `palette`, `keys` (the key table the bindings and the Help
  menu share), `background` (the map picture as pixels) and `path_corners`
  (remaining paths as polylines);
- `live`: the live console's network thread (`link`), the queue to the Tk
  thread (`feed`) and its pure model of the manager's messages;
- `ui`: the Tk views, small classes on one canvas, run on the main thread
  only; a 33 ms `after()` loop polls the source and moves canvas items;
- `player` and `live_console` open the windows or render PNGs (`--screenshot`,
  `--record`), on a private X server from `xvfb` when there is no display.

The console imports fleet_common only, never the manager's internals.
"""
from __future__ import annotations
