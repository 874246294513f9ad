"""The surfel map of a set of poses (:class:`SurfelMap`): the registered surfels of all poses
grouped into global planes, shadow lines removed, the planes refined and grown again in every
pose's image (:func:`build_map`); :func:`map_surfels` scans the poses, builds the map, fires the
check pings and builds it again; :func:`map_surfels_along` drives a trajectory, taking a camera
frame whenever the sonar is free and firing its pings one after another as the robot moves."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from mitsonar.recon.surfels.growing import (_region_at, camera_rays, check_pose, grow_planes,
                                            heard_checks, intersect_planes, region_triangles,
                                            segment_sides, shadow_segments)
from mitsonar.recon.surfels.pinging import MovingPinger, StillPinger
from mitsonar.recon.surfels.planes import (GROUND, PlaneGroups, _pad_groups, _plane_offsets,
                                           _plane_stats, group_surfels, on_ground, refine_planes)
from mitsonar.recon.surfels.scanning import PoseScan, add_surfels, scan_pose
from mitsonar.recon.surfels.settings import SurfelSettings
from mitsonar.recon.thinning import VoxelThinner
from mitsonar.sensors.camera import CameraModel, CameraRenderer
from mitsonar.sensors.sonar import Sonar
from mitsonar.sensors.trajectory import Trajectory

#: Why surfels were not registered (keys of :attr:`SurfelMap.rejected`).
REJECTIONS = ("no_echo", "verification", "shadow_line", "refuted")


@dataclass(frozen=True)
class SurfelMap:
    """The surfel map of a set of poses.

    Attributes:
        scans: per pose what was seen and measured.
        groups: global plane groups of the registered surfels.
        surfel_pose: (k,) pose index of each registered surfel; surfel_index: (k,) its index
            among that pose's candidates.
        surfel_points: (k, 4, 3) their measured points [m].
        surfel_triangles: (k, 3, 3) their image triangles back-projected onto their group plane
            [m].
        vertices: (V, 3), triangles: (F, 3), plane: (F,) the map mesh (union over poses).
        shadow: per pose, (n,) True for segments removed as shadow lines.
        rejected: counts of candidates not registered, by reason (:data:`REJECTIONS`).
        meshes: per pose, the planes grown in its image
            (:class:`~mitsonar.recon.surfels.growing.PoseMesh`).
        settings: the settings the map was built with.
        times: (P,) when each pose's image was taken [s] (:func:`map_surfels_along`; empty
            for :func:`map_surfels`'s poses).
    """

    scans: list
    groups: PlaneGroups
    surfel_pose: np.ndarray
    surfel_index: np.ndarray
    surfel_points: np.ndarray
    surfel_triangles: np.ndarray
    vertices: np.ndarray
    triangles: np.ndarray
    plane: np.ndarray
    shadow: list
    rejected: dict = field(default_factory=dict)
    meshes: list = field(default_factory=list)
    settings: SurfelSettings = SurfelSettings()
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def sample(self, spacing: float = 0.01, seed: int = 0):
        """Points (M, 3) [m] on the mesh, one in each ``spacing`` cube it passes through (about
        one per ``spacing``^2), and their plane group (M,): each pose's mesh sampled uniformly
        at four per ``spacing``^2 (metrics' :func:`~mitsonar.scene.mesh.sample_surface`) and the
        samples thinned as they come to one per cube
        (:class:`~mitsonar.recon.thinning.VoxelThinner`; four, so that a cube a single mesh
        crosses is rarely left empty: on a three-pose corner 50 452 points, 47 292 at one per
        ``spacing``^2). The poses' meshes overlap wherever their images saw the same plane:
        their plain union counted a surface once per pose that saw it (2.7 times the points on
        that corner)."""
        from mitsonar.scene.mesh import SceneMesh, sample_surface

        n = len(self.groups)
        names, materials, glass = [f"plane{g}" for g in range(n)], np.zeros(n, int), \
            np.zeros(n, bool)
        thinner = VoxelThinner(spacing, seed)
        for k, m in enumerate(self.meshes):  # :attr:`vertices` etc. are their union
            if len(m.triangles):
                mesh = SceneMesh(m.vertices, m.triangles, m.plane, names, materials, glass, [])
                samples = sample_surface(mesh, spacing / 2, (seed, k))
                thinner.add(samples.points, m.plane[samples.triangle])
        return thinner.labelled_result()


def _register(scans, shadow, refuted=None):
    """Registered surfels of all poses, minus those built on a shadow segment and those
    ``refuted`` (per pose, (k,) bool over its candidates; None: none): pose (k,), candidate
    index (k,), points (k, 4, 3), viewpoints (k, 3), fill points (k, m, 3)."""
    pose_ids, index = [], []
    for p, (scan, removed) in enumerate(zip(scans, shadow)):
        ok = scan.accepted.copy()
        if refuted is not None:
            ok &= ~refuted[p]
        ok &= ~scan.on_segments(removed)
        pose_ids.append(np.full(int(ok.sum()), p))
        index.append(np.nonzero(ok)[0])
    pose_ids, index = np.concatenate(pose_ids).astype(int), np.concatenate(index).astype(int)
    points = np.array([scans[p].points_world[i] for p, i in zip(pose_ids, index)]).reshape(-1, 4, 3)
    view = np.array([scans[p].pose.translation for p in pose_ids]).reshape(-1, 3)
    m = max((s.fill_world.shape[1] for s in scans if s.fill_world is not None), default=0)
    extra = np.full((len(pose_ids), m, 3), np.nan)
    for k, (p, i) in enumerate(zip(pose_ids, index)):
        if scans[p].fill_world is not None:
            extra[k, :scans[p].fill_world.shape[1]] = scans[p].fill_world[i]
    return pose_ids, index, points, view, extra


def _heard_claims(scan, mesh, groups: PlaneGroups, settings: SurfelSettings):
    """A pose's heard check echoes: points (c, 3) [m], the groups claiming each one's image
    region (c, G) bool, those of them whose plane it lies on within ``merge_sigmas`` expected
    errors (c, G) bool, and its signed distances from every group's plane in expected errors
    (c, G) (:func:`~mitsonar.recon.surfels.planes._plane_offsets`)."""
    heard = np.all(np.isfinite(scan.checks.points), axis=1)
    points = scan.checks.points[heard]
    region = _region_at(mesh.regions, scan.checks.pixels[heard])
    claimed = np.zeros((len(points), len(groups)), dtype=bool)
    claimed[region >= 0] = mesh.hypotheses[region[region >= 0]] > 0
    offsets = _plane_offsets(points, scan.pose.translation, groups, settings)
    return points, claimed, claimed & (np.abs(offsets) <= settings.merge_sigmas), offsets


def _check_points(scans, meshes, groups: PlaneGroups, settings: SurfelSettings):
    """Check-ping points that join the plane fits: points (c, 3) [m], group (c,) and the
    sensor position they were measured from (c, 3) [m]. A check point joins the nearest plane
    claiming its pixel's region that it lies on
    (:func:`~mitsonar.recon.surfels.planes._on_planes`)."""
    out, label, view = [np.zeros((0, 3))], [np.zeros(0, int)], [np.zeros((0, 3))]
    for scan, mesh in zip(scans, meshes):
        if scan.checks is None or len(groups) == 0:
            continue
        pts, _, claimed, _ = _heard_claims(scan, mesh, groups, settings)
        off = np.where(claimed, np.abs(pts @ groups.normals.T - groups.offsets), np.inf)
        g = np.argmin(off, axis=1) if len(pts) else np.zeros(0, int)
        near = np.isfinite(np.take_along_axis(off, g[:, None], 1)[:, 0])
        out.append(pts[near])
        label.append(g[near])
        view.append(np.broadcast_to(scan.pose.translation, (int(near.sum()), 3)))
    return np.concatenate(out), np.concatenate(label), np.concatenate(view)


def refuted_groups(scans, meshes, groups: PlaneGroups, settings: SurfelSettings) -> np.ndarray:
    """(G,) True for plane groups the check pings refute.

    A pose's heard check echo in an image region claimed by some groups confirms those whose
    plane it lies on (:func:`~mitsonar.recon.surfels.planes._on_planes`); an echo on none of
    them says the region's planes are wrong there and counts against every claiming group. A
    group is refuted when at least ``min_refutations`` echoes count against it and they
    outnumber those confirming it: four registered surfels bunched at a cabinet's convex corner
    (front, side and the wall behind) fit some plane through the corner whatever the faces are,
    and on varied_3 such surfels from four poses agreed on a plane 45 deg off every face; 38
    check echoes in the regions it claimed lay on no plane there, 21 on it.

    A group is also refuted when the echoes on its plane scatter about it more than their
    expected errors allow: chi^2, the sum of their squared distances in expected errors, has a
    p-value below ``fit_significance`` (chi^2 with a degree of freedom per echo). Each echo
    lies within ``merge_sigmas`` (3) of the plane, but a plane tilted through surfels whose
    echoes straddle a crease has them all 1-3 expected errors off: on varied_2 two such planes
    (4 and 22 deg off the wall, 13 and 39 % of their area within 2 cm) gave chi^2 per echo 2.7
    and 2.0 over 23 and 90 echoes (p 2e-5 and 4e-8), the room's true planes 0.01-0.29.
    """
    from scipy.stats import chi2

    confirmed, against, misfit = np.zeros((3, len(groups)))
    for scan, mesh in zip(scans, meshes):
        if scan.checks is None or len(groups) == 0:
            continue
        _, claimed, on, offsets = _heard_claims(scan, mesh, groups, settings)
        confirmed += on.sum(axis=0)
        against += (claimed & ~on.any(axis=1, keepdims=True)).sum(axis=0)
        misfit += np.where(on, offsets ** 2, 0.0).sum(axis=0)
    scattered = (confirmed > 0) & (chi2.sf(misfit, np.maximum(confirmed, 1))
                                   < settings.fit_significance)
    return ((against >= settings.min_refutations) & (against > confirmed)) | scattered


def misfit_members(surfel_map: SurfelMap, settings: SurfelSettings) -> np.ndarray:
    """(k,) True for the registered surfels of groups of several whose points do not lie on
    their group's final plane: chi^2, the sum of their points' (four and fill) squared
    distances from it in expected errors (:func:`~mitsonar.recon.surfels.planes._plane_offsets`),
    has a p-value below ``fit_significance`` (a degree of freedom per point); of each group only
    the worst such surfel.

    Grouping tests two surfels against a plane through both, which two small patches far
    apart always admit: on varied_1 a surfel whose four echoes lay on a window pane joined a
    surfel on the wall's face 10 cm in front of it 2.5 m away, on a plane tilted 2.3 deg
    between them. The check echoes on the wall pin its final plane to the face, and the pane
    surfel's points lie 9-10 cm behind it, 2.7-2.9 expected errors each (chi^2 29 over 4,
    p 6e-6)."""
    from scipy.stats import chi2

    groups, label = surfel_map.groups, surfel_map.groups.label
    worst = np.zeros(len(label), dtype=bool)
    several = np.bincount(label, minlength=len(groups))[label] > 1
    if not np.any(several):
        return worst
    p_value = np.ones(len(label))
    for k in np.flatnonzero(several):  # the members of groups of several: a few dozen
        scan, i = surfel_map.scans[surfel_map.surfel_pose[k]], surfel_map.surfel_index[k]
        points = surfel_map.surfel_points[k]
        if scan.fill_world is not None:
            fill = scan.fill_world[i]
            points = np.concatenate([points, fill[np.all(np.isfinite(fill), axis=1)]])
        off = _plane_offsets(points, scan.pose.translation, groups, settings)[:, label[k]]
        p_value[k] = chi2.sf(np.sum(off ** 2), len(points))
    for g in np.unique(label[p_value < settings.fit_significance]):
        members = np.flatnonzero(label == g)
        worst[members[np.argmin(p_value[members])]] = True
    return worst


def build_map(scans, settings: SurfelSettings = SurfelSettings()) -> SurfelMap:
    """Group the registered surfels of all poses, remove shadow lines, grow every pose's regions
    on the global planes and join the meshes (package docstring); then, until none is left,
    drop the surfels of the plane groups the check pings refute (:func:`refuted_groups`) and
    build it again without them.

    A refuted group of several surfels is split first: its surfels are judged alone
    (``group_surfels``' ``alone``) and only those refuted alone are dropped. Surfels built at a
    recessed window's outline hear the wall face with some beams and the pane 10 cm behind it
    with others, and such a surfel fits a plane tilted between the two; on varied_7 two of them
    joined the one surfel whose four echoes all lay on the pane, the check echoes refuted their
    tilted plane (chi^2 per echo 2.95 over 106), and dropping all three left the window
    unmapped. A surfel whose own points do not lie on its group's final plane
    (:func:`misfit_members`) is judged alone too."""
    refuted = [np.zeros(len(s.accepted), dtype=bool) for s in scans]
    alone = [np.zeros(len(s.accepted), dtype=bool) for s in scans]
    for _ in range(settings.max_iterations):  # each round splits or drops at least one group
        surfel_map = _build(scans, settings, refuted, alone)
        label = surfel_map.groups.label
        wrong = np.isin(label, np.nonzero(refuted_groups(scans, surfel_map.meshes,
                                                         surfel_map.groups, settings))[0])
        several = np.bincount(label, minlength=len(surfel_map.groups))[label] > 1
        chosen = wrong | misfit_members(surfel_map, settings)  # misfits: in groups of several
        if not np.any(chosen):
            break
        for p, i, split in zip(surfel_map.surfel_pose[chosen], surfel_map.surfel_index[chosen],
                               several[chosen]):
            (alone if split else refuted)[p][i] = True
    return surfel_map


def _grounded(points, viewpoints, extra, settings: SurfelSettings) -> np.ndarray:
    """(k,) True for the surfels whose points (k, 4, 3) and fill points (k, m, 3) [m]
    (NaN-padded), seen from viewpoints (k, 3) [m], fit the ground alone (:func:`on_ground`)."""
    every = np.concatenate([points, extra], axis=1)
    label = np.broadcast_to(np.arange(len(every))[:, None], every.shape[:2])
    seen = np.broadcast_to(viewpoints[:, None], every.shape)
    finite = np.all(np.isfinite(every), axis=-1)
    return on_ground(len(every), every[finite], label[finite], seen[finite], settings)


def _build(scans, settings: SurfelSettings, refuted, alone) -> SurfelMap:
    """:func:`build_map` without the surfels ``refuted``, those ``alone`` in groups of their own
    (both per pose, (k,) bool over its candidates)."""
    shadow = [np.zeros(len(s.segments), dtype=bool) for s in scans]
    checks = heard_checks(scans)
    for _ in range(2):  # group, find shadow lines, then once more without them
        pose_ids, index, points, view, extra = _register(scans, shadow, refuted)
        single = np.array([alone[p][i] for p, i in zip(pose_ids, index)], bool)
        floor = _grounded(points, view, extra, settings) if settings.ground else None
        groups = group_surfels(points, view, settings, extra, single, floor)
        meshes = [grow_planes(s, s.segments[~r], groups, points, settings, checks)
                  for s, r in zip(scans, shadow)]
        if not settings.remove_shadows:
            break
        found = [shadow_segments(replace_segments(s, ~r), m.regions, m.region_groups,
                                 settings.shadow_offset) for s, r, m in zip(scans, shadow, meshes)]
        new = [r.copy() for r in shadow]
        for r, f in zip(new, found):
            r[np.nonzero(~r)[0][f]] = True
        if all(np.array_equal(a, b) for a, b in zip(new, shadow)):
            break
        shadow = new
    every = np.concatenate([points.reshape(-1, 3), extra.reshape(-1, 3)])
    label = np.concatenate([np.repeat(groups.label, 4), np.repeat(groups.label, extra.shape[1])])
    seen = np.concatenate([np.repeat(view, 4, axis=0), np.repeat(view, extra.shape[1], axis=0)])
    finite = np.all(np.isfinite(every), axis=1)
    every, label, seen = every[finite], label[finite], seen[finite]
    regrow = settings.refine and len(groups) > 0
    if regrow:
        creases = []
        for s, r, m in zip(scans, shadow, meshes):
            segments = s.segments[~r]
            left, right = segment_sides(segments, m.regions, m.region_groups,
                                        settings.shadow_offset)
            pose = s.camera.world_from_camera(s.pose)
            creases += [(s.camera, pose, seg, a, b) for seg, a, b in zip(segments, left, right)
                        if a >= 0 and b >= 0 and a != b]
        previous = None
        for _ in range(settings.max_iterations):  # until the check points on the planes settle
            checked, check_label, check_view = _check_points(scans, meshes, groups, settings)
            if previous is not None and np.array_equal(previous[0], checked) and \
                    np.array_equal(previous[1], check_label):
                break
            previous = checked, check_label
            groups = refine_planes(groups, np.concatenate([every, checked]),
                                   np.concatenate([label, check_label]),
                                   np.concatenate([seen, check_view]), creases, settings)
        # the check echoes on a plane widen its support: a poorly determined plane they confirm
        # over a wide area is then well determined and claims its regions
        every, seen = np.concatenate([every, checked]), np.concatenate([seen, check_view])
        label = np.concatenate([label, check_label])
        groups = replace(groups, normal_errors=_plane_stats(*_pad_groups(
            every[:, None], seen, label), settings)[2])
    if settings.ground and len(groups):  # the floor the robot drives on is known exactly
        floor = on_ground(len(groups), every, label, seen, settings)
        if np.any(floor):
            normals, offsets = groups.normals.copy(), groups.offsets.copy()
            normals[floor], offsets[floor] = GROUND
            groups = replace(groups, normals=normals, offsets=offsets,
                             normal_errors=np.where(floor, 0.0, groups.normal_errors))
            regrow = True
    if regrow:
        meshes = [grow_planes(s, s.segments[~r], groups, points, settings, checks)
                  for s, r in zip(scans, shadow)]
    vertices, triangles, plane, offset = [], [], [], 0
    for m in meshes:
        vertices.append(m.vertices)
        triangles.append(m.triangles + offset)
        plane.append(m.plane)
        offset += len(m.vertices)
    tri3d = _surfel_triangles(scans, pose_ids, index, groups)
    rejected = {"no_echo": 0, "verification": 0, "shadow_line": 0,
                "refuted": int(sum(r.sum() for r in refuted))}
    for s, r in zip(scans, shadow):
        rejected["no_echo"] += int(np.sum(~np.isfinite(s.residual)))
        rejected["verification"] += int(np.sum(np.isfinite(s.residual) & ~s.accepted))
        rejected["shadow_line"] += int(np.sum(s.accepted & s.on_segments(r)))
    return SurfelMap(list(scans), groups, pose_ids, index, points, tri3d,
                     np.concatenate(vertices).reshape(-1, 3),
                     np.concatenate(triangles).reshape(-1, 3).astype(np.int64),
                     np.concatenate(plane).astype(int), shadow, rejected, meshes, settings)


def replace_segments(scan: PoseScan, keep) -> PoseScan:
    """``scan`` with only the segments ``keep`` (n,) bool (pairs of dropped ones are not
    meaningful in the result and are emptied)."""
    return replace(scan, segments=scan.segments[np.asarray(keep, bool)],
                   segment_pairs=np.zeros((0, 2), int), triangles=np.zeros((0, 3, 2)),
                   points_world=np.zeros((0, 4, 3)), residual=np.zeros(0),
                   accepted=np.zeros(0, bool), fill_world=None, checks=None)


def _surfel_triangles(scans, pose_ids, index, groups: PlaneGroups) -> np.ndarray:
    """(k, 3, 3) image triangles of the registered surfels back-projected onto their planes."""
    out = np.zeros((len(pose_ids), 3, 3))
    for k, (p, i) in enumerate(zip(pose_ids, index)):  # a few dozen surfels
        scan = scans[p]
        camera_pose = scan.camera.world_from_camera(scan.pose)
        rays = camera_rays(scan.camera, camera_pose, scan.triangles[i])
        g = groups.label[k]
        t = intersect_planes(camera_pose.translation, rays, groups.normals[g:g + 1],
                             groups.offsets[g:g + 1])[:, 0]
        out[k] = camera_pose.translation + rays * t[:, None]
    return out


def map_surfels(sonar: Sonar, poses, odometry=None, settings: SurfelSettings = SurfelSettings(),
                progress=None) -> SurfelMap:
    """Surfel map from world-from-sensor ``poses`` (list of :class:`~mitsonar.frames.Pose`);
    ``odometry`` (same length) registers the points instead of the true poses when given;
    ``progress`` is called with each pose index (and again for each pose's check pings).

    With ``settings.check_spacing`` > 0 the map is built twice: the first map's grown planes
    are pinged from every pose (:func:`~mitsonar.recon.surfels.growing.check_pose`) and the
    second grows each plane only where that evidence supports it
    (:func:`~mitsonar.recon.surfels.growing._support`)."""
    poses = list(poses)
    odometry = poses if odometry is None else list(odometry)
    if len(odometry) != len(poses):
        raise ValueError(f"odometry has {len(odometry)} poses, poses {len(poses)}")
    if not poses:
        raise ValueError("map_surfels needs at least one pose")
    if settings.max_range is None:
        settings = replace(settings, max_range=sonar.config.max_range)
    renderer = _renderer(sonar, settings)
    scans = []
    for k, (pose, odo) in enumerate(zip(poses, odometry)):
        scans.append(scan_pose(StillPinger(sonar, pose), renderer, odo, settings,
                               seed=settings.seed + k))
        if progress is not None:
            progress(k)
    surfel_map = build_map(scans, settings)
    if settings.region_surfels:
        before = list(scans)
        for k, pose in enumerate(poses):
            mesh = _tentative(scans[k], surfel_map, settings, surfel_map.shadow[k]) \
                if len(surfel_map.groups) else None
            scans[k] = _with_regions(StillPinger(sonar, pose), scans[k], mesh, settings, k)
        if any(a is not b for a, b in zip(scans, before)):
            surfel_map = build_map(scans, settings)
    if settings.check_spacing == 0 or len(surfel_map.groups) == 0:
        return surfel_map
    aims = [_tentative(s, surfel_map, settings, r) for s, r in zip(scans, surfel_map.shadow)]
    checked = []
    for k, (pose, scan, mesh) in enumerate(zip(poses, scans, aims)):
        checked.append(check_pose(StillPinger(sonar, pose), scan, mesh, settings,
                                  _pose_seed(settings, k, CHECK_STREAM)))
        if progress is not None:
            progress(k)
    return build_map(checked, settings)


def _tentative(scan: PoseScan, surfel_map: SurfelMap, settings: SurfelSettings, shadow=None):
    """The map's planes and hypotheses grown in ``scan``'s image without its ``shadow`` (n,)
    bool segments (None: all kept): where the check pings are aimed."""
    keep = slice(None) if shadow is None else ~shadow
    return grow_planes(scan, scan.segments[keep], surfel_map.groups, surfel_map.surfel_points,
                       settings, tentative=True)


#: Random streams of a pose's pings after its surfels' own: check pings, region surfels.
CHECK_STREAM, REGION_STREAM = 2, 3


def _pose_seed(settings: SurfelSettings, k: int, stream: int) -> int:
    """Seed of pose ``k``'s pings of ``stream`` (``CHECK_STREAM``, ``REGION_STREAM``)."""
    return int(np.random.SeedSequence([settings.seed + k, stream]).generate_state(1)[0])


def _with_regions(pinger, scan: PoseScan, mesh, settings: SurfelSettings, k: int) -> PoseScan:
    """``scan`` (pose ``k``) with its region surfels pinged by ``pinger``
    (:func:`~mitsonar.recon.surfels.growing.region_triangles` of the regions ``mesh``'s planes
    leave unclaimed; None: every region), or ``scan`` itself when there are none."""
    triangles = region_triangles(scan, settings, mesh)
    if not len(triangles):
        return scan
    return add_surfels(pinger, scan, triangles, settings, _pose_seed(settings, k, REGION_STREAM))


def _renderer(sonar: Sonar, settings: SurfelSettings) -> CameraRenderer:
    return CameraRenderer(sonar.scene,
                          CameraModel(spp=settings.spp).at_resolution(settings.image_width))


def _mesh_so_far(scans, settings: SurfelSettings):
    """The planes of the surfels registered in ``scans`` so far, grown in the last scan's image
    (None before the first registered surfel): what a check ping can be aimed at as the robot
    drives."""
    _, _, points, view, extra = _register(scans, [np.zeros(len(s.segments), bool) for s in scans])
    if not len(points):
        return None
    groups = group_surfels(points, view, settings, extra)
    return grow_planes(scans[-1], scans[-1].segments, groups, points, settings,
                       heard_checks(scans), tentative=True)


def map_surfels_along(sonar: Sonar, trajectory: Trajectory,
                      settings: SurfelSettings = SurfelSettings(), duration: float | None = None,
                      progress=None) -> SurfelMap:
    """Surfel map of a robot driving the first ``duration`` [s] of ``trajectory`` (None: all of
    it) at the sensors' own rates.

    The camera takes a frame every 1 / ``CameraModel.frame_rate`` (25 Hz); whenever the sonar is
    free the pipeline takes the newest frame, and that frame's pings (four per surfel, the fill
    pings, then the check pings over the planes registered so far, grown in this image) leave one
    after another every ``SonarConfig.record_duration`` (the listening time, 30 ms), each from
    the pose the robot has then and registered with it
    (:class:`~mitsonar.recon.surfels.pinging.MovingPinger`; no odometry drift). The next frame
    is the first the camera takes once the last echo is in. The check pings only see the
    planes known when their frame was taken, unlike :func:`map_surfels`'s second pass. Frames
    follow each other in time, so the loop over them is sequential. ``progress`` is called with
    the trajectory time reached [s] after each frame."""
    if settings.max_range is None:
        settings = replace(settings, max_range=sonar.config.max_range)
    renderer = _renderer(sonar, settings)
    end = trajectory.driven(duration)
    period = 1.0 / renderer.model.frame_rate
    scans, times, frame = [], [], 0
    while frame * period < end:  # frames follow each other in time
        start, k = frame * period, len(scans)
        pinger = MovingPinger(sonar, trajectory, image_time=start, time=start)
        scan = scan_pose(pinger, renderer, pinger.pose, settings, seed=settings.seed + k)
        mesh = _mesh_so_far(scans + [scan], settings) \
            if settings.check_spacing or settings.region_surfels else None
        if settings.region_surfels:
            regions = _with_regions(pinger, scan, mesh, settings, k)
            if regions is not scan:
                scan, mesh = regions, _mesh_so_far(scans + [regions], settings)
        if settings.check_spacing and mesh is not None:
            scan = check_pose(pinger, scan, mesh, settings, _pose_seed(settings, k, CHECK_STREAM))
        scans.append(scan)
        times.append(start)
        frame = max(int(np.ceil(pinger.time / period - 1e-9)), frame + 1)
        if progress is not None:
            progress(min(frame * period, end))
    return replace(build_map(scans, settings), times=np.array(times))
