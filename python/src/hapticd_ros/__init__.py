# SPDX-License-Identifier: Apache-2.0
"""hapticd_ros: hapticd's device as a ROS 2 node (``hapticd-ros``, docs/ros.md), over hapticd_client.

Needs rclpy and the message packages (the distribution's extra ``ros``); ``object_words`` alone needs nothing.
"""
