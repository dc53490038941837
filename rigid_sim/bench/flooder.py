# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The flooding process of ``rigid_sim_bench flood``: WrenchStamped at a fixed total rate.

``python -m rigid_sim.bench.flooder TOPIC RATE PUBLISHERS``: PUBLISHERS publishers on TOPIC
take turns, RATE messages per second in all, each a valid 1 N push in world axes. A line
``on`` or ``off`` on stdin starts or stops the flood; ``count`` answers with the number of
messages sent so far. It runs in its own process, as a careless client would.
"""
import sys
import threading
import time

import rclpy
from geometry_msgs.msg import WrenchStamped
from rclpy.executors import ExternalShutdownException


def commands(state):
    """Follow the stdin commands into ``state`` until stdin closes."""
    for line in sys.stdin:
        word = line.strip()
        if word in ('on', 'off'):
            state['on'] = word == 'on'
        print(state['sent'], flush=True)
    state['done'] = True


def main(topic, rate, publishers):
    """Publish on ``topic`` at ``rate`` Hz in all from ``publishers`` publishers."""
    rclpy.init()
    try:
        node = rclpy.create_node('rigid_sim_bench_flooder')
        outs = [node.create_publisher(WrenchStamped, topic, 10) for _ in range(publishers)]
        message = WrenchStamped()
        message.header.frame_id = 'world'
        message.wrench.force.x = 1.0
        state = {'on': False, 'sent': 0, 'done': False}
        threading.Thread(target=commands, args=(state,), daemon=True).start()
        due = time.perf_counter()
        while not state['done']:
            if not state['on']:
                time.sleep(0.01)
                due = time.perf_counter()
                continue
            outs[state['sent'] % publishers].publish(message)
            state['sent'] += 1
            due += 1.0 / rate
            pause = due - time.perf_counter()
            if pause > 0:
                time.sleep(pause)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()


if __name__ == '__main__':
    main(sys.argv[1], float(sys.argv[2]), int(sys.argv[3]))
