"""Mitsuba BSDF plugin ``acoustic``: acoustic properties beside a nested optical BSDF.

One scene file serves the camera and the sonar: the camera renders the nested BSDF, the sonar
reads the acoustic properties. Scene syntax::

    <bsdf type="acoustic" id="window">
        <string name="preset" value="glass"/>            <!-- optional named preset -->
        <float name="impedance" value="1.4e7"/>          <!-- Z2 [Rayl], or -->
        <float name="absorption" value="0.9"/>           <!-- energy absorption at 40 kHz -->
        <float name="scattering" value="0.02"/>          <!-- diffuse energy fraction -->
        <bsdf type="dielectric"/>                        <!-- what the camera sees -->
    </bsdf>

Explicit values override the preset's. Without a nested BSDF the camera sees a grey diffuse
surface. Invalid values raise ValueError naming the material id.
"""

from __future__ import annotations

import mitsuba as mi

from mitsonar.physics.materials import AcousticMaterial, preset
from mitsonar.jit import variant

if mi.variant() is None:  # the class below derives from a variant-specific mi.BSDF
    mi.set_variant(variant())

PLUGIN_NAME = "acoustic"
_KNOWN = {"preset", "impedance", "absorption", "scattering"}


def material_from_properties(props: mi.Properties) -> AcousticMaterial:
    """Parse and validate the acoustic properties of one ``<bsdf type="acoustic">``."""
    mat_id = props.id() or "<unnamed>"
    unknown = [k for k in props.keys()
               if k not in _KNOWN and props.type(k) != mi.Properties.Type.Object]
    if unknown:
        raise ValueError(f"acoustic material '{mat_id}': unknown properties {unknown}; "
                         f"expected {sorted(_KNOWN)}")
    try:
        base = preset(str(props["preset"])) if "preset" in props else None
    except ValueError as err:
        raise ValueError(f"acoustic material '{mat_id}': {err}") from None
    changes = {k: _number(props, k, mat_id) for k in ("impedance", "absorption", "scattering")
               if k in props}
    if base is None:
        if "impedance" not in changes and "absorption" not in changes:
            raise ValueError(f"acoustic material '{mat_id}': give a 'preset', an 'impedance' "
                             "[Rayl] or an 'absorption' coefficient")
        return AcousticMaterial(mat_id, **changes, source="scene file")
    try:
        return base.with_changes(name=mat_id, **changes)
    except ValueError as err:
        raise ValueError(f"acoustic material '{mat_id}': {err}") from None


def _number(props: mi.Properties, key: str, mat_id: str) -> float:
    """Property ``key`` as a float (a <float>, <integer> or numeric <string>)."""
    try:
        return float(props[key])
    except (TypeError, ValueError):
        raise ValueError(f"acoustic material '{mat_id}': {key} must be a number, "
                         f"got {props[key]!r}") from None


class AcousticBSDF(mi.BSDF):
    """Optical behaviour of the nested BSDF plus an :class:`AcousticMaterial`."""

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        try:
            self.acoustic = material_from_properties(props)
        except ValueError as err:
            raise ValueError(str(err).replace("'<unnamed>'", "(no id)")) from None
        nested = [props[k] for k in props.keys() if isinstance(props[k], mi.BSDF)]
        if len(nested) > 1:
            raise ValueError(f"acoustic material '{self.acoustic.name}': more than one nested BSDF")
        self.nested = nested[0] if nested else mi.load_dict({"type": "diffuse"})
        self.m_flags = self.nested.flags()
        self.m_components = [self.nested.flags(i) for i in range(self.nested.component_count())]

    def sample(self, ctx, si, sample1, sample2, active=True):
        return self.nested.sample(ctx, si, sample1, sample2, active)

    def eval(self, ctx, si, wo, active=True):
        return self.nested.eval(ctx, si, wo, active)

    def pdf(self, ctx, si, wo, active=True):
        return self.nested.pdf(ctx, si, wo, active)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.nested.eval_pdf(ctx, si, wo, active)

    def eval_null_transmission(self, si, active=True):
        return self.nested.eval_null_transmission(si, active)

    def eval_diffuse_reflectance(self, si, active=True):
        return self.nested.eval_diffuse_reflectance(si, active)

    def traverse(self, callback):
        self.nested.traverse(callback)

    def to_string(self):
        return f"AcousticBSDF[{self.acoustic}, nested={self.nested}]"


def register() -> None:
    """Register ``acoustic`` with Mitsuba (the variant must be set)."""
    mi.register_bsdf(PLUGIN_NAME, lambda props: AcousticBSDF(props))
