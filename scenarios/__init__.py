"""Runnable scenarios: the paper's examples and beyond. ``python -m scenarios list``."""
