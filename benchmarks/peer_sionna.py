"""Peer line of the benchmark: Sionna RT computing the same element-pair channel as mitsonar.

Sionna RT (NVIDIA's radio ray tracer on the same Mitsuba 3.9.1 / Dr.Jit 1.5.0; the optional
``bench`` extra) solves the channel between mitsonar's 5 x 5 transmit and 5 x 5 receive arrays
(element positions of :class:`~mitsonar.physics.array.ArrayGeometry`, placed by the sensor pose)
in the benchmark's scene: one bounce, specular + diffuse (no line of sight, refraction or
diffraction), at the radio carrier whose wavelength equals that of the sonar's sound
(c_sound / f_pulse = 8.6 mm: 35 GHz). It shoots ``rays`` rays per source over the whole sphere,
once from each array centre with its synthetic array (``synthetic_array=True``: per-element
phases applied to the centre's paths) and once from each of the 25 elements (exact). The figure
is element-pair path coefficients (complex gain and delay of one path between one transmit and
one receive element) per second; mitsonar's is the same count for its trace and narrow-band
merge of a batch of beams (H hits x 25 x 25 pairs per beam, each beam a 20 deg cone). The jobs
differ in what they keep: Sionna stores every element pair's coefficient, mitsonar's merge kernel
forms each pair's gain and delay and sums them over the transmit elements at once (H x 25 merged
paths out), which is what its synthesis needs.

The scene is the scene file itself (:func:`radio_scene_xml`): every acoustic preset becomes the
ITU radio material of :data:`ITU_TYPE` with the preset's diffuse energy fraction s as Sionna's
scattering coefficient sqrt(s); shapes Sionna cannot trace (it takes triangle meshes only:
disks, cylinders, spheres) are left out and counted. The radio constants do not change the
work, only the gains.

Sionna needs Mitsuba's ``llvm_ad_mono_polarized`` variant and mitsonar ``llvm_ad_rgb``; a process
holds one variant at a time, so Sionna runs in a process of its own (this file as a script:
a job as JSON on stdin, the timings as JSON on stdout), on the CPU as mitsonar does.
"""

from __future__ import annotations

import importlib.metadata
import json
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np

#: ITU material type standing in for each acoustic preset (absorbers: the porous ITU types).
ITU_TYPE = {"concrete": "concrete", "drywall": "plasterboard", "plaster": "plasterboard",
            "glass": "glass", "wood": "wood", "metal": "metal", "fabric": "carpet_tile",
            "foam": "ceiling_board", "air": "vacuum"}
#: Mitsuba shape types that load as triangle meshes (the only ones Sionna RT traces).
MESH_SHAPES = {"rectangle", "cube", "obj", "ply", "serialized"}
#: Rays per source: the full run and ``--quick``.
RAYS, QUICK_RAYS = 100_000, 10_000
#: The variant Sionna runs in (CPU, like mitsonar's).
SIONNA_VARIANT = "llvm_ad_mono_polarized"


def timed(fn, repeat: int):
    """(seconds of the first call, mean seconds of ``repeat`` calls after a second one, last
    output). Two calls warm up: Sionna's second call compiles nothing new yet still runs several
    times slower than the later ones (measured: 2.7 s, then 0.45 s for 1e4 exact rays)."""
    t0 = time.perf_counter()
    out = fn()
    cold = time.perf_counter() - t0
    fn()
    t0 = time.perf_counter()
    for _ in range(repeat):
        out = fn()
    return cold, (time.perf_counter() - t0) / repeat, out


def radio_scene_xml(scene_path: str) -> tuple[str, int]:
    """The shapes of a mitsonar scene file with radio materials, as Sionna scene XML, and the
    number of shapes left out (not triangle meshes)."""
    from mitsonar.physics.materials import DEFAULT_MATERIAL_NAME, preset

    def radio(bsdf):
        found = bsdf.find("string[@name='preset']") if bsdf.get("type") == "acoustic" else None
        name = DEFAULT_MATERIAL_NAME if found is None else found.get("value")
        out = ET.Element("bsdf", type="itu-radio-material", id=bsdf.get("id") or "")
        ET.SubElement(out, "string", name="type", value=ITU_TYPE[name])
        ET.SubElement(out, "float", name="scattering_coefficient",
                      value=repr(float(np.sqrt(preset(name).scattering))))
        return out

    root = ET.parse(scene_path).getroot()
    scene = ET.Element("scene", version=root.get("version", "3.0.0"))
    scene.extend(radio(b) for b in root.findall("bsdf"))
    shapes = root.findall("shape")
    for shape in shapes:
        if shape.get("type") in MESH_SHAPES:
            for i, bsdf in enumerate(shape.findall("bsdf")):
                shape.remove(bsdf)
                shape.insert(i, radio(bsdf))
            scene.append(shape)
    return ET.tostring(scene, encoding="unicode"), len(shapes) - len(scene.findall("shape"))


def sionna_channel(job: dict) -> dict:
    """Time Sionna RT on ``job`` (keys: scene, tx and rx (N, 3) element positions in the world
    frame [m], boresight (3,) the arrays' facing direction, wavelength [m], rays per source,
    repeat): per array mode, cold and warm seconds and element-pair path coefficients."""
    from mitsonar._native import configure_llvm

    configure_llvm()  # the LLVM that Dr.Jit needs here, as for mitsonar
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(SIONNA_VARIANT)
    import sionna.rt as rt
    from scipy.constants import speed_of_light
    from scipy.spatial.transform import Rotation
    from sionna.rt.antenna_pattern import antenna_pattern_registry

    xml, left_out = radio_scene_xml(job["scene"])
    scene = rt.load_scene_from_string(xml)
    scene.frequency = speed_of_light / job["wavelength"]
    b = np.asarray(job["boresight"], dtype=float)
    # Sionna's (yaw, pitch, roll) turns the pattern's boresight (+x) onto b; element positions
    # are given in that rotated frame.
    orientation = [float(np.arctan2(b[1], b[0])), float(np.arcsin(-b[2])), 0.0]
    rotation = Rotation.from_euler("ZYX", orientation).as_matrix()
    pattern = antenna_pattern_registry.get("tr38901")(polarization="V")
    arrays = []
    for name, device in (("tx", rt.Transmitter), ("rx", rt.Receiver)):
        points = np.asarray(job[name], dtype=float)
        centre = points.mean(axis=0)
        local = (points - centre) @ rotation / job["wavelength"]
        arrays.append(rt.AntennaArray(pattern, mi.Point3f(*local.T)))
        scene.add(device(name, position=[float(v) for v in centre], orientation=orientation))
    scene.tx_array, scene.rx_array = arrays
    solver = rt.PathSolver()

    def solve(synthetic: bool):
        paths = solver(scene, max_depth=1, samples_per_src=int(job["rays"]),
                       synthetic_array=synthetic, los=False, specular_reflection=True,
                       diffuse_reflection=True, refraction=False)
        dr.eval(paths.a, paths.tau, paths.valid)
        return paths

    result = dict(version=rt.__version__, frequency=float(scene.frequency[0]),
                  left_out=left_out, rays=int(job["rays"]))
    for mode, synthetic in (("synthetic", True), ("exact", False)):
        cold, warm, paths = timed(lambda: solve(synthetic), job["repeat"])
        valid = np.asarray(paths.valid)
        # a: (rx, rx elements, tx, tx elements, paths); valid per pair, or per device pair
        # with a synthetic array (each valid path then holds every element pair).
        per_valid = int(np.prod(dr.shape(paths.a[0]))) // valid.size
        result[mode] = dict(cold_s=cold, warm_s=warm, paths=int(dr.shape(paths.a[0])[-1]),
                            coefficients=int(valid.sum()) * per_valid)
    return result


def mitsonar_channel(sonar, pose, directions, repeat: int) -> dict:
    """Time mitsonar's trace of the beams ``directions`` (B, 3) from ``pose`` (one batch, as
    scans trace them) and the narrow-band merge of their paths: cold and warm seconds and
    element-pair path coefficients (H x N_tx x N_rx per beam)."""
    k = len(directions)

    def run():
        results = sonar.tracer.trace_many([pose] * k, directions, range(k))
        for result in results:
            sonar.echo_groups(result.paths, sonar.config.pulse)
        return results

    cold, warm, results = timed(run, repeat)
    return dict(cold_s=cold, warm_s=warm,
                coefficients=sum(len(result.paths) for result in results))


def peer_lines(scene_path: str, sonar, pose, directions, quick: bool) -> list:
    """Print the peer lines (coefficients/s of mitsonar and of Sionna RT with a synthetic and an
    exact array, and their ratios); returns [(name, value, ratio)] for the benchmark's
    finiteness check, empty when the ``bench`` extra is not installed."""
    try:
        version = importlib.metadata.version("sionna-rt")
    except importlib.metadata.PackageNotFoundError:
        print("peer: Sionna RT skipped (the `bench` extra is not installed: "
              "pip install -e '.[bench]')")
        return []
    repeat = 1 if quick else 3
    ours = mitsonar_channel(sonar, pose, directions, repeat)
    cfg = sonar.config
    job = dict(scene=str(scene_path), tx=pose.transform_points(cfg.geometry.tx_positions).tolist(),
               rx=pose.transform_points(cfg.geometry.rx_positions).tolist(),
               boresight=pose.transform_vectors([0.0, 0.0, 1.0]).tolist(),
               wavelength=cfg.medium.speed_of_sound / cfg.pulse.frequency,
               rays=QUICK_RAYS if quick else RAYS, repeat=repeat)
    out = subprocess.run([sys.executable, __file__], input=json.dumps(job), capture_output=True,
                         text=True)
    if out.returncode:
        raise RuntimeError(f"the Sionna RT peer failed:\n{out.stderr[-3000:]}")
    peer = json.loads(out.stdout.strip().splitlines()[-1])
    left = f" ({peer['left_out']} non-mesh shapes left out)" if peer["left_out"] else ""
    print(f"peer: Sionna RT {version}, the same scene{left}, {len(job['tx'])} x "
          f"{len(job['rx'])} element pairs, 1 bounce, specular + diffuse, "
          f"{peer['frequency'] / 1e9:.2f} GHz (wavelength {job['wavelength'] * 1e3:.2f} mm), "
          f"{peer['rays']} rays per source; warm times, first call in brackets")
    text, rate = _row("mitsonar trace + merge", ours, f"{len(directions)} beams")
    print(text)
    lines = [("peer: mitsonar coefficients/s", rate, 1.0)]
    for mode in ("synthetic", "exact"):
        text, value = _row(f"Sionna RT, {mode} array", peer[mode], f"{peer[mode]['paths']} paths")
        print(f"{text}; mitsonar / Sionna {rate / value:.3g}")
        lines.append((f"peer: Sionna RT {mode} coefficients/s", value, rate / value))
    return lines


def _row(name: str, timing: dict, what: str) -> tuple[str, float]:
    """A line with the coefficients/s of ``timing`` and its counts, and that rate."""
    rate = timing["coefficients"] / timing["warm_s"]
    return (f"  {name:<32s} {rate:12.4g} coeff/s  ({timing['coefficients']:.3g} coefficients of "
            f"{what} in {timing['warm_s'] * 1e3:.4g} ms [{timing['cold_s'] * 1e3:.4g} ms])"), rate


if __name__ == "__main__":
    print(json.dumps(sionna_channel(json.load(sys.stdin))))
