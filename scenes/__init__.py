"""Shipped scenes (installed as ``mitsonar.scenes``) and the generator that writes them."""
