"""mitsonar: a 40 kHz 5x5 sparse ultrasonic phased array and a camera, simulated on Mitsuba 3.

Importing mitsonar selects a working libLLVM for Dr.Jit (see ``mitsonar._native``) before
Dr.Jit is loaded. SI units everywhere; angles in radians.
"""

from mitsonar._native import configure_llvm

configure_llvm()

from mitsonar.physics.array import ArrayGeometry, ArrayLayout  # noqa: E402
from mitsonar.frames import (Pose, angles_from_direction, direction_from_angles,  # noqa: E402
                     direction_from_fov_angles, fov_angles)
from mitsonar.sensors.camera import CameraModel, CameraRenderer  # noqa: E402
from mitsonar.data.dataset import DatasetSpec, open_dataset, render_dataset  # noqa: E402
from mitsonar.physics.materials import PRESETS, AcousticMaterial, preset  # noqa: E402
from mitsonar.physics.medium import Medium  # noqa: E402
from mitsonar.sensors.ofdm_sonar import OfdmSonar  # noqa: E402
from mitsonar.sensors.imaging_sonar import ImagingSonar  # noqa: E402
from mitsonar.signal.ofdm import Schedule, code_set  # noqa: E402
from mitsonar.signal.detection import Detection, DetectionSettings  # noqa: E402
from mitsonar.scene.loading import AcousticScene, SceneError, load_scene  # noqa: E402
from mitsonar.physics.waveforms import Chirp, Pulse  # noqa: E402
from mitsonar.sensors.sonar import Ping, Scan, Sonar, SonarConfig  # noqa: E402
from mitsonar.trace.settings import TraceSettings  # noqa: E402
from mitsonar.sensors.trajectory import OdometryDrift, Trajectory  # noqa: E402
from mitsonar.physics.transducer import Transducer  # noqa: E402
from mitsonar.recon.voxelmap import VoxelMap, VoxelMapSettings, colourise  # noqa: E402

__all__ = ["AcousticMaterial", "AcousticScene", "ArrayGeometry", "ArrayLayout", "CameraModel",
           "CameraRenderer", "Chirp", "DatasetSpec", "Detection", "OdometryDrift", "Trajectory",
           "open_dataset", "render_dataset", "OfdmSonar", "Schedule", "code_set", "VoxelMap",
           "VoxelMapSettings", "colourise", "ImagingSonar",
           "DetectionSettings", "Medium", "PRESETS", "Ping", "Pose", "Pulse", "Scan", "SceneError",
           "Sonar", "SonarConfig", "TraceSettings", "Transducer", "angles_from_direction",
           "direction_from_angles", "direction_from_fov_angles", "fov_angles", "load_scene",
           "preset"]
__version__ = "0.1.0"
