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
these is given: a user's profile is never overridden nor merged with this one. Fast DDS
writes the whole segment when it makes it, so the profile is not used either when
``/dev/shm`` has less than twice the segment free (Docker gives containers 64 MB): a write
past a full tmpfs would kill the process.
"""
from collections import namedtuple
import os
from pathlib import Path
import shutil
import xml.etree.ElementTree as ElementTree

from rigid_sim.resources import config_directories

PROFILE = 'fastdds_profiles.xml'
VARIABLE = 'FASTRTPS_DEFAULT_PROFILES_FILE'   # what Fast DDS 2 (ROS 2 Jazzy) reads
# A user's choice of profile: variables of Fast DDS 2 and 3, files it loads from the
# working directory.
USER_VARIABLES = (VARIABLE, 'FASTDDS_DEFAULT_PROFILES_FILE')
USER_FILES = ('DEFAULT_FASTRTPS_PROFILES.xml', 'DEFAULT_FASTDDS_PROFILES.xml')
# rmw implementations built on Fast DDS; an unset RMW_IMPLEMENTATION is Fast DDS in Jazzy.
FAST_DDS_RMW = ('rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp')
SHARED_MEMORY = Path('/dev/shm')   # where Fast DDS's segments live on Linux
ROOM = 2   # segments' worth of free shared memory the profile needs
XML_NAMESPACE = '{http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles}'
# What use_shipped_profile chose: the profile named (None: none) and a line for the log
# (None: the user's choice, nothing to say).
Choice = namedtuple('Choice', 'profile note')


def shipped_profile():
    """Return the path of the packaged profile, or None if it is not installed."""
    for folder in config_directories():
        if (folder / PROFILE).is_file():
            return folder / PROFILE
    return None


def segment_size(profile):
    """Return the shared-memory segment size (bytes) that ``profile`` gives."""
    root = ElementTree.parse(profile).getroot()
    return max(int(element.text) for element in root.iter(f'{XML_NAMESPACE}segment_size'))


def use_shipped_profile(environ=None, working_directory=None, shared_memory=SHARED_MEMORY):
    """Name the shipped profile in ``environ`` unless the user chose one; a :data:`Choice`.

    Call it before ``rclpy.init``. ``environ`` defaults to ``os.environ``, the working
    directory to the process's.
    """
    environ = os.environ if environ is None else environ
    folder = Path.cwd() if working_directory is None else Path(working_directory)
    if any(name in environ for name in USER_VARIABLES):
        return Choice(None, None)
    if any((folder / name).is_file() for name in USER_FILES):
        return Choice(None, None)
    if (environ.get('RMW_IMPLEMENTATION') or FAST_DDS_RMW[0]) not in FAST_DDS_RMW:
        return Choice(None, None)
    profile = shipped_profile()
    if profile is None:
        return Choice(None, None)
    needed = ROOM * segment_size(profile)
    if Path(shared_memory).is_dir() and shutil.disk_usage(shared_memory).free < needed:
        free = shutil.disk_usage(shared_memory).free
        return Choice(None, f'Fast DDS profile {profile} not used: {shared_memory} has '
                            f'{free / 2 ** 20:.0f} MB free, it needs {needed / 2 ** 20:.0f} '
                            f'(service answers may then wait seconds while large messages '
                            f'are sent; docker run --shm-size gives more)')
    environ[VARIABLE] = str(profile)
    return Choice(profile, f'Fast DDS profile: {profile} ({VARIABLE} names yours)')
