"""Shadow lines (the paper's Fig. 8a, a challenging case): a sharp shadow edge across a wall,
which the camera's line detector reports like a crease, and what surfel scanning makes of it
with and without shadow-line removal.

Scene (written on the fly): a room corner, walls x = 2 m and y = 2 m (drywall) on a concrete
floor z = 0, lit by a sun that reaches all three faces (no shadows of their own), plus a lamp
shining along +x that lights only the wall x = 2 (the floor and the wall y = 2 are parallel to
it). A board in the plane x = -2, behind the robot and outside the camera's and the sonar's view,
keeps the lamp off the wall above a line: the shadow edge, horizontal at a height or slanted.
Three robot poses 2.8 m from the crease, yaw 45 deg and +-8 deg ('paper' sonar preset).

Each shadow is mapped twice: with shadow-line removal (the default, a segment with one plane on
both sides is removed with the surfels built on it) and without
(``SurfelSettings(remove_shadows=False)``). Per run:

* detected: poses where a segment lies within 2 px of the shadow edge's image over its length;
  removed: poses where that segment was removed as a shadow line; creases removed: segments on
  the corner's creases removed (mistakes); other lines removed: the rest (e.g. the sun's shadow
  of the board on the floor or a wall, also a shadow line); shadow surfels: registered surfels
  built on the shadow segment;
* planes: plane groups grown in the images (3 is right; a lone surfel whose normal is poorly
  determined is not grown); normal error: the largest angle between a true face's normal and
  its plane's [deg]; corner error: where the three planes meet, from the true corner;
* the map (sampled every 1 cm) scored with :mod:`mitsonar.evaluation.metrics`: accuracy within 2 cm and
  completeness of the faces in view (in line of sight and in the array's field of view of a pose,
  within the sonar's range).

Writes shadow_lines.csv/.md and shadow_lines.png (the middle pose's image with the segments and
the planes grown over it, with and without removal, for each shadow; scores per shadow).

    .venv/bin/python experiments/shadow_lines.py --out out/shadow_lines          # ~3 min
    .venv/bin/python experiments/shadow_lines.py --quick --out out/shadow_lines  # ~1 min
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import mitsonar
from mitsonar.physics.beampattern import in_fov
from mitsonar.io import write_table
from mitsonar.evaluation.metrics import evaluate, sample_surface, visible_from
from mitsonar.plots import _pyplot, save_png
from mitsonar.scene.mesh import scene_mesh
from mitsonar.scene.xml import material_xml, spanned_rectangle_xml
from mitsonar.recon.surfels import SurfelSettings, map_surfels, plane_colours, tone_map

CREASE = np.array([2.0, 2.0, 0.0])  # where the two walls and the floor meet [m]
#: True faces: name -> (unit normal towards the room, offset d of n . x = d [m]).
FACES = {"wall_x": (np.array([-1.0, 0.0, 0.0]), -2.0), "wall_y": (np.array([0.0, -1.0, 0.0]), -2.0),
         "floor": (np.array([0.0, 0.0, 1.0]), 0.0)}
SUN = ('<emitter type="directional"><vector name="direction" x="0.45" y="0.45" z="-0.77"/>'
       '<rgb name="irradiance" value="1"/></emitter>')
LAMP = ('<emitter type="directional"><vector name="direction" x="1" y="0" z="0"/>'
        '<rgb name="irradiance" value="1.5"/></emitter>')
ROBOT_DISTANCE = 2.8  # robot centre to the crease [m]
YAWS = np.radians([37.0, 45.0, 53.0])  # robot headings [rad]
BOARD_TOP = 3.5  # top of the horizontal board [m] (the walls are 3.2 m and 3 m tall)
EDGE_TOLERANCE = 2.0  # a segment this close to the shadow edge's image is on it [pixels]


@dataclass(frozen=True)
class Shadow:
    """The shadow edge on the wall x = 2: through (y = 0, z = ``height`` [m]), rising at
    ``slope`` [rad] towards +y (0: horizontal)."""

    height: float
    slope: float = 0.0

    @property
    def label(self) -> str:
        if self.slope == 0:
            return f"horizontal at {self.height:g} m"
        return f"slanted {np.degrees(self.slope):g} deg through {self.height:g} m"

    def board_xml(self) -> str:
        """The board in the plane x = -2 whose lower edge casts the edge (the lamp shines
        along +x, so the shadow is the board's outline moved along x); it spans y in
        [-4, 2.5] m at its lower edge and reaches above the wall."""
        along = np.array([0.0, np.cos(self.slope), np.sin(self.slope)])
        up = np.array([0.0, -np.sin(self.slope), np.cos(self.slope)])
        half = (3.25 / np.cos(self.slope),
                (BOARD_TOP - self.height) / 2 + 2.0 * abs(np.sin(self.slope)))
        start = np.array([-2.0, -0.75, self.height - 0.75 * np.tan(self.slope)])
        return spanned_rectangle_xml("board", start + half[1] * up, along, up, half)

    def edge_points(self) -> np.ndarray:
        """Two points (2, 3) [m] of the edge on the wall."""
        return np.array([[2.0, y, self.height + y * np.tan(self.slope)] for y in (-1.0, 1.0)])


def corner_scene(directory: Path, shadow: Shadow) -> Path:
    path = directory / f"corner_{shadow.height:g}_{np.degrees(shadow.slope):g}.xml"
    parts = [material_xml("wall_x", 0.5, preset="drywall"),
             material_xml("wall_y", 0.8, preset="drywall"),
             material_xml("floor", 0.15, preset="concrete"),
             material_xml("board", 0.5, preset="drywall"),
             SUN, LAMP, shadow.board_xml(),
             spanned_rectangle_xml("wall_x", CREASE + [0, -3, 1.6], [0, 0, 1], [0, 1, 0], (1.6, 3)),
             spanned_rectangle_xml("wall_y", CREASE + [-3, 0, 1.5], [1, 0, 0], [0, 0, 1], (4, 1.5)),
             spanned_rectangle_xml("floor", CREASE + [-3, -3, 0], [1, 0, 0], [0, 1, 0], (3, 3))]
    path.write_text('<scene version="3.0.0">\n' + "\n".join(parts) + "\n</scene>\n")
    return path


def robot_poses() -> list:
    """World-from-sensor poses of the robot ``ROBOT_DISTANCE`` from the crease, facing it."""
    return [mitsonar.Pose.sensor_on_robot(CREASE[0] - ROBOT_DISTANCE * np.cos(y),
                                          CREASE[1] - ROBOT_DISTANCE * np.sin(y), y)
            for y in YAWS]


#: The corner's three creases, two points (2, 3) [m] on each.
CREASES = [np.array([CREASE, CREASE + step]) for step in ([0.0, 0.0, 1.0], [0.0, -1.0, 0.0],
                                                          [-1.0, 0.0, 0.0])]


def near_line(scan, points) -> np.ndarray:
    """(n,) True for the pose's segments within EDGE_TOLERANCE of the image of the 3-D line
    through points (2, 3) [m]."""
    to_camera = scan.camera.world_from_camera(scan.pose).inverse()
    ends = scan.camera.project(to_camera.transform_points(points))
    d = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    across = np.abs((scan.segments.reshape(-1, 2, 2) - ends[0]) @ [-d[1], d[0]]).max(axis=1)
    return across < EDGE_TOLERANCE


def score_map(surfel_map, shadow: Shadow, mesh, samples, observable, seed: int) -> dict:
    """The figures of one map (module docstring)."""
    detected = removed = creases_removed = others_removed = shadow_surfels = 0
    for p, (scan, dropped) in enumerate(zip(surfel_map.scans, surfel_map.shadow)):
        edge = near_line(scan, shadow.edge_points())
        crease = np.any([near_line(scan, c) for c in CREASES], axis=0)
        detected += int(edge.any())
        removed += int(np.any(dropped & edge))
        creases_removed += int(np.sum(dropped & crease))
        others_removed += int(np.sum(dropped & ~edge & ~crease))
        registered = scan.segment_pairs[surfel_map.surfel_index[surfel_map.surfel_pose == p]]
        shadow_surfels += int(np.any(edge[registered], axis=1).sum()) if len(registered) else 0
    groups = surfel_map.groups
    lone = np.bincount(groups.label, minlength=len(groups)) == 1
    grown = np.flatnonzero(~(lone & (groups.normal_errors > surfel_map.settings.max_normal_error)))
    normal_error, corner_error = np.nan, np.nan
    if len(grown):
        used = [int(grown[np.argmax(groups.normals[grown] @ n)]) for n, _ in FACES.values()]
        normal_error = max(np.degrees(np.arccos(np.clip(groups.normals[g] @ n, -1, 1)))
                           for g, (n, _) in zip(used, FACES.values()))
        if len(set(used)) == 3:
            corner = np.linalg.solve(groups.normals[used], groups.offsets[used])
            corner_error = float(np.linalg.norm(corner - CREASE))
    points, _ = surfel_map.sample(0.01, seed=seed)
    overall = evaluate(points, mesh, samples=samples, observable=observable).overall
    return {"shadow": shadow.label, "detected": detected, "removed": removed,
            "creases_removed": creases_removed, "others_removed": others_removed,
            "shadow_surfels": shadow_surfels,
            "planes": len(grown), "normal_error_deg": float(normal_error),
            "corner_error_m": corner_error, "points": overall.points,
            "accuracy": overall.accuracy, "completeness": overall.completeness}


def observable_faces(sonar, mesh, poses, seed: int):
    """Ground-truth samples (1 cm) and the mask of those in view: in line of sight, in the
    array's field of view and within the sonar's range of a pose."""
    samples = sample_surface(mesh, 0.01, seed)
    geometry, seen = sonar.config.geometry, np.zeros(len(samples.points), dtype=bool)
    for pose in poses:
        local = pose.inverse().transform_points(samples.points)
        seen |= in_fov(local, geometry.fov_horizontal, geometry.fov_vertical) \
            & visible_from(sonar.scene, samples.points, pose.translation[None],
                           max_range=sonar.config.max_range)
    return samples, seen


def run(shadows, width: int, seed: int) -> tuple[list[dict], list[dict]]:
    """Rows (a shadow x removal on/off) and, per shadow, the maps for the figure."""
    rows, maps = [], []
    poses = robot_poses()
    with tempfile.TemporaryDirectory() as tmp:
        for shadow in shadows:
            sonar = mitsonar.Sonar(corner_scene(Path(tmp), shadow),
                                   mitsonar.SonarConfig.preset("paper"))
            mesh = scene_mesh(sonar.scene)
            samples, observable = observable_faces(sonar, mesh, poses, seed)
            pair = {}
            for remove in (True, False):
                settings = SurfelSettings(image_width=width, seed=seed, remove_shadows=remove)
                pair[remove] = map_surfels(sonar, poses, settings=settings)
                row = score_map(pair[remove], shadow, mesh, samples, observable, seed)
                rows.append({"removal": "on" if remove else "off", **row})
                print(f"{shadow.label}, removal {rows[-1]['removal']}: shadow line found in "
                      f"{row['detected']}/{len(poses)} poses, removed in {row['removed']}, "
                      f"{row['planes']} planes, {100 * row['accuracy']:.1f} % within 2 cm, "
                      f"completeness {100 * row['completeness']:.1f} %", file=sys.stderr)
            maps.append((shadow, pair))
    return rows, maps


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/shadow_lines"))
    parser.add_argument("--heights", default="0.6,1.2",
                        help="heights of horizontal shadow edges on the wall [m], comma separated")
    parser.add_argument("--slanted", type=float, default=20.0,
                        help="also a shadow edge rising at this angle [deg] through 0.9 m "
                             "(0: none)")
    parser.add_argument("--width", type=int, default=400, help="camera image width [pixels]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true",
                        help="one horizontal edge at 0.6 m (for the test suite)")
    args = parser.parse_args(argv)
    try:
        heights = [float(h) for h in args.heights.split(",")]
    except ValueError:
        raise ValueError(f"--heights must be numbers [m], comma separated, got {args.heights!r}")
    if not all(0.0 < h < 3.0 for h in heights):
        raise ValueError(f"--heights must lie on the 3.2 m wall, within (0, 3) m, got {heights}")
    if not -45.0 < args.slanted < 45.0:
        raise ValueError(f"--slanted must be within (-45, 45) deg, got {args.slanted}")
    shadows = [Shadow(h) for h in heights]
    if args.slanted:
        shadows.append(Shadow(0.9, np.radians(args.slanted)))
    if args.quick:
        shadows = [Shadow(0.6)]
    rows, maps = run(shadows, args.width, args.seed)
    write_outputs(args.out, rows, maps)
    return 0


def write_outputs(out: Path, rows: list[dict], maps) -> None:
    out.mkdir(parents=True, exist_ok=True)
    poses = len(YAWS)
    md = [f"Shadow edge across the wall x = 2, {poses} poses 2.8 m from the corner.", "",
          "| shadow edge | removal | found in poses | removed in poses | creases removed | "
          "other lines removed | "
          "surfels on the shadow | planes | normal error deg | corner error cm | "
          "points | within 2 cm % | completeness % |",
          "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        corner = f"{100 * r['corner_error_m']:.1f}" if np.isfinite(r["corner_error_m"]) else "-"
        md.append(f"| {r['shadow']} | {r['removal']} | {r['detected']}/{poses} | "
                  f"{r['removed']}/{poses} | {r['creases_removed']} | {r['others_removed']} | "
                  f"{r['shadow_surfels']} | "
                  f"{r['planes']} | {r['normal_error_deg']:.2f} | {corner} | {r['points']} | "
                  f"{100 * r['accuracy']:.1f} | {100 * r['completeness']:.1f} |")
    write_table(out / "shadow_lines.csv", rows, md)
    save_figure(out / "shadow_lines.png", maps)
    print("\n".join(md))
    print(f"Wrote {out}/shadow_lines.csv, .md and .png")


def save_figure(path: Path, maps) -> None:
    """Per shadow (a row): the middle pose's image with its segments (red: removed as shadow
    lines), then the planes grown over it with and without removal."""
    plt = _pyplot()
    fig = plt.figure(figsize=(15.0, 4.0 * len(maps)), layout="constrained")
    axes = fig.subplots(len(maps), 3, squeeze=False)
    for row, (shadow, pair) in zip(axes, maps):
        for ax, (title, remove) in zip(row, (("segments", True), ("planes, removal on", True),
                                             ("planes, removal off", False))):
            surfel_map = pair[remove]
            mid = len(surfel_map.scans) // 2
            scan, dropped = surfel_map.scans[mid], surfel_map.shadow[mid]
            ax.imshow(tone_map(scan.gray), cmap="gray", vmin=0, vmax=1)
            if title == "segments":
                for seg, gone in zip(scan.segments, dropped):
                    ax.plot(seg[[0, 2]], seg[[1, 3]], color="red" if gone else "lime", lw=1.5)
            else:
                mesh = surfel_map.meshes[mid]
                grown = mesh.grid_plane >= 0
                colours = plane_colours(max(len(surfel_map.groups), 1))
                uv = mesh.grid_pixels[grown]
                ax.scatter(uv[:, 0], uv[:, 1], c=colours[mesh.grid_plane[grown]], s=1.0,
                           alpha=0.35, linewidths=0)
                for seg in scan.segments[~dropped]:
                    ax.plot(seg[[0, 2]], seg[[1, 3]], color="white", lw=0.8)
            u0, v0, u1, v1 = scan.box
            ax.add_patch(plt.Rectangle((u0, v0), u1 - u0, v1 - v0, fill=False, ec="yellow",
                                       lw=0.8))
            ax.set_xlim(0, scan.camera.width)
            ax.set_ylim(scan.camera.height, 0)
            ax.set_axis_off()
            ax.set_title(f"{shadow.label}: {title}", fontsize=10)
    fig.suptitle("Shadow lines: segments (green kept, red removed as shadow lines) and the plane "
                 "grown at each pixel (colour per plane group; yellow: the array's field of view)")
    save_png(fig, path)


if __name__ == "__main__":
    sys.exit(main())
