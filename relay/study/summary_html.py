"""The HTML summary of a study's results: per measure, a table of each condition's n, mean, SD and median, and a
plot of every value by condition (inline SVG: one page, no script, nothing fetched)."""

from __future__ import annotations

from collections.abc import Sequence
from html import escape

from .results import Summary

#: The plot's size (px) and its margins: values on a shared axis, one column per condition.
WIDTH, HEIGHT, MARGIN = 360, 160, 36
#: Measures named for people reading the summary; others show their own name.
TITLES = {
    "time_s": "Time to success or the limit (s)",
    "success": "Succeeded (1) or not (0)",
    "sus": "SUS score (0-100)",
    "tlx": "Raw NASA-TLX (0-100)",
    "commands": "Commands sent",
    "refusals": "Commands refused",
    "near_collisions": "Near-collisions (within 0.2 m)",
    "estops": "Emergency stops",
    "teleop_s": "Time driving by hand (s)",
    "goal_s": "Time with a goal (s)",
    "view_switches": "View switches",
    "probe_correct": "Situation-awareness probes answered right (share)",
}


def _number(value: float | None) -> str:
    return "–" if value is None else f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"


def plot(summaries: Sequence[Summary]) -> str:
    """Every value as a dot over its condition, the mean as a bar."""
    values = [v for s in summaries for v in s.values]
    low, high = min([*values, 0.0]), max(values)
    span = (high - low) or 1.0
    column = (WIDTH - 2 * MARGIN) / max(1, len(summaries))

    def y(v: float) -> float:
        return HEIGHT - MARGIN - (v - low) / span * (HEIGHT - 2 * MARGIN)

    parts = [
        f'<svg viewBox="0 0 {WIDTH} {HEIGHT}" width="{WIDTH}" height="{HEIGHT}" role="img">',
        f'<line x1="{MARGIN}" y1="{y(low):.1f}" x2="{WIDTH - MARGIN}" y2="{y(low):.1f}" class="axis"/>',
        f'<text x="4" y="{y(high) + 4:.1f}">{_number(high)}</text>',
        f'<text x="4" y="{y(low) + 4:.1f}">{_number(low)}</text>',
    ]
    for i, s in enumerate(summaries):
        centre = MARGIN + column * (i + 0.5)
        for k, v in enumerate(s.values):
            dx = (k % 5 - 2) * 3  # a little spread, so that equal values stay countable
            parts.append(f'<circle cx="{centre + dx:.1f}" cy="{y(v):.1f}" r="3"/>')
        parts.append(
            f'<line x1="{centre - column / 3:.1f}" y1="{y(s.mean):.1f}" x2="{centre + column / 3:.1f}" '
            f'y2="{y(s.mean):.1f}" class="mean"/>'
        )
        parts.append(f'<text x="{centre:.1f}" y="{HEIGHT - 8}" text-anchor="middle">{escape(s.condition)}</text>')
    parts.append("</svg>")
    return "".join(parts)


def summary_html(study: str, summaries: Sequence[Summary], participants: int) -> str:
    measures = list(dict.fromkeys(s.measure for s in summaries))
    sections = []
    for measure in measures:
        rows = [s for s in summaries if s.measure == measure]
        table = "".join(
            f"<tr><td>{escape(s.condition)}</td><td>{s.n}</td><td>{_number(s.mean)}</td>"
            f"<td>{_number(s.sd)}</td><td>{_number(s.median)}</td></tr>"
            for s in rows
        )
        sections.append(
            f"<section><h2>{escape(TITLES.get(measure, measure))}</h2><table><thead><tr><th>Condition</th><th>n</th>"
            f"<th>Mean</th><th>SD</th><th>Median</th></tr></thead><tbody>{table}</tbody></table>{plot(rows)}</section>"
        )
    style = (
        "body{font:14px system-ui,sans-serif;margin:2em;color:#111}table{border-collapse:collapse;margin:.5em 0}"
        "td,th{border:1px solid #bbb;padding:.2em .6em;text-align:right}td:first-child{text-align:left}"
        "svg text{font-size:11px}circle{fill:#2a6fb0}.mean{stroke:#c0392b;stroke-width:3}.axis{stroke:#888}"
    )
    people = f"{participants} participant" + ("" if participants == 1 else "s")
    return (
        f'<!doctype html><html lang="en"><head><meta charset="utf-8"><title>{escape(study)}: results</title>'
        f"<style>{style}</style></head><body><h1>{escape(study)}</h1><p>{people}.</p>"
        + "".join(sections)
        + "</body></html>\n"
    )
