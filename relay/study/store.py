"""Where a study's runs are kept: one JSON file per participant in the study's folder, written whole and atomically
after every change of the run, so that a relay stopped at any moment restarts from the last step taken.

Blocking (a write and an fsync): the relay calls it off the event loop (relay/study/service.py). Beside the runs,
``_active.json`` names the participant whose run the relay drives, so that a restarted relay goes on with it.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import IO, Any

from ..atomic_file import write_atomically
from .model import Study
from .run import RunState, StudyError, StudyRun

#: A run's file is read whole: bounded (a run of 50 tasks with probes is about 40 kB).
MAX_RUN_BYTES = 5_000_000
#: The file naming the participant whose run the relay drives (participants' names never start with "_").
ACTIVE = "_active.json"


class RunStore:
    def __init__(self, folder: Path, study: Study) -> None:
        self.folder = Path(folder) / study.name
        self.study = study

    def _path(self, participant: str) -> Path:
        return self.folder / f"{participant}.json"

    def save(self, run: StudyRun) -> None:
        self.write(run.state.participant, run.saved())

    def write(self, participant: str, saved: Mapping[str, Any]) -> None:
        """A run's state as :meth:`StudyRun.saved` gave it (taken on the relay's loop, written here, off it)."""
        self._write(self._path(participant), json.dumps(saved).encode())

    def set_active(self, participant: str) -> None:
        """The participant whose run the relay drives: the one it goes on with after a restart."""
        self._write(self.folder / ACTIVE, json.dumps({"participant": participant}).encode())

    def active(self) -> str | None:
        """The participant last joined (None: nobody yet, or one no longer in the study)."""
        path = self.folder / ACTIVE
        if not path.exists():
            return None
        saved = self._read(path, ("participant",))
        participant = saved.get("participant")
        return participant if participant in self.study.participants else None

    def _write(self, path: Path, data: bytes) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)

        def write(out: IO[bytes]) -> None:
            out.write(data)

        write_atomically(path, write)

    def load(self, participant: str) -> StudyRun:
        """The participant's run as last saved, or a new one at the start."""
        path = self._path(participant)
        if not path.exists():
            return StudyRun(self.study, RunState(participant))
        return StudyRun.restored(self.study, self._read(path))

    def runs(self) -> list[StudyRun]:
        """Every participant's saved run, in the study's order of participants."""
        return [self.load(p) for p in self.study.participants if self._path(p).exists()]

    def _read(self, path: Path, fields: Iterable[str] = RunState.__dataclass_fields__) -> dict[str, Any]:
        try:
            with path.open("rb") as f:
                data = f.read(MAX_RUN_BYTES + 1)
            if len(data) > MAX_RUN_BYTES:
                raise StudyError(f"{path}: larger than {MAX_RUN_BYTES} bytes")
            saved = json.loads(data)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise StudyError(f"{path}: not a readable run ({str(exc)[:200]})") from None
        fields = set(fields)
        if not isinstance(saved, dict) or not set(saved) <= fields or "participant" not in saved:
            raise StudyError(f"{path}: not a run of this relay (fields {', '.join(sorted(fields))})")
        return saved
