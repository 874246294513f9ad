"""Procedural textures: tileable 8-bit sRGB PNGs made from integer-hash value noise (no random
generator: the same bytes on every machine), and the PNG writer they and the sky map use. Each
texture is one repeat of its pattern; a material's ``uv_scale`` sets how often it repeats over a
shape."""

from __future__ import annotations

import struct
import zlib
from typing import Callable

import numpy as np


def _png(rgb: np.ndarray) -> bytes:
    """(height, width, 3) uint8 RGB image as PNG bytes (deterministic: fixed zlib level)."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def _hash01(ix: np.ndarray, iy: np.ndarray, seed: int) -> np.ndarray:
    """Deterministic pseudo-random values in [0, 1) of integer lattice points."""
    m = np.uint64(0xFFFFFFFF)
    h = ((ix.astype(np.uint64) * np.uint64(0x9E3779B1)) ^ (iy.astype(np.uint64) *
         np.uint64(0x85EBCA77)) ^ np.uint64((seed * 0xC2B2AE3D) & 0xFFFFFFFF)) & m
    for mult, shift in ((0x2C1B3C6D, 15), (0x297A2D39, 12), (0x7FEB352D, 15)):
        h ^= h >> np.uint64(shift)
        h = (h * np.uint64(mult)) & m
    h ^= h >> np.uint64(16)
    return h.astype(np.float64) / 2.0 ** 32


def _value_noise(size: tuple[int, int], cells: tuple[int, int], seed: int) -> np.ndarray:
    """(rows, cols) smooth value noise in [0, 1), tileable: ``cells`` = (along cols, along rows)
    lattice cells per repeat."""
    rows, cols = size
    u = (np.arange(cols) + 0.5) / cols * cells[0]
    v = (np.arange(rows) + 0.5) / rows * cells[1]
    iu, iv = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    fu, fv = u - iu, v - iv
    fu, fv = fu * fu * (3 - 2 * fu), fv * fv * (3 - 2 * fv)
    u0, u1 = iu % cells[0], (iu + 1) % cells[0]
    v0, v1 = iv % cells[1], (iv + 1) % cells[1]

    def at(a, b):
        return _hash01(a[None, :], b[:, None], seed)

    top = at(u0, v0) * (1 - fu) + at(u1, v0) * fu
    bottom = at(u0, v1) * (1 - fu) + at(u1, v1) * fu
    return top * (1 - fv)[:, None] + bottom * fv[:, None]


def _fbm(size, cells, seed, octaves=4) -> np.ndarray:
    """Sum of octaves of value noise, normalised to [0, 1]."""
    total, norm = np.zeros(size), 0.0
    for k in range(octaves):
        amp = 0.5 ** k
        total += amp * _value_noise(size, (cells[0] * 2 ** k, cells[1] * 2 ** k), seed + 17 * k)
        norm += amp
    return total / norm


def srgb_png(rgb01: np.ndarray) -> bytes:
    """(height, width, 3) sRGB values (clipped to [0, 1]) as an 8-bit PNG."""
    return _png(np.round(np.clip(rgb01, 0.0, 1.0) * 255).astype(np.uint8))


def wood_png(light=(0.78, 0.60, 0.40), dark=(0.55, 0.36, 0.20), seed=11) -> bytes:
    """Plank of wood, 128 x 128: growth rings and fibres running along v (image columns)."""
    n = 128
    x = (np.arange(n) + 0.5) / n
    warp = _fbm((n, n), (2, 3), seed)
    rings = 0.5 + 0.5 * np.cos(2 * np.pi * (9 * x[None, :] + 2.2 * warp))
    fibre = _value_noise((n, n), (48, 3), seed + 5)
    t = np.clip(0.75 * rings ** 3 + 0.25 * fibre, 0, 1)[..., None]
    return srgb_png(np.asarray(light) * (1 - t) + np.asarray(dark) * t)


def concrete_png() -> bytes:
    """2 m x 2 m slab of a sealed concrete floor, 128 x 128: mottled grey with sparse dark
    specks and a dark saw-cut joint along two edges (a joint grid when repeated)."""
    n = 128
    mottle = _fbm((n, n), (4, 4), 23)
    fine = _value_noise((n, n), (64, 64), 29)
    grey = 0.50 + 0.16 * (mottle - 0.5) + 0.05 * (fine - 0.5)
    speck = _hash01(np.arange(n)[None, :], np.arange(n)[:, None], 31) > 0.985
    grey = np.where(speck, grey - 0.18, grey)
    joint = np.zeros((n, n), bool)
    joint[:1, :] = True
    joint[:, :1] = True
    grey = np.where(joint, 0.25, grey)
    rgb = grey[..., None] * np.array([1.0, 0.98, 0.94])
    return srgb_png(rgb)


def hazard_png() -> bytes:
    """Yellow and black diagonal safety stripes, 64 x 64 (4 stripe pairs per repeat)."""
    n = 64
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    band = ((i + j) // (n // 8)) % 2 == 0
    rgb = np.where(band[..., None], np.array([0.93, 0.74, 0.08]), np.array([0.08, 0.08, 0.08]))
    return srgb_png(rgb)


def carpet_png() -> bytes:
    """1 m x 1 m of carpet tiles, 128 x 128: four 0.5 m tiles, each pile striped and turned a
    quarter from its neighbours (a checkerboard of stripe directions), blue-grey."""
    n = 128
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    turned = ((i // (n // 2)) + (j // (n // 2))) % 2 == 1
    stripes = np.where(turned, np.sin(2 * np.pi * i / 8), np.sin(2 * np.pi * j / 8))
    pile = _value_noise((n, n), (64, 64), 41)
    t = (0.5 + 0.25 * stripes + 0.25 * (pile - 0.5))[..., None]
    rgb = np.array([0.30, 0.34, 0.42]) * (1 - t) + np.array([0.46, 0.50, 0.58]) * t
    seam = (i % (n // 2) == 0) | (j % (n // 2) == 0)
    return srgb_png(np.where(seam[..., None], rgb * 0.8, rgb))


#: Texture file name -> function writing its PNG bytes (``Material.texture`` keys).
TEXTURES: dict[str, Callable[[], bytes]] = {
    "wood_oak.png": wood_png,
    "wood_walnut.png": lambda: wood_png(light=(0.55, 0.37, 0.22), dark=(0.33, 0.19, 0.10),
                                        seed=13),
    "concrete_floor.png": concrete_png,
    "hazard.png": hazard_png,
    "carpet.png": carpet_png,
}
