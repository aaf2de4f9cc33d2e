"""Opening the live console: a window on the display, or headless on a private Xvfb.

`run_live_console` starts the network thread (`live.link.ManagerLink`),
builds the window (`ui.live_app.LiveApp`) and runs Tk's loop on this thread
until the window is closed, a signal arrives (SIGINT, SIGTERM: the window
closes cleanly, so a supervising process can stop it), or what was asked
for is done:

- `screenshot`: the whole window saved as PNG `after` seconds, then closed;
- `record`: a frame every `every` plan steps and at every change of the run
  (`live.recorder`), until closed;
- `close_when_done`: close that many seconds after the run is done;
- `start_when_ready`: press Start once every robot is connected and has a
  pose, as an operator would (the demo's console does);
- `switch_when_stalled`: switch the run to that strategy once, as an operator
  would who sees a robot wait for a stalled one (`fleetctl demo --switch`);
- `present`: open in the presentation view for visitors (full screen; on a
  private Xvfb, a 1600 x 1000 screen unless `size` says otherwise).

Without a display (no DISPLAY), a screenshot or a recording renders on a
private Xvfb; a plain window says what to do instead.
"""
from __future__ import annotations

import os
import signal
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, List, Optional, Tuple

from fleet_common.errors import FleetError
from fleet_common.transport.curve_keys import ConsoleKeys

from .live.feed import LiveFeed
from .live.link import ManagerLink
from .live.model import LiveModel
from .live.recorder import Recorder
from .player import _display, _tk, _wait_until_viewable, default_canvas_size
from .recent import RecentFiles, default_recent_path
from .view_options import ViewOptions

if TYPE_CHECKING:
    from .ui.live_app import LiveApp

__all__ = ["LiveOptions", "LiveOutcome", "run_live_console", "AutoStart", "AutoSwitch"]

#: The live console's canvas fits this box (the panels take the rest of a laptop screen).
LIVE_CANVAS = (820, 620)
#: The private screen of a headless presentation view (a projector's 16:10).
PRESENTATION_SCREEN = (1600, 1000)


@dataclass
class LiveOptions:
    name: str = "console"
    size: Optional[Tuple[int, int]] = None
    screenshot: Optional[Path] = None
    after: float = 5.0
    record: Optional[Path] = None
    every: float = 1.0
    close_when_done: Optional[float] = None
    start_when_ready: bool = False
    switch_when_stalled: Optional[str] = None
    present: bool = False
    view: ViewOptions = field(default_factory=ViewOptions)


@dataclass
class LiveOutcome:
    frames: List[Path] = field(default_factory=list)
    screenshot: Optional[Path] = None
    run_state: Optional[str] = None
    reason: str = "window closed"


class AutoStart:
    """Presses Start once every robot is connected and has a pose; a refused Start (a robot
    not on its start cell yet) is pressed again a second later, at most `tries` times."""

    def __init__(self, ask: Callable[..., None], tries: int = 30, every: float = 1.0) -> None:
        self.ask, self.tries, self.every = ask, tries, every
        self.done = False
        self._last = -1e9

    def __call__(self, model: LiveModel, now: float) -> None:
        state = model.state
        if self.done or not model.connected or state is None or not state.robots:
            return
        if state.run.state != "waiting" or self.tries <= 0:
            self.done = True  # started (by us or anyone), or we gave up
            return
        if any(r.link != "up" or r.x is None for r in state.robots) or now - self._last < self.every:
            return
        self._last = now
        self.tries -= 1
        self.ask("start", based_on=state.version)


class AutoSwitch:
    """Switches the running run to `strategy` once a robot waits for a stalled one (the story
    told both), as an operator watching would; once: a refused switch is not asked again, and
    a run already under `strategy` is left alone."""

    def __init__(self, ask: Callable[..., None], strategy: str) -> None:
        self.ask, self.strategy = ask, strategy
        self.done = False

    def __call__(self, model: LiveModel, now: float) -> None:
        state = model.state
        if self.done or not model.connected or state is None or state.run.state != "running" \
                or state.run.purpose != "plan":
            return
        if state.run.strategy == self.strategy:
            self.done = True
            return
        stalled = set(model.ticker.stalled())
        if any(r.waiting is not None and stalled.intersection(r.waiting.on) for r in state.robots):
            self.done = True
            self.ask("strategy", based_on=state.version, name=self.strategy)


def run_live_console(endpoint: str, keys: Optional[ConsoleKeys], options: LiveOptions) -> LiveOutcome:
    """Open the live console on the manager at `endpoint` and run it until it closes."""
    from .ui.live_app import LiveApp

    size = options.size or default_canvas_size(13, 14, LIVE_CANVAS)
    screen = (options.size or PRESENTATION_SCREEN) if options.present else (size[0] + 760, size[1] + 160)
    with _screen(options.screenshot is not None or options.record is not None, screen,
                 options.present) as display:
        feed = LiveFeed()
        model = LiveModel(endpoint)
        link = ManagerLink(endpoint, feed, keys=keys, name=options.name).start()
        try:
            root = _tk(display)
            root.geometry("+0+0")
            app = LiveApp(root, feed, model, link.request, options.view, canvas_size=size,
                          recent=RecentFiles(default_recent_path()), present=options.present)
            _wait_until_viewable(root, app.canvas)
            run = _Run(app, options, link.request)
            root.mainloop()
        finally:
            link.stop()
    if run.failed:
        raise FleetError(run.failed)
    return run.outcome


class _Run:
    """What the window does besides showing the fleet: record, take the screenshot, press Start,
    close when done or on a signal. Its `after_frame` runs after each frame, on Tk's thread."""

    def __init__(self, app: "LiveApp", options: LiveOptions, ask: Callable[..., None]) -> None:
        from .ui import capture

        self.app, self.options, self.root = app, options, app.root
        self.outcome = LiveOutcome()
        self.failed = ""
        self.stopping: List[str] = []
        for sig in (signal.SIGINT, signal.SIGTERM):  # from a supervisor: close cleanly
            signal.signal(sig, lambda signum, _f: self.stopping.append(signal.Signals(signum).name))
        self.recorder: Optional[Recorder] = None
        if options.record is not None:
            self.recorder = Recorder(options.record, lambda p: capture.grab(self.root, p), options.every)
            self.outcome.frames = self.recorder.frames
        self.starter = AutoStart(ask) if options.start_when_ready else None
        self.switcher = AutoSwitch(ask, options.switch_when_stalled) if options.switch_when_stalled else None
        self.done_at: Optional[float] = None
        self.closing = False
        app.after_frame.append(self.after_frame)
        if options.screenshot is not None:
            self.root.after(int(options.after * 1000), self.shot)

    def close(self, reason: str) -> None:
        if not self.closing:
            self.closing = True
            self.outcome.reason = reason
            self.root.after_idle(self.root.destroy)

    def after_frame(self) -> None:
        model, now = self.app.model, time.monotonic()
        run = model.state.run if model.state is not None else None
        if run is not None:
            self.outcome.run_state = run.state
        if self.recorder is not None and model.scene is not None:
            try:
                self.recorder.offer(run, [line.text for line in model.story], model.told)
            except FleetError as err:  # the screen cannot be read: say so once, stop recording
                self.app.status.set("recording stopped: {}".format(err))
                self.recorder = None
        if self.starter is not None:
            self.starter(model, now)
        if self.switcher is not None:
            self.switcher(model, now)
        if self.stopping:
            self.close("stopped by {}".format(self.stopping[0]))
        elif self.options.close_when_done is not None and run is not None and run.state == "done":
            if self.done_at is None:
                self.done_at = now
            elif now - self.done_at >= self.options.close_when_done:
                self.close("the run is done")

    def shot(self) -> None:
        from .ui import capture

        try:
            capture.grab(self.root, self.options.screenshot)
            self.outcome.screenshot = self.options.screenshot
        except FleetError as err:
            self.failed = str(err)
        self.close(self.failed or "screenshot taken")


@contextmanager
def _screen(headless_ok: bool, screen: Tuple[int, int], exact: bool = False) -> Iterator[str]:
    """The display to open the window on: $DISPLAY, or a private Xvfb of `screen` pixels (at
    least) when nobody needs to see the window (a screenshot, a recording); without either,
    FleetError saying what to do."""
    if not headless_ok and not os.environ.get("DISPLAY"):
        raise FleetError("no display (DISPLAY is not set): use --screenshot PNG or --record DIR, "
                         "which render on a private Xvfb, or run it on a desktop")
    with _display(screen, exact) as display:
        yield display
