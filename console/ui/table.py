"""A scrolled table (ttk.Treeview with a scrollbar), as the live console's lists use it."""
from __future__ import annotations

import tkinter as tk
from tkinter import ttk
from typing import Callable, Optional, Sequence, Tuple

Column = Tuple[str, str, int]  # name, heading, width in pixels


def scrolled_table(master: tk.Misc, columns: Sequence[Column], style: str, font: tuple, row_height: int,
                   height: int, stretch: str, tree_column: str = "",
                   on_scroll: Optional[Callable[[], None]] = None) -> ttk.Treeview:
    """A table packed into `master` beside its scrollbar; `stretch` names the column that takes
    the spare width; with `tree_column` (its heading) the first column is Tk's tree column,
    which can show an image before its text; `on_scroll` is called when other rows come into
    view."""
    body = ttk.Frame(master)
    body.pack(fill=tk.BOTH, expand=True)
    ttk.Style(master).configure(style, font=font, rowheight=row_height)
    tree = ttk.Treeview(body, columns=[c[0] for c in columns], show=("tree", "headings") if tree_column
                        else "headings", selectmode="browse", height=height, style=style, takefocus=0)
    for name, title, width in columns:
        tree.heading(name, text=title)
        tree.column(name, width=width, stretch=name == stretch, anchor=tk.W)
    if tree_column:
        tree.heading("#0", text=tree_column)
    bar = ttk.Scrollbar(body, orient=tk.VERTICAL, command=tree.yview)
    def scrolled(first: str, last: str) -> None:
        bar.set(first, last)
        if on_scroll is not None:
            on_scroll()

    tree.configure(yscrollcommand=scrolled)
    tree.pack(side=tk.LEFT, fill=tk.BOTH, expand=True)
    bar.pack(side=tk.RIGHT, fill=tk.Y)
    return tree
