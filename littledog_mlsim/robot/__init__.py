"""LittleDog in pybullet: URDF, servo and sensor models, effect plug-ins."""
