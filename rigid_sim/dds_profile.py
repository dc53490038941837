# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The Fast DDS profile the node ships, used when the user names none.

With Fast DDS's defaults, service answers were lost now and then while the node sent its
all-body messages (~/markers, ~/poses, /tf: ~4 MB a tick for 10 000 bodies) and were resent
only at the answer writer's next heartbeat, 1 to 15 s later: every message a participant
sends on the machine goes through its one shared-memory segment, 0.5 MB by default, and a
full segment takes back its oldest buffers, also one still queued for its reader
(docs/performance.md, "Control answers lost in shared memory"). ``config/fastdds_profiles.xml``
gives the node's participant a 64 MB segment and its service answers a 50 ms heartbeat.

Fast DDS reads the file named by ``FASTRTPS_DEFAULT_PROFILES_FILE`` (``FASTDDS_...`` from
Fast DDS 3 on) and a ``DEFAULT_FASTRTPS_PROFILES.xml`` in the working directory when it
makes the participant, at ``rclpy.init``. The node names its file there only when none of
these is given: a user's profile is never overridden nor merged with this one.
"""
import os
from pathlib import Path

from rigid_sim.resources import config_directories

PROFILE = 'fastdds_profiles.xml'
VARIABLE = 'FASTRTPS_DEFAULT_PROFILES_FILE'   # what Fast DDS 2 (ROS 2 Jazzy) reads
# A user's choice of profile: variables of Fast DDS 2 and 3, files it loads from the
# working directory.
USER_VARIABLES = (VARIABLE, 'FASTDDS_DEFAULT_PROFILES_FILE')
USER_FILES = ('DEFAULT_FASTRTPS_PROFILES.xml', 'DEFAULT_FASTDDS_PROFILES.xml')
# rmw implementations built on Fast DDS; an unset RMW_IMPLEMENTATION is Fast DDS in Jazzy.
FAST_DDS_RMW = ('rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp')


def shipped_profile():
    """Return the path of the packaged profile, or None if it is not installed."""
    for folder in config_directories():
        if (folder / PROFILE).is_file():
            return folder / PROFILE
    return None


def use_shipped_profile(environ=None, working_directory=None):
    """Name the shipped profile in ``environ`` unless the user chose one; the path or None.

    Call it before ``rclpy.init``. ``environ`` defaults to ``os.environ``, the working
    directory to the process's.
    """
    environ = os.environ if environ is None else environ
    folder = Path.cwd() if working_directory is None else Path(working_directory)
    if any(name in environ for name in USER_VARIABLES):
        return None
    if any((folder / name).is_file() for name in USER_FILES):
        return None
    if (environ.get('RMW_IMPLEMENTATION') or FAST_DDS_RMW[0]) not in FAST_DDS_RMW:
        return None
    profile = shipped_profile()
    if profile is not None:
        environ[VARIABLE] = str(profile)
    return profile
