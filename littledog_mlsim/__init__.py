"""littledog_mlsim: a learned rigid-body simulator of the LittleDog quadruped, served over ROS 2."""

__version__ = "0.1.0"
