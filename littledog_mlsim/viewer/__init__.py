"""The browser view of the simulators (``littledog-mlsim view``, ``viewer_node``): docs/viewer.md.

``urdf`` (robot model and forward kinematics) and ``tracks`` (replay data) are plain NumPy;
``scene`` draws with viser; ``live`` subscribes with rclpy.
"""
