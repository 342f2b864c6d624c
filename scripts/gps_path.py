#!/usr/bin/env python3
"""Accumulates GPS fixes (geometry_msgs/PointStamped) into a nav_msgs/Path for rviz.

The Victoria Park fixes are in a local metric frame (`gps`: x = longitude, y = latitude metres)
whose origin and heading differ from the SLAM map's (the map starts at the vehicle's first pose).
~alignment_x, ~alignment_y, ~alignment_yaw are the rigid alignment that maps map points into the
gps frame (gps = R(yaw) map + t), i.e. "gps_alignment" of the metrics.json that ekf_slam_offline
writes; the fixes are published in ~frame_id (default map) through its inverse. All zero: the fixes
are shown as they are, unaligned.

Topics: gps (in), ~path (out, latched).
"""
import math

import rospy
from geometry_msgs.msg import PointStamped, PoseStamped
from nav_msgs.msg import Path


def main():
    rospy.init_node("gps_path")
    tx = rospy.get_param("~alignment_x", 0.0)
    ty = rospy.get_param("~alignment_y", 0.0)
    yaw = rospy.get_param("~alignment_yaw", 0.0)
    frame = rospy.get_param("~frame_id", "map")
    c, s = math.cos(yaw), math.sin(yaw)
    path = Path()
    path.header.frame_id = frame
    pub = rospy.Publisher("~path", Path, queue_size=1, latch=True)

    def on_fix(msg):
        if not (math.isfinite(msg.point.x) and math.isfinite(msg.point.y)):
            rospy.logwarn_throttle(10.0, "gps_path: non-finite fix skipped")
            return
        if path.poses and msg.header.stamp < path.poses[-1].header.stamp:
            rospy.logwarn("gps_path: time jumped backwards: path cleared")
            del path.poses[:]
        # map = R(yaw)^T (gps - t)
        dx, dy = msg.point.x - tx, msg.point.y - ty
        pose = PoseStamped()
        pose.header.stamp = msg.header.stamp
        pose.header.frame_id = frame
        pose.pose.position.x = c * dx + s * dy
        pose.pose.position.y = -s * dx + c * dy
        pose.pose.orientation.w = 1.0
        path.poses.append(pose)
        path.header.stamp = msg.header.stamp
        pub.publish(path)

    rospy.Subscriber("gps", PointStamped, on_fix, queue_size=100)
    rospy.spin()


if __name__ == "__main__":
    main()
