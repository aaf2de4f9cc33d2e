"""Recording a live run as pictures: a frame every N plan steps, and at each change of the run.

`FrameSchedule` decides (pure): a frame when the first state is shown, when
the run's state changes (waiting, running, paused, done, ...), and each time
the run's plan clock (`RunInfo.run_steps`, which goes on across a reroute)
passes another multiple of `every` steps. `Recorder` writes the frames as
NNNN.png through the grab function it is given (the window's pixels,
`console.ui.capture`), and one line per frame in `frames.txt` (file, run
state, plan step, run clock, then the sentences of the run's story told
since the frame before, as the presentation view's ticker shows them; a new
sentence is a frame of its own), so a headless run leaves a picture story of
itself.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Callable, List, Optional, Sequence

from fleet_common.control import RunInfo

__all__ = ["FrameSchedule", "Recorder"]


class FrameSchedule:
    def __init__(self, every: float = 1.0) -> None:
        if not every > 0:
            raise ValueError("frames every {} steps: expected a positive number".format(every))
        self.every = every
        self._state: Optional[str] = None
        self._slot = -1

    def due(self, run: Optional[RunInfo]) -> bool:
        """Whether the picture showing `run` should be saved."""
        if run is None:
            return False
        slot = int(math.floor(run.run_steps / self.every + 1e-9)) if run.clock > 0 else -1
        changed = run.state != self._state
        moved = slot > self._slot
        self._state, self._slot = run.state, max(slot, self._slot)
        return changed or moved


class Recorder:
    def __init__(self, folder: Path, grab: Callable[[Path], None], every: float = 1.0) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.grab = grab
        self.schedule = FrameSchedule(every)
        self.frames: List[Path] = []
        self._told = 0
        self._index = self.folder / "frames.txt"
        self._index.write_text("# file  run state  plan step  run clock (s)  | the story told since the "
                               "frame before\n")

    def offer(self, run: Optional[RunInfo], story: Sequence[str] = (), told: int = 0) -> Optional[Path]:
        """Save a frame if one is due for `run`, or the story (its last sentences, `told` of them
        so far) says something new; the file written, if any."""
        due = self.schedule.due(run)
        new = list(story)[max(0, len(story) - (told - self._told)):] if told > self._told else []
        if new and run is not None:
            due = True
        if not due:
            return None
        self._told = told
        return self.save(run, " ; ".join(new))

    def save(self, run: Optional[RunInfo], told: str = "") -> Path:
        path = self.folder / "{:04d}.png".format(len(self.frames) + 1)
        self.grab(path)
        self.frames.append(path)
        with self._index.open("a") as index:
            index.write("{}  {}  {:.2f}  {:.2f}{}\n".format(
                path.name, run.state if run else "-", run.run_steps if run else 0.0,
                run.clock if run else 0.0, "  | " + told if told else ""))
        return path
