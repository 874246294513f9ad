"""Mitsuba scenes with acoustic materials: loading (one ``mi.Scene`` serves camera, sonar and
ground truth), the acoustic BSDF plugin's registration, triangle meshes of the ground truth, and
the XML building blocks that scenes and tests are written from."""
