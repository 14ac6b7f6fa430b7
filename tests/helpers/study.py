"""The browser tests' study: a relay running DRIVE_STUDY (tests/helpers/study_files.py), and its results as
`xr-relay study export` writes them, read back."""

from __future__ import annotations

import asyncio
import contextlib
import csv
import io
from collections.abc import AsyncIterator
from pathlib import Path

from relay.cli.options import Options
from relay.config import load_config
from relay.study import cli as study_cli
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.helpers.study_files import DRIVE_STUDY


@contextlib.asynccontextmanager
async def study_relay(folder: Path, study_text: str = DRIVE_STUDY) -> AsyncIterator[RunningRelay]:
    """The demo fleet's relay running ``study_text`` (written to ``folder``/study.yaml, its runs in ``folder``/runs)."""
    study = folder / "study.yaml"
    await asyncio.to_thread(study.write_text, study_text)
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    running = await start_relay(config, options=Options(study=str(study), study_runs=str(folder / "runs")))
    try:
        yield running
    finally:
        await running.runner.cleanup()


async def exported(folder: Path) -> dict[tuple[str, str, str], float]:
    """Export the study run under ``folder`` (its study.yaml, its runs/) and read the tidy CSV back: each row's value
    by (condition, task, measure)."""
    out = folder / "results"
    argv = ["export", str(folder / "study.yaml"), "--runs", str(folder / "runs"), "--out", str(out)]
    assert await asyncio.to_thread(study_cli.main, argv) == 0
    text = await asyncio.to_thread((out / "drive-study.csv").read_text)
    return {(r["condition"], r["task"], r["measure"]): float(r["value"]) for r in csv.DictReader(io.StringIO(text))}
