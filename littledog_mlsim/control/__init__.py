"""Closed-loop control of a simulated LittleDog (no rclpy): a streaming trot gait whose
velocity, yaw rate, step height and period may change every 10 ms step, command schedules with
smooth blends between move types, and controllers that read odometry and joint states."""
