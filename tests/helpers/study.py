"""A study's results as `xr-relay study export` writes them, read back by the browser tests that answered it."""

from __future__ import annotations

import asyncio
import csv
import io
from pathlib import Path

from relay.study import cli as study_cli


async def exported(folder: Path) -> dict[tuple[str, str, str], float]:
    """Export the study run under ``folder`` (its study.yaml, its runs/) and read the tidy CSV back: each row's value
    by (condition, task, measure)."""
    out = folder / "results"
    argv = ["export", str(folder / "study.yaml"), "--runs", str(folder / "runs"), "--out", str(out)]
    assert await asyncio.to_thread(study_cli.main, argv) == 0
    text = await asyncio.to_thread((out / "drive-study.csv").read_text)
    return {(r["condition"], r["task"], r["measure"]): float(r["value"]) for r in csv.DictReader(io.StringIO(text))}
