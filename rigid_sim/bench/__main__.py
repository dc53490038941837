# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``python -m rigid_sim.bench``: the same as the ``rigid_sim_bench`` console script."""
import sys

from rigid_sim.bench.cli import main

sys.exit(main())
