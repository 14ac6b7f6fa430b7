"""Which Fast DDS participant profile the ros backend's node runs with (robots.yaml ``ros.dds_profile``).

Fast DDS reads its default profile file once per process, when its first participant is created, from
``FASTDDS_DEFAULT_PROFILES_FILE`` (``FASTRTPS_DEFAULT_PROFILES_FILE`` before Fast DDS 3). The relay points it at
its own profile for large images (fastdds_large_images.xml, which says why and what it measured) unless the
operator's environment names a file already: theirs wins, and the choice is logged either way. Other RMW
implementations ignore it.
"""

from __future__ import annotations

import logging
import os
from collections.abc import MutableMapping
from pathlib import Path

logger = logging.getLogger(__name__)

#: The profile shipped with the relay: shared memory with room for raw 720p images, then UDPv4.
LARGE_IMAGES = Path(__file__).with_name("fastdds_large_images.xml")
ENV_VARS = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")


def profile_path(setting: str) -> Path | None:
    """The file a ``ros.dds_profile`` setting names: ``large_images`` (the relay's), ``builtin`` (none: Fast DDS's
    own transports) or a path checked when the config is read."""
    if setting == "builtin":
        return None
    return LARGE_IMAGES if setting == "large_images" else Path(setting)


def apply(setting: str, environ: MutableMapping[str, str] = os.environ) -> str:
    """Point Fast DDS at the profile ``setting`` names unless the environment chose one; returns what is in effect
    (for the log and ``/healthz``)."""
    for name in ENV_VARS:
        if environ.get(name):
            logger.info("Fast DDS profile from %s: %s (robots.yaml ros.dds_profile not applied)", name, environ[name])
            return f"{name}={environ[name]}"
    path = profile_path(setting)
    if path is None:
        logger.info("Fast DDS profile: its built-in transports (ros.dds_profile: builtin)")
        return "builtin"
    for name in ENV_VARS:
        environ[name] = str(path)
    logger.info("Fast DDS profile: %s", path)
    return str(path)
