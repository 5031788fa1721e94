"""Readers and writers: runs files, encoder logs (optiodom folders, the generic CSV, ROS bags),
poses files, parameter exports, atomic file writes."""

__all__: list[str] = []
