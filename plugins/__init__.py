"""Mitsuba plugins of mitsonar (installed as ``mitsonar.plugins``)."""
