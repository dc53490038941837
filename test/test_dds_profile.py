# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's Fast DDS profile: used when the user names none, never over the user's.

What it buys (no service answer lost for seconds while the node sends ~4 MB a tick) is
timed by ``rigid_sim_bench node --control-works rviz`` (docs/performance.md); here only the
configuration is checked: which profile the process gets, and that Fast DDS reads the
shipped one (its shared-memory segment is the size the profile gives).
"""
import os
from pathlib import Path
import shutil
import subprocess
import sys

import pytest

import processes
from rigid_sim import dds_profile

NAMESPACE = dds_profile.XML_NAMESPACE
STARTING_NODE = 'from rigid_sim import main; main.executable()'
DEFAULT_SEGMENT = 512 * 1024   # bytes: Fast DDS's shared-memory segment when unconfigured
SEGMENT = dds_profile.segment_size(dds_profile.shipped_profile())


def test_the_profile_is_named_when_the_user_names_none(tmp_path):
    environ = {'ROS_DOMAIN_ID': '7'}
    profile, note = dds_profile.use_shipped_profile(environ, tmp_path, tmp_path)
    assert profile is not None and profile.is_file() and str(profile) in note
    assert environ == {'ROS_DOMAIN_ID': '7', 'FASTRTPS_DEFAULT_PROFILES_FILE': str(profile)}
    assert dds_profile.use_shipped_profile({'RMW_IMPLEMENTATION': ''}, tmp_path,
                                           tmp_path).profile == profile


@pytest.mark.parametrize('chosen', [
    {'FASTRTPS_DEFAULT_PROFILES_FILE': '/home/me/dds.xml'},
    {'FASTRTPS_DEFAULT_PROFILES_FILE': ''},   # set empty: the user wants none
    {'FASTDDS_DEFAULT_PROFILES_FILE': '/home/me/dds.xml'},
    {'RMW_IMPLEMENTATION': 'rmw_cyclonedds_cpp'},   # no Fast DDS to configure
])
def test_a_users_choice_is_left_as_it_is(tmp_path, chosen):
    environ = dict(chosen)
    assert dds_profile.use_shipped_profile(environ, tmp_path, tmp_path) == (None, None)
    assert environ == chosen


@pytest.mark.parametrize('name', ['DEFAULT_FASTRTPS_PROFILES.xml',
                                  'DEFAULT_FASTDDS_PROFILES.xml'])
def test_a_profile_in_the_working_directory_is_the_users_choice(tmp_path, name):
    (tmp_path / name).write_text('<profiles/>')
    environ = {}
    assert dds_profile.use_shipped_profile(environ, tmp_path, tmp_path) == (None, None)
    assert environ == {}


def test_too_little_shared_memory_for_the_segment_leaves_fast_dds_defaults(tmp_path,
                                                                           monkeypatch):
    """Docker's 64 MB /dev/shm: Fast DDS would write past it making the segment; said why."""
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(shutil, 'disk_usage',
                        lambda path: usage._replace(free=64 * 2 ** 20))
    environ = {}
    profile, note = dds_profile.use_shipped_profile(environ, tmp_path, tmp_path)
    assert profile is None and environ == {}
    assert 'not used' in note and '64 MB free' in note


def test_the_segment_holds_several_ticks_of_every_bodys_messages():
    """64 MiB: ~16 ticks of ~/markers, ~/poses and /tf of 10 000 boxes (~4 MB a tick)."""
    assert SEGMENT >= 16 * 4_000_000 > 100 * DEFAULT_SEGMENT


def _shared_memory_segments(pid):
    """Return the sizes (bytes) of the Fast DDS segments mapped by process ``pid``."""
    sizes = []
    for line in Path(f'/proc/{pid}/maps').read_text().splitlines():
        fields = line.split()
        if len(fields) == 6 and Path(fields[5]).name.startswith('fastrtps_') and \
                'port' not in fields[5] and not fields[5].endswith('_el'):
            start, end = (int(address, 16) for address in fields[0].split('-'))
            sizes.append(end - start)
    return sizes


def _started_node_segments(tmp_path, **chosen):
    """Start the executable on the default scene; its segments' sizes once it simulates."""
    environment = dict(os.environ, ROS_LOG_DIR=str(tmp_path))
    for name in dds_profile.USER_VARIABLES:   # this run's own choice, if any, is not the test's
        environment.pop(name, None)
    environment.update(chosen)
    node = processes.start([sys.executable, '-c', STARTING_NODE], cwd=tmp_path,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           env=environment, text=True)
    try:
        lines = []
        for line in node.stdout:   # rclpy.init made the participant before this line
            lines.append(line)
            if 'simulating' in line:
                break
        return _shared_memory_segments(node.pid), ''.join(lines)
    finally:
        processes.end(node)


def test_the_executable_sends_through_the_profiles_segment(tmp_path):
    """Fast DDS read the shipped file: the node maps a segment of the size it gives.

    Where /dev/shm lacks the room (a container's 64 MB), the node says it left the profile
    out and maps only Fast DDS's default segments: checked instead, never skipped.
    """
    room = shutil.disk_usage(dds_profile.SHARED_MEMORY).free >= dds_profile.ROOM * SEGMENT
    sizes, output = _started_node_segments(tmp_path)
    if room:
        assert 'Fast DDS profile:' in output, output
        assert max(sizes) >= SEGMENT, (sizes, output)
    else:
        assert 'not used' in output, output
        assert sizes and max(sizes) < 2 * DEFAULT_SEGMENT, (sizes, output)


def test_the_executable_keeps_the_users_profile(tmp_path):
    """A user's (empty) profile file: Fast DDS's default segments only, no log line."""
    users = tmp_path / 'mine.xml'
    users.write_text(f'<profiles xmlns="{NAMESPACE[1:-1]}"/>')
    sizes, output = _started_node_segments(tmp_path, FASTRTPS_DEFAULT_PROFILES_FILE=str(users))
    assert 'Fast DDS profile:' not in output, output
    assert sizes and max(sizes) < 2 * DEFAULT_SEGMENT, (sizes, output)
