"""``mitsonar map repeated|surfel``: the two reconstruction modes."""

from __future__ import annotations

import sys

import numpy as np

from mitsonar.cli.arguments import (add_drive_arguments, add_echoes_argument,
                                    add_output_argument, add_preset_argument, add_record_argument,
                                    add_scene_argument, add_trajectory_argument,
                                    add_workers_argument, command_group, drive_config,
                                    trajectory_from_args)
from mitsonar.recon.repeated import REGISTRATIONS, SCANS, RepeatedMapSpec, map_repeated
from mitsonar.recon.surfels import (SurfelSettings, map_surfels, map_surfels_along,
                                    save_surfel_map, summary)
from mitsonar.recon.voxelmap import VoxelMapSettings, save_voxel_figure, save_voxel_ply
from mitsonar.sensors.camera import CameraModel
from mitsonar.sensors.imaging_sonar import TRANSMISSIONS
from mitsonar.sensors.sonar import Sonar
from mitsonar.sensors.trajectory import sensor_poses


def add_cli(subparsers) -> None:
    """``mitsonar map repeated`` and ``mitsonar map surfel``."""
    sub = command_group(subparsers, "map", help="reconstruction maps")
    r = sub.add_parser("repeated", help="OFDM repeated scanning into a coloured voxel map",
                       description="Drive the scene's default trajectory (or the waypoints "
                                   "given) firing OFDM frames (or single-ping images) back to "
                                   "back, colour the points from the camera and voxelise them.")
    add_scene_argument(r)
    add_output_argument(r)
    add_trajectory_argument(r)
    _add_drive_arguments(r)
    r.add_argument("--frames", type=int, default=None,
                   help="fire only this many frames (default: every frame that starts while "
                        "the robot drives, back to back: 4.8 frames/s)")
    r.add_argument("--step", type=float, default=5.0, help="beam grid step [deg] (default 5)")
    r.add_argument("--dither", type=int, default=RepeatedMapSpec.dither,
                   help="shift the beam grid from frame to frame through DITHER x DITHER "
                        "offsets of step / DITHER, so frames steer between each other's beams "
                        f"(default {RepeatedMapSpec.dither}; 1: the paper's fixed grid)")
    r.add_argument("--voxel", type=float, default=0.05, help="voxel size [m] (default 0.05)")
    add_preset_argument(r)
    add_drive_arguments(r, "with --scan imaging, the most points per second: docs/imaging.md")
    r.add_argument("--scan", choices=SCANS, default="ofdm",
                   help="OFDM frames back to back ('ofdm', the paper's) or single-ping receive "
                        "images, one per listening cycle, a camera image every 0.2 s "
                        "('imaging') (default: ofdm)")
    r.add_argument("--transmit", choices=tuple(TRANSMISSIONS), default="element",
                   help="with --scan imaging: one transmit element ('element', as RTIS) or the "
                        "whole array defocused over the field of view ('defocused', 14 dB more; "
                        "docs/imaging.md) (default: element)")
    r.add_argument("--registration", choices=REGISTRATIONS, default="beam",
                   help="pose of the points: each beam's pose at firing ('beam') or one odometry "
                        "pose per frame ('frame', the paper's) (default: beam)")
    add_echoes_argument(r, RepeatedMapSpec.echoes, "that become points")
    r.add_argument("--seed", type=int, default=0,
                   help="seed of the noise and the diffuse phases (default 0)")
    add_workers_argument(r, "the frames")
    add_record_argument(r)
    r.set_defaults(func=_run_repeated)
    _add_surfel(sub)


def _add_drive_arguments(parser) -> None:
    """``--duration`` and ``--speed``: how much of the trajectory is driven, how fast."""
    parser.add_argument("--duration", type=float, default=None,
                        help="drive only the first DURATION seconds of the trajectory (default: "
                             "all of it)")
    parser.add_argument("--speed", type=float, default=None,
                        help="robot speed along the trajectory [m/s] (default: the "
                             "trajectory's, 0.2 m/s in the shipped scenes)")


def _drive(args):
    """The trajectory (at ``--speed``) and the time driven [s] (``--duration``), announced."""
    from dataclasses import replace

    trajectory = trajectory_from_args(args)
    if args.frames is not None and args.frames < 1:
        raise ValueError(f"--frames must be >= 1, got {args.frames}")
    if args.speed is not None:
        trajectory = replace(trajectory, speed=args.speed)
    if args.duration is not None and not 0 < args.duration <= trajectory.duration:
        raise ValueError(f"--duration must lie in (0, {trajectory.duration:.1f}] s, the "
                         f"trajectory's length, got {args.duration:g}")
    driven = trajectory.driven(args.duration)
    print(f"Driving {driven:.1f} s of the {trajectory.duration:.1f} s trajectory at "
          f"{trajectory.speed:g} m/s, turning at {np.degrees(trajectory.yaw_rate):g} deg/s.",
          file=sys.stderr)
    return trajectory, driven


def _run_repeated(args) -> int:
    from tqdm import tqdm

    if args.transmit != "element" and args.scan != "imaging":
        raise ValueError(f"--transmit {args.transmit} needs --scan imaging (OFDM frames steer "
                         "the whole array)")
    config = drive_config(args)
    trajectory, driven = _drive(args)
    spec = RepeatedMapSpec(frames=args.frames, duration=driven, scan_step=np.radians(args.step),
                           dither=args.dither,
                           voxels=VoxelMapSettings(voxel_size=args.voxel),
                           registration=args.registration, echoes=args.echoes, seed=args.seed,
                           scan=args.scan, transmit=TRANSMISSIONS[args.transmit])
    sonar = Sonar(args.scene, config)
    label = "OFDM frames" if args.scan == "ofdm" else "image frames"
    with tqdm(desc=label, unit="frame", file=sys.stderr) as bar:
        def step(_, total):
            bar.total = total
            bar.update()

        voxels, positions, frames = map_repeated(sonar, trajectory, spec, step, args.workers)
    save_voxel_ply(args.out / "voxel_map.ply", voxels)
    save_voxel_figure(args.out / "voxel_map.png", voxels, positions,
                      title=f"{args.scene.parent.name}: {len(frames)} {label}")
    points = sum(len(s.points) for s in frames)
    kept = f"{args.echoes} echoes" if args.scan == "ofdm" else \
        f"{sum(len(s.images) for s in frames)} images"
    print(f"{points} points ({kept}) from {len(frames)} frames -> {len(voxels)} voxels; wrote {args.out}/voxel_map.ply and voxel_map.png (top, side and 3-D views).")
    if args.record is not None:
        from mitsonar.data.map_mcap import record_repeated
        from mitsonar.data.mcap_recorder import describe

        counts = record_repeated(args.record, frames, voxels, trajectory, seed=args.seed)
        print(f"Recorded {describe(args.record, counts)}.")
    return 0


def _add_surfel(map_subparsers) -> None:
    """``mitsonar map surfel``."""
    s = map_subparsers.add_parser(
        "surfel", help="surfel scanning into a plane mesh (paper III-D)",
        description="Along a trajectory, driven at the sensors' own rates: camera lines -> "
                    "triangle surfels -> 4 pings each -> verified surfels -> plane groups -> "
                    "planes grown between the image lines; scored against the scene's ground "
                    "truth.")
    add_scene_argument(s)
    add_output_argument(s)
    add_trajectory_argument(s)
    _add_drive_arguments(s)
    s.add_argument("--frames", type=int, default=None,
                   help="instead of driving, stop at this many poses spread evenly over the "
                        "trajectory and scan from each (default: drive, taking a 25 Hz camera "
                        "frame whenever the sonar is free and pinging every 30 ms)")
    s.add_argument("--width", type=int, default=400,
                   help="camera image width [pixels] (default 400)")
    s.add_argument("--spp", type=int, default=8, help="camera samples per pixel (default 8)")
    add_preset_argument(s)
    s.add_argument("--seed", type=int, default=0,
                   help="seed of the camera images and the pings (default 0)")
    add_record_argument(s)
    s.set_defaults(func=_run_surfel)


def _run_surfel(args) -> int:
    import time

    from tqdm import tqdm

    from mitsonar.evaluation.metrics import evaluate
    from mitsonar.scene.mesh import scene_mesh
    from mitsonar.sensors.sonar import SonarConfig

    settings = SurfelSettings(image_width=args.width, spp=args.spp, seed=args.seed)
    trajectory, driven = _drive(args)
    sonar = Sonar(args.scene, SonarConfig.preset(args.preset))
    # the poses a recording stamps the pings with: the still poses, or every camera frame
    times = np.linspace(0.0, driven, args.frames) if args.frames is not None else \
        trajectory.times_at_rate(CameraModel().frame_rate, driven)
    recording = None
    if args.record is not None:
        from mitsonar.data.map_mcap import SurfelRunRecording

        recording = SurfelRunRecording(sonar, trajectory, times,
                                       sensor_poses(trajectory.poses_at(times)), seed=args.seed)
        sonar = recording.sonar
    start = time.perf_counter()
    if args.frames is None:
        with tqdm(total=round(driven, 2), desc="trajectory driven", unit="s",
                  bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s [{elapsed}<{remaining}]",
                  file=sys.stderr) as bar:
            surfel_map = map_surfels_along(sonar, trajectory, settings, driven,
                                           lambda t: bar.update(round(t, 2) - bar.n))
        times = surfel_map.times
    else:
        passes = 1 if settings.check_spacing == 0 else 2
        with tqdm(total=passes * len(times), desc="poses (scan, check)", unit="pose",
                  file=sys.stderr) as bar:
            surfel_map = map_surfels(sonar, sensor_poses(trajectory.poses_at(times)),
                                     settings=settings, progress=lambda _: bar.update())
    points, plane = save_surfel_map(args.out, surfel_map,
                                    title=f"{args.scene.parent.name}: {len(times)} poses")
    info = summary(surfel_map)
    score = evaluate(points, scene_mesh(sonar.scene)).overall if len(points) else None
    print(f"{len(times)} camera frames, {info['registered_surfels']} of "
          f"{info['candidate_surfels']} surfels registered ({info['pings']} pings), "
          f"{len(surfel_map.groups)} planes, "
          f"{info['shadow_lines_removed']} shadow lines removed, "
          f"{time.perf_counter() - start:.0f} s; wrote {args.out}/surfel_map.ply, "
          f"surfel_points.ply, surfels.json, surfel_map.png")
    if score is not None:
        print(f"accuracy: {100 * score.accuracy:.1f} % of {len(points)} sampled points "
              f"({1e-4 * len(points):.1f} m^2) within 2 cm of the ground truth (median "
              f"{100 * score.median_distance:.1f} cm); they cover {100 * score.completeness:.1f} % "
              f"of the scene's surface")
    if recording is not None:
        from mitsonar.data.mcap_recorder import describe

        counts = recording.save(args.record, surfel_map, points, plane)
        print(f"Recorded {describe(args.record, counts)}.")
    return 0
