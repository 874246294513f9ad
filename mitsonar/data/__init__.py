"""Data on disk: paired camera + echo datasets (atomic writes: :mod:`mitsonar.io`)."""
