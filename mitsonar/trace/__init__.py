"""Acoustic ray tracing: scene + pose + beam -> surface patches -> echo paths (amplitude and delay
per patch and element pair), with the per (patch, element) factors in one Dr.Jit kernel."""
