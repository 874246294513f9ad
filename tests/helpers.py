"""Helpers shared by the tests: repository paths and common poses (scene XML pieces are in
``mitsonar.scene.xml``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mitsonar

#: The repository's root, and its shipped scenes.
ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"

#: The sensor sits at the world origin looking along +z (world frame = sensor frame).
IDENTITY = mitsonar.Pose.identity()
BROADSIDE = np.array([0.0, 0.0, 1.0])
