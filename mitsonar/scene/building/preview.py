"""PNG previews of a written scene, rendered with Mitsuba in the scene's look
(:func:`~mitsonar.scene.building.lights.direct_light_integrator`, else its own integrator)."""

from __future__ import annotations

from pathlib import Path

from mitsonar.scene.building.lights import direct_light_integrator
from mitsonar.scene.loading import mitsuba


def render_preview(scene_xml, png, view: str = "camera", width: int = 320, height: int = 240,
                   spp: int = 16, overview=None) -> None:
    """Render a PNG of ``scene_xml`` in its look from the camera placeholder (``view='camera'``)
    or from ``overview`` = (origin, target) with a 75 deg lens."""
    mi = mitsuba()
    scene = mi.load_file(str(scene_xml), optimize=False, width=width, height=height, spp=spp)
    sensor = scene.sensors()[0]
    if view == "overview":
        origin, target = overview
        sensor = mi.load_dict({
            "type": "perspective", "fov": 75.0, "fov_axis": "x",
            "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=target, up=[0, 0, 1]),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "gaussian"}}})
    direct = direct_light_integrator(scene)
    integrator = scene.integrator() if direct is None else mi.load_dict(direct)
    image = mi.render(scene, sensor=sensor, integrator=integrator, spp=spp, seed=0)
    Path(png).parent.mkdir(parents=True, exist_ok=True)
    mi.util.write_bitmap(str(png), image)
