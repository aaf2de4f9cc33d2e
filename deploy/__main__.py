"""`python -m deploy`: what scripts/ciirc-exec.sh's server:*, robots:* and net:check call."""
from __future__ import annotations

import sys

from .cli import main

sys.exit(main())
