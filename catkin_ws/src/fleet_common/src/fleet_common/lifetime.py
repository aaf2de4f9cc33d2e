"""Child processes that do not outlive their parent.

A command that starts helpers (the demo: a virtual fleet, a manager, a
console; the console: its private Xvfb) stops them itself on a normal exit
or Ctrl-C. If it is killed outright (SIGKILL, a test's timeout), it cannot,
and the helpers would run on for ever. On Linux the kernel can tell a child
when its parent dies (prctl PR_SET_PDEATHSIG); `die_with_parent` is the
`preexec_fn` that asks for SIGTERM then. Elsewhere it does nothing.
"""
from __future__ import annotations

import ctypes
import signal
import sys
from typing import Callable, Optional

__all__ = ["die_with_parent"]

_PR_SET_PDEATHSIG = 1


def _prctl() -> Optional[Callable[..., int]]:
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


_PRCTL = _prctl()  # looked up before any fork: the child only makes the call


def die_with_parent() -> None:
    """In the child, between fork and exec: SIGTERM when the parent dies."""
    if _PRCTL is not None:
        _PRCTL(_PR_SET_PDEATHSIG, int(signal.SIGTERM))
