"""Reading YAML nodes with their line numbers, so that every error names the file, the line and the field."""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

import yaml
from yaml.constructor import SafeConstructor
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from ..errors import ConfigError
from .model import Limits

_TOPIC = re.compile(r"^/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*$")
_FRAME = re.compile(r"^[A-Za-z0-9_./-]{1,128}$")
_COLOUR = re.compile(r"^#[0-9a-fA-F]{6}$")

T = TypeVar("T")


class _Reader:
    """Walks the composed YAML node tree so that every error can name its line."""

    def __init__(self, file: str) -> None:
        self.file = file
        self._constructor = SafeConstructor()

    def fail(self, node: Node | None, path: str, message: str) -> ConfigError:
        line = node.start_mark.line + 1 if node is not None else None
        return ConfigError(self.file, line, path, message)

    def value(self, node: Node) -> Any:
        return self._constructor.construct_object(node, deep=True)

    def show(self, node: Node) -> str:
        if isinstance(node, ScalarNode):
            value = self.value(node)
            return "nothing" if value is None else f'"{value}"' if isinstance(value, str) else str(value)
        return "a list" if isinstance(node, SequenceNode) else "a mapping"

    def mapping(
        self, node: Node, path: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()
    ) -> dict[str, Node]:
        if not isinstance(node, MappingNode):
            raise self.fail(node, path, f"expected a mapping, got {self.show(node)}")
        out: dict[str, Node] = {}
        for key_node, value_node in node.value:
            key = self.value(key_node)
            if not isinstance(key, str):
                raise self.fail(key_node, path, f"keys must be strings, got {self.show(key_node)}")
            if key in out:
                raise self.fail(key_node, _join(path, key), "appears twice")
            if key not in allowed:
                raise self.fail(key_node, _join(path, key), "unknown field; expected one of " + ", ".join(allowed))
            out[key] = value_node
        for key in required:
            if key not in out:
                raise self.fail(node, _join(path, key), "is required")
        return out

    def sequence(self, node: Node, path: str) -> Iterator[tuple[int, Node]]:
        if not isinstance(node, SequenceNode):
            raise self.fail(node, path, f"expected a list, got {self.show(node)}")
        return enumerate(node.value)

    def number(self, node: Node, path: str, *, positive: bool = False, non_negative: bool = False) -> float:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
            number = float(value)
            if not ((positive and number <= 0) or (non_negative and number < 0)):
                return number
        what = "a positive number" if positive else "a number >= 0" if non_negative else "a number"
        raise self.fail(node, path, f"expected {what}, got {self.show(node)}")

    def optional_number(self, node: Node | None, path: str) -> float | None:
        if node is None or (isinstance(node, ScalarNode) and self.value(node) is None):
            return None
        return self.number(node, path)

    def integer(self, node: Node, path: str) -> int:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, int) or isinstance(value, bool) or value <= 0:
            raise self.fail(node, path, f"expected a positive integer, got {self.show(node)}")
        return value

    def boolean(self, node: Node, path: str) -> bool:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, bool):
            raise self.fail(node, path, f"expected true or false, got {self.show(node)}")
        return value

    def string(
        self, node: Node, path: str, *, pattern: re.Pattern[str] | None = None, expected: str = "a string"
    ) -> str:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, str) or not value or (pattern is not None and not pattern.match(value)):
            raise self.fail(node, path, f"expected {expected}, got {self.show(node)}")
        return value

    def choice(self, node: Node, path: str, choices: tuple[str, ...]) -> str:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if value not in choices:
            raise self.fail(node, path, "expected one of " + ", ".join(choices) + f", got {self.show(node)}")
        assert isinstance(value, str)
        return value

    def get(self, fields: dict[str, Node], key: str, path: str, read: Callable[[Node, str], T], default: T) -> T:
        node = fields.get(key)
        if node is None:
            return default
        return read(node, _join(path, key))


def compose(text: str, file: str) -> Node | None:
    """The YAML text's node tree (None for an empty file); YAML that does not parse is a ConfigError naming the line."""
    try:
        node: Node | None = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as exc:
        line = exc.problem_mark.line + 1 if exc.problem_mark is not None else None
        raise ConfigError(file, line, "", f"not valid YAML: {exc.problem}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(file, None, "", f"not valid YAML: {exc}") from None
    return node


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _topic(reader: _Reader, node: Node, path: str, namespace: str) -> str:
    value = reader.string(node, path, pattern=_TOPIC, expected="a ROS topic name such as /robot1/odom")
    return resolve_topic(namespace, value)


def resolve_topic(namespace: str, name: str) -> str:
    """An absolute topic as written; a relative one inside ``namespace`` (``""`` is the root)."""
    if name.startswith("/"):
        return name
    return f"{namespace.rstrip('/')}/{name}"


def speed_limits(reader: _Reader, node: Node, path: str) -> Limits:
    """``{linear: m/s, angular: rad/s}``, both required and positive: a base's velocity limits, an arm tip's."""
    f = reader.mapping(node, path, ("linear", "angular"), required=("linear", "angular"))
    return Limits(
        linear=reader.number(f["linear"], f"{path}.linear", positive=True),
        angular=reader.number(f["angular"], f"{path}.angular", positive=True),
    )
