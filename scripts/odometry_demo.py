"""Interim main job: the odometry node, started like `ros2 run`, fed a generated /odom stream."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import rclpy
from nav_msgs.msg import Odometry
from rclpy.node import Node
from transforms3d.euler import euler2quat

DT = 0.05


def main() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE")}
    executable = Path(sys.prefix) / "lib" / "amr_turtlebot3" / "odometry_node"
    node_process = subprocess.Popen([str(executable), "--ros-args", "-p", "autostart:=true"], env=env)
    rclpy.init()
    node = Node("odom_stream")
    publisher = node.create_publisher(Odometry, "odom", 10)
    received: list[Odometry] = []
    node.create_subscription(Odometry, "odometry", received.append, 10)
    try:
        deadline = time.monotonic() + 20.0
        while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        v, w = 0.15, 0.5  # a circle of 0.3 m radius
        for k in range(60):
            t = k * DT
            message = Odometry()
            message.header.stamp.sec, message.header.stamp.nanosec = int(t), int((t % 1) * 1e9)
            message.pose.pose.position.x = v / w * math.sin(w * t)
            message.pose.pose.position.y = v / w * (1 - math.cos(w * t))
            q = euler2quat(0.0, 0.0, w * t)
            message.pose.pose.orientation.w, message.pose.pose.orientation.z = q[0], q[3]
            publisher.publish(message)
            rclpy.spin_once(node, timeout_sec=DT)
        for _ in range(20):
            rclpy.spin_once(node, timeout_sec=0.05)
        for message in received[::10]:
            twist = message.twist.twist
            print(f"t={message.header.stamp.sec + message.header.stamp.nanosec * 1e-9:5.2f} s  "
                  f"v={twist.linear.x:.4f} m/s  w={twist.angular.z:.4f} rad/s")
        print(f"odometry_node derived {len(received)} twists from 60 poses (commanded v={v}, w={w})")
    finally:
        node.destroy_node()
        rclpy.shutdown()
        node_process.send_signal(signal.SIGINT)
        node_process.wait(timeout=10)


if __name__ == "__main__":
    main()
