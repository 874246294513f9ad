"""``mitsonar dataset render|info|export``: paired camera + echo datasets."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mitsonar.cli.arguments import (add_drive_arguments, add_echoes_argument,
                                    add_preset_argument, add_scene_argument,
                                    add_shared_hits_argument, add_workers_argument, command_group,
                                    drive_config, output_directory, output_file)
from mitsonar.data.dataset import SCANS, DatasetSpec, open_dataset, render_dataset


def add_cli(subparsers) -> None:
    """``mitsonar dataset render|info|export``."""
    sub = command_group(subparsers, "dataset",
                        help="paired camera + echo datasets along trajectories")
    r = sub.add_parser("render", help="render (or resume) a dataset along the scene's trajectory",
                       description="Render camera images, per-microphone echoes of a beam scan, "
                                   "poses and calibration for every sample along a trajectory. "
                                   "Interrupted renders resume where they stopped.")
    add_scene_argument(r)
    r.add_argument("--out", type=output_directory, required=True,
                   help="dataset directory, created if absent; a partial render there resumes")
    r.add_argument("--period", type=float, default=1.0,
                   help="time between samples along the trajectory [s] (default 1)")
    r.add_argument("--step", type=float, default=10.0, help="beam grid step [deg] (default 10)")
    r.add_argument("--width", type=int, default=400, help="image width [pixels] (default 400)")
    r.add_argument("--spp", type=int, default=16, help="camera samples per pixel (default 16)")
    r.add_argument("--samples", type=int, default=None,
                   help="render only the first N samples (default: all)")
    r.add_argument("--seed", type=int, default=0,
                   help="base seed of the noise, diffuse phases, odometry drift and renderer "
                        "(default 0)")
    add_preset_argument(r)
    add_echoes_argument(r, DatasetSpec.echoes, "recorded, with their attributes")
    r.add_argument("--scan", choices=SCANS, default=DatasetSpec.scan,
                   help="what the sonar records per sample: a beam scan over the field of view "
                        "('beams', --step, --echoes) or one single-ping receive image ('image', "
                        "every point of it with its attributes) (default: beams)")
    add_drive_arguments(r, "with --scan image, the most points per image: docs/imaging.md")
    add_shared_hits_argument(r)
    add_workers_argument(r, "the samples")
    r.add_argument("--scheduler", default=None,
                   help="Dask scheduler address, or 'local' for a Dask LocalCluster of --workers "
                        "(default: none, local processes)")
    r.set_defaults(func=_run_render)
    i = sub.add_parser("info", help="summarise a dataset and check every file")
    i.add_argument("path", type=Path, help="dataset directory (as written by dataset render)")
    i.set_defaults(func=_run_info)
    x = sub.add_parser("export", help="write a dataset as MCAP with ROS 2 messages (Foxglove)",
                       description="Write every sample's camera image, depth, calibration, "
                                   "sonar detections, per-channel echoes, frames, odometry and "
                                   "ground truth as one MCAP file (docs/mcap.md). Every file is "
                                   "verified first; a bad one is named and nothing is written.")
    x.add_argument("path", type=Path, help="dataset directory (as written by dataset render)")
    x.add_argument("--out", type=output_file, required=True, metavar="FILE.mcap",
                   help="MCAP file to write (replaced if it exists)")
    x.set_defaults(func=_run_export)


def _run_render(args) -> int:
    import sys

    from tqdm import tqdm

    if not args.scene.is_file():
        raise ValueError(f"{args.scene}: scene file not found")
    drive_config(args)  # a sweep the transducers cannot pass, named by its options
    if args.shared_hits and args.scan != "beams":
        raise ValueError(f"--shared-hits applies to --scan beams, not --scan {args.scan}")
    spec = DatasetSpec(str(args.scene), period=args.period, scan_step=np.radians(args.step),
                       image_width=args.width, spp=args.spp, seed=args.seed,
                       max_samples=args.samples, sonar_preset=args.preset, echoes=args.echoes,
                       scan=args.scan, broadband=args.broadband, chirp=args.chirp,
                       shared_hits=args.shared_hits)
    total = len(spec.timeline()[0])
    with tqdm(total=total, desc="samples", unit="sample", file=sys.stderr) as bar:
        done = sum((args.out / "samples" / f"{k:06d}" / "manifest.json").exists() for k in range(total))
        bar.update(done)
        render_dataset(spec, args.out, workers=args.workers, scheduler=args.scheduler,
                       progress=lambda _: bar.update())
    print(f"Wrote {total} samples to {args.out} (read them with mitsonar.data.dataset.open_dataset).")
    return 0


def _run_info(args) -> int:
    ds = open_dataset(args.path)
    for k in range(len(ds)):
        ds[k]  # verifies sizes and checksums
    spec = ds.meta["spec"]
    print(f"{args.path}: {len(ds)} samples of {spec['scene']}, every {spec['period']} s; "
          f"all files verified.")
    return 0


def _run_export(args) -> int:
    import sys

    from tqdm import tqdm

    from mitsonar.data.dataset_mcap import export_dataset
    from mitsonar.data.mcap_recorder import describe

    with tqdm(total=len(open_dataset(args.path)), desc="samples", unit="sample",
              file=sys.stderr, leave=False) as bar:
        counts = export_dataset(args.path, args.out, progress=lambda _: bar.update())
    print(f"Wrote {describe(args.out, counts)}.")
    return 0
