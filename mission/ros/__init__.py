"""The ROS 2 side of the application: message conversions, the ROS world adapter and the node.

Only :mod:`mission.ros.ros_adapter` and :mod:`mission.ros.node` import rclpy. The conversions, the sensor
cache and the message factories also work on messages decoded by ``rosbags`` (replay and recording
without a ROS install), so importing this package never requires ROS.
"""
