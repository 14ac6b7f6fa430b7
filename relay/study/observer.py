"""What the relay's events count in a study's task running: the operator's commands and the relay's refusals,
estops, changes of view, findings marked and goals reached. Hooks the session, inspection and the event router call;
each counts and returns (none is on a stop's path), and nothing is counted outside a task."""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from ..errors import ProtocolError
from .run import StudyRun

if TYPE_CHECKING:
    from ..session.protocol import Command

#: Commands that are not the operator's work in a task: keep-alives, names, streams, history, the study's own.
_NOT_COUNTED: Final = frozenset({"ping", "name", "findings/page", "study/join", "study/start", "study/answer"})
#: Commands sent continuously while a robot or arm is driven by hand: counted only when refused (their time is
#: ``teleop_s``).
_CONTINUOUS: Final = ("cmd_vel", "arm/twist")


class StudyEvents:
    """The hooks into the study's active run (``active``, which the study service sets; None: nothing counts). Built
    before the parts that call it (the audit, inspection, the event router), and given to the study service."""

    def __init__(self) -> None:
        self.active: StudyRun | None = None
        self._views: dict[str, str] = {}  # what each client last said it looks through (its `viewer`'s view)

    def observe(self, command: Command, error: ProtocolError | None) -> None:
        """A command's outcome (the session calls this beside the audit): counted in the task running."""
        run = self.active
        if run is None or run.state.phase != "task" or command.identifier in _NOT_COUNTED:
            return
        if command.identifier.endswith("/stream"):
            return
        if error is None and command.identifier.endswith(_CONTINUOUS):
            return
        if error is None and command.identifier == "estop" and getattr(command, "action", "stop") == "stop":
            run.estop()
        run.command(refused=error is not None)

    def viewed(self, client_id: str, view: str | None) -> None:
        """A client's viewpoint (``viewer``) said what it looks through: a change is a view switch of the task
        running (the first a client says is where it starts, not a switch)."""
        if view is None:
            return
        before = self._views.get(client_id)
        self._views[client_id] = view
        run = self.active
        if before is not None and before != view and run is not None:
            run.view_switch()

    def forget(self, client_id: str) -> None:
        """The client left: its view is no longer kept."""
        self._views.pop(client_id, None)

    def finding(self, target: str | None) -> None:
        """A finding was marked (about a capture of ``target``, if any)."""
        run = self.active
        if run is not None and target is not None:
            run.finding(target)

    def goal_reached(self, robot: str) -> None:
        run = self.active
        if run is not None:
            run.goal_reached(robot)
