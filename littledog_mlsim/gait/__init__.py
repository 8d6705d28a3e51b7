"""Open-loop trot gait generator and analytic leg inverse kinematics."""
