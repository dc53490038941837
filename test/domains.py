# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The ROS domain each test process takes (conftest.py sets it before any test starts)."""

DOMAINS = 101   # ROS_DOMAIN_ID 1..101 are valid on Linux with the default ports


def own_domain(environ, pid):
    """Return this test process's ROS_DOMAIN_ID.

    The user's, else one from the pid. A pytest-xdist worker 'gwK' (the README's command
    runs two) takes the one its controller chose plus K: the workers' node processes, all
    named rigid_sim, must not meet. A domain in 1..DOMAINS stays there (counted round);
    one the user set above it is theirs.
    """
    chosen = environ.get('ROS_DOMAIN_ID', '').strip()
    domain = int(chosen) if chosen else 1 + pid % DOMAINS
    worker = environ.get('PYTEST_XDIST_WORKER', '')
    if worker.startswith('gw'):
        shifted = domain + int(worker[2:])
        domain = 1 + (shifted - 1) % DOMAINS if domain <= DOMAINS else shifted
    return domain
