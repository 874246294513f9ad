"""Data on disk: paired camera + echo datasets and atomic file output."""
