# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench``: the benchmark console script (entry point ``cli:main``)."""
import argparse
import sys

from rigid_sim.bench import (MissingPackage, accuracy, contact, estimates, flood, goals,
                             imu_cost, inertia_cost, node_rate, stability, startup,
                             throughput)

SUBCOMMANDS = (
    ('accuracy', accuracy, 'integrator error against CPU time, with exact oracles'),
    ('contact', contact, 'contact scenes against closed forms and MuJoCo, in one run'),
    ('estimates', estimates, 'error estimates of every integrator against the true local error'),
    ('flood', flood, 'a flood of wrench messages: real-time factor with and without'),
    ('goals', goals, 'goals solved for the twist or wrench that reaches them, against scipy'),
    ('imu', imu_cost, 'the cost of an IMU per published reading, and of none'),
    ('inertia', inertia_cost, 'inertia-tensor estimates: error against time'),
    ('node', node_rate, 'the node at scale: real-time factor and tick time against N'),
    ('stability', stability, 'the hard cases through every integrator'),
    ('startup', startup, 'process start to the first step, with and without compiled kernels'),
    ('throughput', throughput, 'CPU time per body-step against the number of bodies'),
)


def build_parser():
    """Return the argument parser of every subcommand."""
    parser = argparse.ArgumentParser(
        prog='rigid_sim_bench', description='rigid_sim benchmarks: what accuracy costs in time.')
    commands = parser.add_subparsers(dest='command', required=True)
    for name, module, summary in SUBCOMMANDS:
        sub = commands.add_parser(name, help=summary, description=summary)
        module.add_arguments(sub)
        sub.set_defaults(run=module.main)
    return parser


def main(argv=None):
    """Parse ``argv`` (default ``sys.argv[1:]``) and run the subcommand; exit status."""
    parser = build_parser()
    args = parser.parse_args(sys.argv[1:] if argv is None else list(argv))
    try:
        args.run(args)
    except MissingPackage as error:
        parser.exit(2, f'rigid_sim_bench {args.command}: error: {error}\n')
    return 0
