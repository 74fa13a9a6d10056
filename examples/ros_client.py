"""Talk to a running ``forte ros`` node: wait for its plan, send a payload mass, print the answer.

    forte ros examples/tasks/lift.yaml &          # the node (in another terminal, or in the background)
    python examples/ros_client.py --mass 0.35     # this client

Prints the node's first status, then the status and the timing of the re-plan for ``--mass``;
exits 1 when the node does not answer within ``--timeout`` seconds. Needs the ``ros`` extra.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64, String
from trajectory_msgs.msg import JointTrajectory


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mass", type=float, required=True, help="payload mass to send (kg)")
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds to wait for each answer")
    args = parser.parse_args()
    rclpy.init()
    node = rclpy.create_node("forte_example_client")
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    statuses: list[dict] = []
    trajectories: list[tuple[float, JointTrajectory]] = []
    node.create_subscription(String, "/forte/status", lambda m: statuses.append(json.loads(m.data)), latched)
    node.create_subscription(JointTrajectory, "/forte/joint_trajectory",
                             lambda m: trajectories.append((time.perf_counter(), m)), latched)
    publisher = node.create_publisher(Float64, "/forte/payload_mass", 10)

    def wait(condition) -> bool:
        deadline = time.monotonic() + args.timeout
        while time.monotonic() < deadline and not condition():
            rclpy.spin_once(node, timeout_sec=0.05)
        return condition()

    try:
        if not wait(lambda: statuses and trajectories):
            print(f"no plan from forte ros within {args.timeout:g} s", file=sys.stderr)
            return 1
        print("first plan:", json.dumps(statuses[-1]))
        # the latched plan can arrive before discovery has matched our publisher with the node's
        # subscription; a message published before that match is lost (volatile topic)
        if not wait(lambda: publisher.get_subscription_count() > 0):
            print(f"forte ros does not subscribe to /forte/payload_mass within {args.timeout:g} s", file=sys.stderr)
            return 1
        before = len(trajectories)
        sent = time.perf_counter()
        publisher.publish(Float64(data=args.mass))
        if not wait(lambda: any(s.get("seq", 0) >= 1 for s in statuses)):
            print(f"no answer to the mass {args.mass:g} kg within {args.timeout:g} s", file=sys.stderr)
            return 1
        answer = next(s for s in statuses if s.get("seq", 0) >= 1)
        wait(lambda: len(trajectories) > before or not answer.get("solved", False))
        arrived = trajectories[-1][0] if len(trajectories) > before else float("nan")
        print("re-plan:", json.dumps(answer))
        print(f"{len(trajectories[-1][1].points)} waypoints; mass sent -> new trajectory {arrived - sent:.3f} s")
        return 0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
