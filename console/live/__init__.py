"""The live console: the window of a running fleet (`fleetctl console --manager ENDPOINT`).

Two threads, as thonny does it. The network thread (`link.ManagerLink`) owns
the socket and the protocol session (`fleet_common.control`, never the
manager's internals) and puts every decoded message on a `feed.LiveFeed`.
The Tk thread drains the feed once a frame (`model.LiveSource`), so it never
waits on the network. The rest is pure and tested without a display:

    feed       the queue between the threads and the link's own items
    model      what the console knows (scene, newest state, proposal, event list)
    scene      the manager's scene as the map layers draw it
    picture    the map's arrays: poses, ghosts, greyed, behind, waits
    describe   the same facts in words (robot list, robot panel, blocked-by chain)
    recorder   when to save a frame (every N plan steps, start and end)

The Tk side is `console.ui.live_app.LiveApp` and its panels; `console.
live_console` opens it in a window or headless on a private Xvfb.
"""
from __future__ import annotations
