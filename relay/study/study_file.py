"""Reading a study file (YAML): every error names the file, the line and the field, as robots.yaml's do.

    study: valve-and-spill
    participants: [P01, P02, P03, P04]
    conditions:
      - {name: headset, client: {view: headset}}
      - {name: desktop, client: {view: desktop, sound: off}}
    order: latin              # a balanced Latin square; or {P01: [desktop, headset], ...}
    questionnaires: {after_task: [tlx], after_condition: [sus]}
    tasks:
      - name: reach-spill
        instruction: Send robot1 to the spill in chemical storage.
        time_limit: 180
        start: {reset_estop: true, robots: {robot1: {x: 2.0, y: 3.0, yaw: 0}}}
        success: {robot_in_region: {robot: robot1, region: [[9, 1], [12, 1], [12, 4], [9, 4]]}}
        probes: [{at: 30, question: room, robot: robot2}]

docs/study.md describes every field.
"""

from __future__ import annotations

import re
from pathlib import Path

from yaml.nodes import MappingNode, Node, ScalarNode

from ..config.reader import _Reader, compose
from ..errors import ConfigError
from .counterbalance import latin_orders
from .model import (
    CLIENT_SETTINGS,
    PROBE_QUESTIONS,
    QUESTIONNAIRES,
    Condition,
    FindingAtTarget,
    GoalReached,
    Probe,
    Questionnaire,
    RobotInRegion,
    Start,
    StartPose,
    Study,
    Success,
    Task,
)

#: Names of studies, participants, conditions and tasks: they become file names and CSV cells.
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
_NAME_EXPECTED = "a name of letters, digits, '_', '.' or '-' (at most 64)"
#: A study file is read whole: bounded, as every file the relay loads.
MAX_BYTES = 1_000_000
MAX_ITEMS = 1000
MAX_INSTRUCTION = 2000


def load_study(path: str | Path) -> Study:
    path = Path(path)
    try:
        with path.open("rb") as f:
            data = f.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ConfigError(str(path), None, "", f"cannot read the file: {exc.strerror or exc}") from None
    if len(data) > MAX_BYTES:
        raise ConfigError(str(path), None, "", f"larger than {MAX_BYTES} bytes")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(str(path), None, "", "the file is not UTF-8 text") from None
    return parse_study(text, str(path))


def parse_study(text: str, file: str = "study.yaml") -> Study:
    root = compose(text, file)
    if root is None:
        raise ConfigError(file, None, "", "the file is empty; a study needs participants, conditions and tasks")
    return _StudyReader(file).study(root)


class _StudyReader(_Reader):
    def name(self, node: Node, path: str) -> str:
        return self.string(node, path, pattern=_NAME, expected=_NAME_EXPECTED)

    def names(self, node: Node, path: str) -> list[tuple[Node, str]]:
        out: list[tuple[Node, str]] = []
        for i, item in self.sequence(node, path):
            if i >= MAX_ITEMS:
                raise self.fail(item, path, f"more than {MAX_ITEMS} entries")
            name = self.name(item, f"{path}[{i}]")
            if any(name == seen for _, seen in out):
                raise self.fail(item, f"{path}[{i}]", f'"{name}" appears twice')
            out.append((item, name))
        return out

    def study(self, root: Node) -> Study:
        top = self.mapping(
            root,
            "",
            ("study", "participants", "conditions", "order", "questionnaires", "tasks"),
            required=("study", "participants", "conditions", "tasks"),
        )
        participants = [name for _, name in self.names(top["participants"], "participants")]
        if not participants:
            raise self.fail(top["participants"], "participants", "needs at least one participant")
        conditions = self.conditions(top["conditions"])
        order_node = top.get("order")
        names = [c.name for c in conditions]
        if order_node is None or (isinstance(order_node, ScalarNode) and self.value(order_node) == "latin"):
            orders = latin_orders(participants, names)
        else:
            orders = self.orders(order_node, participants, names)
        after_task, after_condition = self.questionnaires(top.get("questionnaires"))
        return Study(
            name=self.name(top["study"], "study"),
            participants=tuple(participants),
            conditions=tuple(conditions),
            orders=tuple(orders),
            tasks=self.tasks(top["tasks"]),
            after_task=after_task,
            after_condition=after_condition,
        )

    def conditions(self, node: Node) -> list[Condition]:
        out: list[Condition] = []
        for i, item in self.sequence(node, "conditions"):
            path = f"conditions[{i}]"
            f = self.mapping(item, path, ("name", "client"), required=("name",))
            name = self.name(f["name"], f"{path}.name")
            if any(c.name == name for c in out):
                raise self.fail(f["name"], f"{path}.name", f'"{name}" appears twice')
            settings: list[tuple[str, str]] = []
            if "client" in f:
                fields = self.mapping(f["client"], f"{path}.client", tuple(CLIENT_SETTINGS))
                for key, value in fields.items():
                    # YAML reads a bare on/off as true/false: both spellings mean the setting's two values.
                    raw = self.value(value)
                    text = {True: "on", False: "off"}.get(raw, raw) if isinstance(raw, bool) else raw
                    if text not in CLIENT_SETTINGS[key]:
                        choices = ", ".join(CLIENT_SETTINGS[key])
                        raise self.fail(
                            value, f"{path}.client.{key}", f"expected one of {choices}, got {self.show(value)}"
                        )
                    settings.append((key, str(text)))
            out.append(Condition(name, tuple(settings)))
        if not out:
            raise self.fail(node, "conditions", "needs at least one condition")
        return out

    def orders(self, node: Node, participants: list[str], names: list[str]) -> list[tuple[str, tuple[str, ...]]]:
        f = self.mapping(node, "order", tuple(participants), required=tuple(participants))
        out: list[tuple[str, tuple[str, ...]]] = []
        for participant in participants:
            path = f"order.{participant}"
            given = self.names(f[participant], path)
            for item, name in given:
                if name not in names:
                    raise self.fail(item, path, f'"{name}" is not a condition; expected one of ' + ", ".join(names))
            if len(given) != len(names):
                missing = ", ".join(n for n in names if n not in {g for _, g in given})
                raise self.fail(f[participant], path, f"every condition once; missing {missing}")
            out.append((participant, tuple(name for _, name in given)))
        return out

    def questionnaires(self, node: Node | None) -> tuple[tuple[Questionnaire, ...], tuple[Questionnaire, ...]]:
        if node is None:
            return ("tlx",), ("sus",)
        f = self.mapping(node, "questionnaires", ("after_task", "after_condition"))
        chosen: list[tuple[Questionnaire, ...]] = []
        for key, default in (("after_task", ("tlx",)), ("after_condition", ("sus",))):
            if key not in f:
                chosen.append(default)  # type: ignore[arg-type]
                continue
            items: list[Questionnaire] = []
            for i, item in self.sequence(f[key], f"questionnaires.{key}"):
                items.append(self.choice(item, f"questionnaires.{key}[{i}]", QUESTIONNAIRES))  # type: ignore[arg-type]
            chosen.append(tuple(items))
        return chosen[0], chosen[1]

    def tasks(self, node: Node) -> tuple[Task, ...]:
        out: list[Task] = []
        for i, item in self.sequence(node, "tasks"):
            if i >= MAX_ITEMS:
                raise self.fail(item, "tasks", f"more than {MAX_ITEMS} tasks")
            path = f"tasks[{i}]"
            f = self.mapping(
                item,
                path,
                ("name", "instruction", "time_limit", "start", "success", "probes"),
                required=("name", "instruction", "time_limit", "success"),
            )
            name = self.name(f["name"], f"{path}.name")
            if any(t.name == name for t in out):
                raise self.fail(f["name"], f"{path}.name", f'"{name}" appears twice')
            instruction = self.string(f["instruction"], f"{path}.instruction")
            if len(instruction) > MAX_INSTRUCTION:
                raise self.fail(f["instruction"], f"{path}.instruction", f"longer than {MAX_INSTRUCTION} characters")
            limit = self.number(f["time_limit"], f"{path}.time_limit", positive=True)
            start = self.start(f["start"], f"{path}.start") if "start" in f else Start()
            probes = self.probes(f["probes"], f"{path}.probes", limit) if "probes" in f else ()
            out.append(Task(name, instruction, limit, start, self.success(f["success"], f"{path}.success"), probes))
        if not out:
            raise self.fail(node, "tasks", "needs at least one task")
        return tuple(out)

    def start(self, node: Node, path: str) -> Start:
        f = self.mapping(node, path, ("reset_estop", "robots"))
        reset = self.boolean(f["reset_estop"], f"{path}.reset_estop") if "reset_estop" in f else True
        poses: list[StartPose] = []
        if "robots" in f:
            robots = self.mapping(f["robots"], f"{path}.robots", tuple(self.keys(f["robots"], f"{path}.robots")))
            for robot, pose_node in robots.items():
                where = f"{path}.robots.{robot}"
                p = self.mapping(pose_node, where, ("x", "y", "yaw"), required=("x", "y"))
                yaw = self.number(p["yaw"], f"{where}.yaw") if "yaw" in p else 0.0
                poses.append(
                    StartPose(robot, self.number(p["x"], f"{where}.x"), self.number(p["y"], f"{where}.y"), yaw)
                )
        return Start(tuple(poses), reset)

    def keys(self, node: Node, path: str) -> list[str]:
        """The keys of a mapping whose keys are robot names (checked against the fleet when the study starts)."""
        if not isinstance(node, MappingNode):
            raise self.fail(node, path, f"expected a mapping, got {self.show(node)}")
        return [self.name(key, path) for key, _ in node.value]

    def success(self, node: Node, path: str) -> Success:
        kinds = ("robot_in_region", "finding_at_target", "goal_reached")
        f = self.mapping(node, path, kinds)
        if len(f) != 1:
            raise self.fail(node, path, "expected exactly one of " + ", ".join(kinds))
        ((kind, value),) = f.items()
        where = f"{path}.{kind}"
        if kind == "robot_in_region":
            g = self.mapping(value, where, ("robot", "region"), required=("robot", "region"))
            region = tuple(
                self.point(p, f"{where}.region[{i}]") for i, p in self.sequence(g["region"], f"{where}.region")
            )
            if len(region) < 3:
                raise self.fail(g["region"], f"{where}.region", "a region needs at least three corners")
            return RobotInRegion(self.name(g["robot"], f"{where}.robot"), region)
        if kind == "finding_at_target":
            g = self.mapping(value, where, ("target",), required=("target",))
            return FindingAtTarget(self.name(g["target"], f"{where}.target"))
        g = self.mapping(value, where, ("robot", "without_collision"), required=("robot",))
        clean = (
            self.boolean(g["without_collision"], f"{where}.without_collision") if "without_collision" in g else False
        )
        return GoalReached(self.name(g["robot"], f"{where}.robot"), clean)

    def point(self, node: Node, path: str) -> tuple[float, float]:
        items = list(self.sequence(node, path))
        if len(items) != 2:
            raise self.fail(node, path, f"expected [x, y] in metres, got {self.show(node)}")
        return self.number(items[0][1], f"{path}[0]"), self.number(items[1][1], f"{path}[1]")

    def probes(self, node: Node, path: str, limit: float) -> tuple[Probe, ...]:
        out: list[Probe] = []
        for i, item in self.sequence(node, path):
            where = f"{path}[{i}]"
            f = self.mapping(item, where, ("at", "question", "robot"), required=("at", "question", "robot"))
            at = self.number(f["at"], f"{where}.at", positive=True)
            if at >= limit:
                raise self.fail(f["at"], f"{where}.at", f"after the task's time limit ({limit:g} s)")
            question = self.choice(f["question"], f"{where}.question", PROBE_QUESTIONS)
            out.append(Probe(at, question, self.name(f["robot"], f"{where}.robot")))  # type: ignore[arg-type]
        return tuple(sorted(out, key=lambda p: p.at))
