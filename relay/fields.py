"""Kept while relay/ moves into packages: the fields live in :mod:`relay.wire.fields`."""

from .wire.fields import show as show

__all__ = ["show"]
