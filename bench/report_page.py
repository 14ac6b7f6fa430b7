"""The page's parts every section uses: tables, a target's status, the page itself and a section's head."""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from typing import Any

import matplotlib

matplotlib.use("Agg")  # files only: no display on a benchmark machine

import matplotlib.pyplot as plt

from .common import JsonDict, Settings


def table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for row in rows:
        lines.append("| " + " | ".join(str(c) for c in row) + " |")
    return "\n".join(lines) + "\n"


def status(t: JsonDict) -> str:
    if t["met"] is True:
        return "met"
    if t["met"] is False:
        return "**MISSED**"
    return "n/a" if t.get("reason") else "reported"


def pct(value: float | None) -> str:
    return "n/a" if value is None else f"{100 * value:.0f} %"


class Page:
    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.parts: list[str] = []
        settings.img.mkdir(parents=True, exist_ok=True)

    def add(self, text: str) -> None:
        self.parts.append(text.rstrip("\n") + "\n")

    def image(self, fig: Any, name: str, alt: str) -> None:
        path = self.settings.img / f"bench_{name}.png"
        if fig.get_layout_engine() is None:
            fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        relative = os.path.relpath(path, self.settings.doc.parent)
        self.add(f"![{alt}]({relative})\n")

    def text(self) -> str:
        return "\n".join(self.parts)


def anchor(title: str) -> str:
    return "".join(c for c in title.lower().replace(" ", "-") if c.isalnum() or c == "-")


def section(page: Page, r: JsonDict, doc: str) -> bool:
    page.add(f"## {r['title']}\n")
    page.add(doc)
    if "error" in r:
        page.add(f"**The benchmark failed:** `{r['error']}`\n")
        return False
    if "skipped" in r:
        page.add(f"**Not measured:** {r['skipped']}.\n")
        return False
    return True
