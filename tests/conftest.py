"""Fixtures shared by the tests (helpers that are not fixtures live in ``helpers.py``)."""

from __future__ import annotations

import pytest

from mitsonar.scene.xml import write_scene


@pytest.fixture
def scene_file(tmp_path):
    """Factory: scene_file(name, *xml_parts) -> path of a scene written in tmp_path."""
    def make(name, *parts):
        return write_scene(tmp_path / f"{name}.xml", *parts)
    return make
