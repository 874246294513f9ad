"""Surfel scanning reconstruction (paper section III-D); split into modules in the next commit."""

from mitsonar.recon.surfels.planes import *  # noqa: F401,F403
