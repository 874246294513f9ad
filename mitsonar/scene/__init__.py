"""Mitsuba scenes with acoustic materials.

* ``loading``: one ``mi.Scene`` serves camera, sonar and ground truth; the acoustic BSDF plugin's
  registration; invalid materials reported in one line naming the file and the material.
* ``mesh``: the ground truth, every shape as one triangle mesh in the world frame [m].
* ``xml``: small XML pieces (materials, rectangles, spheres, whole files) for scenes written in
  code, by tests and experiments.
* ``building``: the building blocks of whole rooms (shell with openings, windows, lights,
  furniture, materials, textures) and the writer of scene.xml + ground_truth.json.
* ``shipped``: the four shipped scenes, one short module each (``scenes/generate.py`` writes them).
* ``varied``: furnished rooms drawn from a seed (plan, looks, glass, furniture), to try methods
  beyond the shipped scenes.
"""
