"""Seeded varied rooms (``varied_room(seed)``), for testing methods beyond the shipped scenes.

* ``room``: :func:`~mitsonar.scene.varied.room.varied_room` and writing N of them.
* ``plan``: the plan (rectangle or L), its walls, free floor and the robot's loop.
* ``looks``: wall, floor and ceiling colours, textures and materials; lights.
* ``glass``: windows in the outer walls and free-standing glass partitions, the sun.
* ``furniture``: furniture placed without overlaps, clear of the robot's loop.
"""
