"""The two exceptions of the URDF → GLB conversion.

RelayError (relay.errors)
└── RobotModelError   the URDF cannot become a model at all; callers see it
MeshUnavailable       one mesh file cannot be used; the conversion turns it into a fallback and a warning
                      (or, with ``fallback=False``, into a RobotModelError), so it never leaves the package
"""

from __future__ import annotations

from ...errors import RelayError


class RobotModelError(RelayError):
    """A URDF cannot be turned into a model: unparsable XML, no links, a broken tree, or (with
    ``fallback=False``) a mesh file that is missing or unreadable. The message says which."""


class MeshUnavailable(Exception):
    """A mesh URI that cannot be turned into triangles; the message names the file and why."""
