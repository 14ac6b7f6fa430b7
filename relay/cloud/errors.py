"""The one exception of the cloud package.

RelayError (relay.errors)
└── CloudError   a cloud, depth image or map file that cannot be read; the message names the field, encoding or file
"""

from __future__ import annotations

from typing import Final

from ..errors import RelayError

#: The longest a name taken from the wire (a field, an encoding) may be in a message: anyone can send a long one.
NAME_LIMIT: Final = 40


class CloudError(RelayError):
    """A sensor message or a map file that cannot become points or voxels; ``str(err)`` says which part and why."""


def shown(name: object) -> str:
    """``name`` quoted and cut to :data:`NAME_LIMIT` characters, for a message of bounded length."""
    text = str(name)
    return repr(text if len(text) <= NAME_LIMIT else text[:NAME_LIMIT] + "...")
