"""Data on disk: paired camera + echo datasets (atomic writes: :mod:`mitsonar.io`) and MCAP
recordings with ROS 2 messages."""
