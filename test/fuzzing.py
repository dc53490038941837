# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Hypothesis settings shared by the fuzz tests (imported as ``fuzzing``).

Derandomised, so CI runs the same examples every time and a failure reproduces;
``RIGID_SIM_FUZZ_EXAMPLES=N`` runs N fresh random examples per test instead, for a longer
hunt on a developer's machine.
"""
import os

from hypothesis import HealthCheck, settings

HUNT = os.environ.get('RIGID_SIM_FUZZ_EXAMPLES')


def fuzz(examples):
    """Return the settings of a fuzz test of ``examples`` examples in CI (no deadline)."""
    return settings(max_examples=int(HUNT) if HUNT else examples, deadline=None,
                    derandomize=not HUNT, database=None,
                    # One node serves every example of a test: that it survives them all is
                    # the point, so the fixture is meant to outlive the example.
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])
