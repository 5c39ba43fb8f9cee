"""Matplotlib figures of planner results; matplotlib is imported lazily inside functions.
"""
