"""The Help window: every key and mouse gesture, from `console.keys`."""
from __future__ import annotations

import tkinter as tk
from tkinter import ttk
from typing import Optional

from ..keys import help_lines

_open: Optional[tk.Toplevel] = None


def show_keys(master: tk.Misc) -> tk.Toplevel:
    """Open (or raise) the list of keyboard shortcuts."""
    global _open
    if _open is not None and _open.winfo_exists():
        _open.lift()
        return _open
    top = tk.Toplevel(master)
    top.title("FleetControl player: keys")
    lines = help_lines()
    text = tk.Text(top, width=58, height=len(lines) + 1, font=("DejaVu Sans Mono", -12),
                   borderwidth=0, padx=10, pady=8)
    text.insert("1.0", "\n".join(lines))
    text.configure(state=tk.DISABLED)
    text.pack(fill=tk.BOTH, expand=True)
    ttk.Button(top, text="Close", command=top.destroy).pack(pady=(0, 8))
    top.bind("<Escape>", lambda e: top.destroy())
    _open = top
    return top
