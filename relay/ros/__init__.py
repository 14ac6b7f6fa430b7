"""What the relay knows of ROS 2 without a ROS install: messages, CDR, TF, Nav2's types, rclpy loading."""
