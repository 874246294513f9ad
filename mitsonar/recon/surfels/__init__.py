"""Surfel scanning reconstruction (paper section III-D, Fig. 5): camera lines -> triangle surfels
-> four pings each -> verification -> registration (12) -> fill pings -> plane optimisation
(14)(15) and joint refinement with the image creases ->
planes grown inside the image regions bounded by the line segments -> surfel map.

Per pose (:func:`~mitsonar.recon.surfels.scanning.scan_pose`): the image is rendered, line segments
are detected in the part inside the array's field of view, triangle surfels are built from segment
pairs and each is pinged at its four scan pixels (:mod:`mitsonar.recon.lines`; beam directions by
(10)(11), parallel to the camera rays). A surfel is registered when all four beams detect an echo
and the measured centroid lies within ``verify_threshold`` (0.15 m, the paper's) of the plane
through the three other points; its points go to the world by (12) with the odometry pose. Beyond
the paper, the three outer points must also span at least ``min_spread`` of the triangle the aimed
beams give at the measured ranges (:func:`~mitsonar.recon.surfels.scanning.spread_ratio`): four
echoes bunched on one edge (a window frame answering for glass seen obliquely, which returns no
echo) pass the coplanarity test whatever plane they are said to span, and such a surfel, tilted 36
deg on room_glass, pulled a window and the floor into one group.

Plane optimisation (:func:`~mitsonar.recon.surfels.planes.group_surfels`): the paper groups surfels
whose normals agree (cosine similarity); here that is only the first, coarse gate (see the
deviations below). Two surfels share a plane when their normals agree within ``merge_angle`` widened
by ``merge_sigmas`` standard errors of the two normals, and every point of both (four scan points
and the fill points) lies within ``merge_sigmas`` expected errors (``range_sigma``, ``angle_sigma``:
the refinement's weights, below) of the least-squares plane through all of them, and that one
plane fits them no worse than a plane each beyond chance: weighting every point by its expected
error, the chi^2 of the joint plane minus those of the two planes (a likelihood-ratio test, chi^2
with 3 degrees of freedom if they share a plane) stays within the quantile that ``merge_sigmas``
normal deviates cover (14.2 at 3). The last test tells parallel planes a few cm apart: a wall's face
10 cm in front of a window pane has every point within 3 expected errors (3-6 cm each at 3 m and
oblique incidence) of a plane tilted between it and a patch of the pane, but the pane's own points
fit their plane to 5 mm. Connected components chain groups along a wall; a surfel its group
(without it) fails this test on is taken out, the worst first (on room_glass a wall surfel had
chained with each surfel of the window 10 cm behind it and the wall's plane was grown on the pane's,
9-10 cm off). Each group's plane is the least-squares fit (14)(15) of its points: the last right
singular vector of the centred points, oriented towards the sensor positions that saw it. Then,
until nothing changes: every surfel moves to the group whose fitted plane fits all its points (the
same three tests against the group without it), the best by its worst point's distance over its
expected error, or to a group of its own if none does, and groups whose points fit one plane
together merge. A group whose normal is poorly determined (standard error above
``max_normal_error``: a small noisy surfel that fits no other group, or a few small ones close
together) claims no image region, so no plane is grown from it
(:func:`~mitsonar.recon.surfels.growing.grow_planes`; its points still enter the fits).

Deviations from the paper, measured on a rendered room corner (two walls and a floor, three
poses 2.8 m away, 'paper' preset; per scan point, measured against the true range along the
beam): the echo of a scan point always comes from the face it is aimed at (all 25 reflectors of
the paper model, and all rays within 4 deg of the axis of the physical model, hit that face, the
nearest crease being 17 cm or more away), so neighbouring faces are not the error source. The
error is the footprint's: at incidence theta the footprint spans r w tan(theta) in range
(10-25 cm on the walls at 20-47 deg, 50-65 cm on the floor at 73-75 deg) and the strongest
envelope peak picks a part of it, as if the echo came from a direction about 1 deg off the axis:
points lie 0-3.5 cm off their plane on the walls (random sign), +3.2-3.8 cm on the floor (the
nearer part of a grazing footprint echoes louder); the physical model's diffuse speckle is worse
(up to 6 cm off on the walls, 25 cm range errors on the floor). Four such points per surfel and
three surfels per face give normals 1-3 deg off. Hence:

* Fill pings (:func:`~mitsonar.recon.surfels.scanning.fill_pixels`): each registered surfel is
  pinged again at up to ``max_fill`` pixels on a grid of one footprint (``fill_spacing``, 5 deg)
  inside its triangle, at least ``fill_margin`` (3 deg: half a footprint plus the line's error) from
  its edges, so no footprint reaches across a crease; these beams are re-aimed at the plane of the
  surfel's four measured points (:func:`~mitsonar.recon.lines.scan_directions` with a depth),
  removing the 7.5 cm camera-array parallax. Fill echoes farther than ``verify_threshold`` from the
  surfel's plane are dropped. They join the group fits (14)(15) but not the verification.
* Grouping by point fit (:func:`~mitsonar.recon.surfels.planes.group_surfels`): the paper compares
  the surfels' normals. A surfel's normal is determined by its points' errors over its extent: the
  standard error is atan(s / S2), s the per-point error (from the fit's residuals, at least the
  expected error) and S2 the points' second singular value. A small surfel with 1-3 cm point errors
  has a normal 7-13 deg off (10-17 deg standard error) and formed a group of its own, which claimed
  an image region and grew a wrong plane, or split a wall so that a shadow line across it was kept
  (the shadow test with the edge at 0.9 m: now removed in all three poses, normals 0.7-1.4 deg off).
  Judged by whether its points fit the wall's plane within their expected errors, with the normal
  test widened by the normals' standard errors, it joins the wall; a surfel on another face has
  points tens of centimetres off the plane and a normal 90 deg off, and stays apart. On
  scenes/room_glass (8 poses, 800 px, 'paper' preset: five registered surfels, all on the two
  windows) this puts the third surfel on the east window into that window's group, yet the map gets
  worse (15.3 % of the sampled points within 2 cm instead of 24.8 %): most of it comes from one pose
  whose 13 segments close no region, so its whole crop is grown onto the nearest claiming plane, and
  the window's plane, fitted to 12 points on a strip 37 cm tall, is tilted 2.5 deg (grouping cannot
  fix either).
* Joint refinement (:func:`~mitsonar.recon.surfels.planes.refine_planes`): the planes are refitted
  together, minimising robust (soft L1) residuals of (a) every point's distance from its plane over
  its expected error sqrt(``range_sigma``^2 + (r tan(``angle_sigma``) sin(theta))^2), which
  down-weights grazing points, and (b) for every detected segment with a different plane on each
  side (a crease, :func:`~mitsonar.recon.surfels.growing.segment_sides`), the pixel distance of its
  ends from the image of the line where the two planes meet, over ``crease_sigma``. The camera fixes
  where planes meet (the paper's "planes expand until they intersect ... constrained by the line
  segments", used here as a constraint on the fit), the sonar fixes the depth and the rest of the
  orientation. Constraints whose residual on the sonar-only planes exceeds ``crease_gate`` (an
  occlusion edge, a segment between unrelated planes) are left out. On the corner this gives normals
  within 0.7 deg and the corner within 1 cm (tests/recon/test_surfels.py); the pose meshes are then
  grown again on the refined planes. ``max_fill=0, refine=False`` is the paper's method.

Growing (:func:`~mitsonar.recon.surfels.growing.region_labels`,
:func:`~mitsonar.recon.surfels.growing.grow_planes`): the detected segments, extended by
``barrier_extension`` and drawn ``barrier_width`` thick, cut the field-of-view crop into 4-connected
regions. Every registered surfel (from any pose) whose scan points project into a region claims it
for its group. Each claimed region's pixels (on a ``stride`` grid) are back-projected along the
camera rays onto every claiming plane and the *nearest* intersection in front of the camera (within
``max_range``) is kept: inside a room (concave corners) the nearest of two planes is the visible
one, so a region that leaks across an undetected crease is still split at the planes' intersection
("planes expand until they intersect or exceed the field of view, constrained by the line
segments"). Convex edges seen from outside (a box corner) would need the farthest instead; this
implementation assumes room interiors. The mesh of a pose joins grid neighbours on the same plane
into triangles; the map is the union over poses, rebuilt on the global planes.

Junctions (:func:`~mitsonar.recon.surfels.growing.barriers`): before the segments become
barriers, the pieces of one line are bridged across gaps up to ``bridge_gap`` of the image width,
and an end that stops at most ``junction_gap`` pixels short of a junction with another segment or
with the crop's border is extended to it (:func:`~mitsonar.recon.lines.close_junctions`); FLD
often stops a few pixels short of a window's corner, and the whole crop leaked through that gap
onto the window's plane. A bridged line reaches further, up to its own length (at most
``bridge_gap`` of the width): on varied_1 a wall-floor crease found over 400 px stopped 130 px
short of the crop's side and the floor's region leaked round its end onto the wall.

Check pings (:func:`~mitsonar.recon.surfels.growing.check_pose`,
:func:`~mitsonar.recon.surfels.growing._support`; an addition beyond the paper, ``check_spacing=0``
turns it off): a plane grown over a whole region asserts depths the sonar never measured. After the
first map, every pose pings its grown planes on a ``check_spacing`` (5 deg) grid, ``fill_margin``
away from the lines, aimed at the grown plane's point. A check echo on a plane claiming its region
(within ``merge_sigmas`` expected errors) joins that plane's fit
(:func:`~mitsonar.recon.surfels.map._check_points`; assignment and refit repeat until the set
settles), and the map is grown again, each plane only where the nearest evidence in the same region
(projected surfel points and heard check pings) confirms it; a check without an echo (a smooth wall
seen obliquely reflects away from the array) says nothing. On scenes/room_glass (8 poses, 800 px,
'paper' preset) a window plane fitted to 12 points on a 37 cm strip was 2.4 deg off and grown over a
whole crop: 15.3 % of the sampled points within 2 cm; junction closing, the check points in the fits
and the gating bring it to 99.8 % (measured on raw 32 spp images). The check echoes of every pose
count in every image (:func:`~mitsonar.recon.surfels.growing.heard_checks`).

Plane hypotheses (:func:`~mitsonar.recon.surfels.map.refuted_groups`): four echoes near a convex
corner fit some plane through it whatever the faces are; on varied_3 surfels bunched at a
cabinet's corner (front, side and the wall behind) from four poses agreed on a plane 45 deg off
every face, and it was grown over the wall (4.7 % of the map within 2 cm). A group is refuted
when at least ``min_refutations`` check echoes in the regions it claims lie on none of the
claiming planes and outnumber those on it; its surfels are dropped and the map is built again.
A refuted group of several surfels is split first and its surfels judged alone, so a good surfel
that was joined by wrong ones survives them (varied_7: a window pane's surfel, joined by two that
straddled the 10 cm reveal in front of it, on a plane tilted 14 deg; the pane went unmapped).
A surfel whose own points misfit its group's final plane (their chi^2 in expected errors,
:func:`~mitsonar.recon.surfels.map.misfit_members`) is judged alone too: grouping tests two
surfels against a plane through both, which two small patches far apart always admit, and only
the final plane, pinned by the check echoes, shows that one of them lies behind it (varied_1: a
pane's surfel on the wall's plane 10 cm in front of it).
A poorly determined plane (a lone surfel's, most often) claims nothing but stays a hypothesis
(:attr:`~mitsonar.recon.surfels.growing.PoseMesh.hypotheses`): the check pings are aimed over its
region (``tentative`` growth), the echoes on it join its fit, and the normal's standard error is
recomputed with them, so a plane the sonar confirms over a wide area claims its region (on
varied_1 the floor, held by one surfel, 16 deg standard error alone, 1.4 deg with its checks).

The floor the robot drives on is known: its wheels stand on z = 0 of the world frame
(``Pose.sensor_on_robot``). After the refinement, a group whose surfel, fill and check echoes fit
that plane as well as their own (the merging tests, the ground taken as a group known exactly,
:func:`~mitsonar.recon.surfels.planes.on_ground`) is held to it, with no normal error
(``ground``; beyond the paper). A floor fitted to echoes at grazing incidence, whose expected
errors are cm, and pulled by the creases of the walls around it came out tilted: on varied_9
(region surfels, 20 s) 0.6 deg, 62 % of its 75 000 points within 2 cm, though its echoes lay
within 2 mm of the floor; held, 97.5 %. The surfels whose own echoes fit the ground are grouped
among themselves, apart from the others: a small floor surfel's normal is poorly
determined, so it fits other planes too, and on varied_5 (whole drive) one 5 cm floor surfel
joined a surfel 4.5 m away whose echoes lay on a sofa's edges, on a plane tilted 10 deg off the
floor that held 17 % of the map a median 87 cm off.

Region surfels (:func:`~mitsonar.recon.surfels.growing.region_triangles`,
:func:`~mitsonar.recon.surfels.scanning.add_surfels`; an addition beyond the paper, off by
default, ``region_surfels=True`` turns it on): a triangle surfel needs two segments meeting at a
junction, and a floor bounded by one wall-floor crease and the crop's border, or a wall whose
corners are out of view, has none. After a pose's own surfels are pinged, every region of its
image that no plane claims (no registered surfel's points, of any pose so far, fall in it) gets
one candidate: its three outer scan pixels spread over the part of the region at least
``fill_margin`` from every barrier (the pixel farthest from that part's centroid, the pixel
farthest from it, the pixel farthest from the line through both), pinged there and at their
centroid, verified, filled and grouped like the others. On room_glass's first 8 s (800 px,
'paper' preset) 0.7 % of the observable floor had been inside a candidate (15.8 % was in the
sonar's view and range) and 0.2 % was mapped; with region surfels 7.6 % is mapped, and the map
covers 10.3 % of the observable ground truth instead of 5.5 %, 100.0 % of its points within
2 cm (``experiments/surfel_coverage.py``). It is off by default because a floor held by region
surfels alone, seen at grazing incidence (its echoes come from the near part of each footprint,
cm off the plane, and no crease constrains it), can be tilted: on varied_9 a floor plane of two
region surfels was 0.8 deg off and 2.2 cm low, grown over 163 000 points (95.8 -> 57.9 % within
2 cm).

Shadow lines (paper Fig. 8a, :func:`~mitsonar.recon.surfels.growing.shadow_segments`): a segment
whose two sides (sampled ``shadow_offset`` pixels across it) both lie in regions claimed by the same
single plane group is not a structural edge (a cast shadow, a texture edge): it is removed, the
surfels built on it are dropped, and the regions are recomputed without it.

Pixel coordinates follow :mod:`mitsonar.recon.lines` (pixel centres at half-integers).

Modules, one per concept, in the order the data flows; each imports only those above it:

* :mod:`~mitsonar.recon.surfels.settings`: :class:`SurfelSettings`, read by every stage.
* :mod:`~mitsonar.recon.surfels.planes`: plane fits (14)(15), plane groups and the joint
  refinement, on point arrays alone (no image, no sonar).
* :mod:`~mitsonar.recon.surfels.scanning`: one pose's image, surfels, pings (four, then fill),
  verification and registration (12): a :class:`PoseScan`.
* :mod:`~mitsonar.recon.surfels.growing`: regions between the segments, planes grown in one
  pose's image (a :class:`~mitsonar.recon.surfels.growing.PoseMesh`), check pings, shadow lines.
* :mod:`~mitsonar.recon.surfels.map`: all poses together: a :class:`SurfelMap`;
  :func:`map_surfels` runs the whole pipeline.
* :mod:`~mitsonar.recon.surfels.outputs`: summary, figure and the written files.

The cut follows the types each stage makes: point arrays -> :class:`PlaneGroups`, an image and
pings -> :class:`PoseScan`, a scan and the groups -> ``PoseMesh``, all poses -> :class:`SurfelMap`
-> files. The plane geometry comes before the scanning because a pose's verification and fill
pings fit planes too. The lines and triangle surfels of the image are
:mod:`mitsonar.recon.lines`. The check pings are fired beside ``PoseMesh`` (they sample the grown
planes) and read back by the growth (``_support``); joining them to the plane fits across poses
(``_check_points``) belongs to the map. The names other code imports are re-exported here.
"""

from mitsonar.recon.surfels.growing import grow_planes, region_labels, shadow_segments
from mitsonar.recon.surfels.map import SurfelMap, map_surfels, map_surfels_along
from mitsonar.recon.surfels.outputs import plane_colours, save_surfel_map, summary
from mitsonar.recon.surfels.planes import PlaneGroups, fit_plane, group_surfels
from mitsonar.recon.surfels.scanning import CheckPings, PoseScan, tone_map, verify
from mitsonar.recon.surfels.settings import SurfelSettings

__all__ = ["CheckPings", "fit_plane", "group_surfels", "grow_planes", "map_surfels",
           "map_surfels_along",
           "plane_colours", "PlaneGroups", "PoseScan", "region_labels", "save_surfel_map",
           "shadow_segments", "summary", "SurfelMap", "SurfelSettings", "tone_map", "verify"]
