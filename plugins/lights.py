"""Mitsuba emitter plugins ``key_light`` and ``ambient_light``: the lighting of the paper's Gazebo
worlds (a directional sun plus a constant ambient term, rendered without interreflection) in a
room that, unlike a Gazebo world, has a ceiling.

``key_light`` is parallel light (``direction`` of travel, ``irradiance`` [W/m^2] normal to the
rays, linear RGB) whose shadow rays stop where they leave the room's boxes (``rooms``: "x0 x1 y0 y1
z0 z1; ..." [m], the rooms' interiors): the ceiling, the outer walls and the walls between rooms
cast no shadows of it, what stands inside a room does (no rooms: nothing does). So each flat
surface of the building is lit evenly, by the cosine of its angle to the light, as a Gazebo world
without a roof::

    <emitter type="key_light" id="key">
        <vector name="direction" value="-0.5, -0.29, -0.82"/>
        <rgb name="irradiance" value="6, 6, 6"/>
        <string name="rooms" value="-4.5 3 -3 3 0 2.6"/>
    </emitter>

``ambient_light`` (``irradiance`` [W/m^2], linear RGB) lights every surface point as a parallel
light along its own normal would, never shadowed: a diffuse surface of albedo rho shows rho E / pi
whatever its orientation, the ambient term of a rasteriser. Both are delta lights (no surface
shows them; only next-event estimation reaches them).
"""

from __future__ import annotations

import drjit as dr
import mitsuba as mi

from mitsonar.jit import variant

if mi.variant() is None:  # the classes below derive from a variant-specific mi.Emitter
    mi.set_variant(variant())

#: Length of a shadow ray from a point outside every room box [m] (nothing shadows it).
_OUTSIDE = 1e-4


def _colour(props: mi.Properties, name: str, emitter: str) -> mi.Color3f:
    """An ``<rgb>`` property as a colour; a clear error naming the emitter when absent."""
    if name not in props:
        raise ValueError(f"{emitter} emitter '{props.id()}': give its '{name}' as <rgb>")
    value = props[name]
    return mi.Color3f(float(value[0]), float(value[1]), float(value[2]))


def parse_rooms(text: str, emitter_id: str = "") -> list[tuple[float, ...]]:
    """Room boxes (x0, x1, y0, y1, z0, z1) [m] from "x0 x1 y0 y1 z0 z1; ..." (empty: none, so
    nothing casts shadows of the light)."""
    boxes = []
    for part in text.split(";") if text.strip() else []:
        values = part.split()
        try:
            box = tuple(float(v) for v in values)
        except ValueError:
            box = ()
        if len(box) != 6 or box[0] >= box[1] or box[2] >= box[3] or box[4] >= box[5]:
            raise ValueError(f"key_light emitter '{emitter_id}': rooms must be 'x0 x1 y0 y1 z0 z1"
                             f"; ...' with x0 < x1, y0 < y1, z0 < z1 [m], got {part.strip()!r}")
        boxes.append(box)
    return boxes


class _DeltaLight(mi.Emitter):
    """What the two lights share: a delta direction, no surface emission, no particle tracing."""

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        self.m_flags = mi.EmitterFlags.DeltaDirection | mi.EmitterFlags.Infinite

    def _sample(self, it, toward, dist, value):
        """The direction sample towards the light along unit ``toward``, the shadow ray ending
        after ``dist`` [m]."""
        ds = dr.zeros(mi.DirectionSample3f)
        ds.p = it.p + toward * dist
        ds.n = -toward
        ds.time = it.time
        ds.pdf = 1.0
        ds.delta = True
        ds.emitter = mi.EmitterPtr(self)
        ds.d = toward
        ds.dist = dist
        return ds, mi.Spectrum(value)

    def pdf_direction(self, it, ds, active=True):
        return mi.Float(0.0)

    def eval(self, si, active=True):
        return mi.Spectrum(0.0)

    def traverse(self, callback):
        pass


class KeyLight(_DeltaLight):
    """Parallel light whose shadow rays end where they leave the room boxes (module docstring)."""

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        self.irradiance = _colour(props, "irradiance", "key_light")
        direction = dr.normalize(mi.ScalarVector3f(props["direction"]))
        if not direction[2] < 0:
            raise ValueError(f"key_light emitter '{props.id()}': the light must travel "
                             f"downwards (direction z < 0), got {props['direction']}")
        self.toward = -direction
        self.rooms = parse_rooms(str(props["rooms"]), props.id())

    def sample_direction(self, it, sample, active=True):
        toward = mi.Vector3f(self.toward)
        inverse = dr.rcp(toward)
        dist = mi.Float(_OUTSIDE)
        for box in self.rooms:  # a few rooms: the kernel is built once
            lo = mi.Point3f(box[0], box[2], box[4])
            hi = mi.Point3f(box[1], box[3], box[5])
            inside = dr.all((it.p >= lo - 1e-6) & (it.p <= hi + 1e-6))
            t0, t1 = (lo - it.p) * inverse, (hi - it.p) * inverse
            far = dr.maximum(t0, t1)
            leave = dr.minimum(dr.minimum(far.x, far.y), far.z)
            dist = dr.select(inside, dr.maximum(dist, leave), dist)
        return self._sample(it, toward, dist, self.irradiance)

    def eval_direction(self, it, ds, active=True):
        return mi.Spectrum(self.irradiance)

    def to_string(self):
        return f"KeyLight[toward={self.toward}, irradiance={self.irradiance}]"


class AmbientLight(_DeltaLight):
    """Unshadowed light along each point's own normal (module docstring)."""

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        self.irradiance = _colour(props, "irradiance", "ambient_light")

    def sample_direction(self, it, sample, active=True):
        return self._sample(it, it.n, mi.Float(_OUTSIDE), self.irradiance)

    def eval_direction(self, it, ds, active=True):
        return mi.Spectrum(self.irradiance)

    def to_string(self):
        return f"AmbientLight[irradiance={self.irradiance}]"


def register() -> None:
    """Register ``key_light`` and ``ambient_light`` with Mitsuba (the variant must be set)."""
    mi.register_emitter("key_light", lambda props: KeyLight(props))
    mi.register_emitter("ambient_light", lambda props: AmbientLight(props))
