"""Simulator validation of planner predictions (pymunk and MuJoCo backends)."""
