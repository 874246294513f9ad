"""mitsonar: a 40 kHz 5x5 sparse ultrasonic phased array and a camera, simulated on Mitsuba 3.

Importing mitsonar selects a working libLLVM for Dr.Jit (see ``mitsonar._native``) before
Dr.Jit is loaded. SI units everywhere; angles in radians.
"""

from ._native import configure_llvm

configure_llvm()

from .array import ArrayGeometry, ArrayLayout  # noqa: E402
from .frames import (Pose, angles_from_direction, direction_from_angles,  # noqa: E402
                     direction_from_fov_angles, fov_angles)
from .camera import CameraModel, CameraRenderer  # noqa: E402
from .dataset import DatasetSpec, open_dataset, render_dataset  # noqa: E402
from .materials import PRESETS, AcousticMaterial, preset  # noqa: E402
from .medium import Medium  # noqa: E402
from .ofdm import OfdmSonar, Schedule, code_set  # noqa: E402
from .processing import Detection, DetectionSettings  # noqa: E402
from .scene import AcousticScene, SceneError, load_scene  # noqa: E402
from .signals import Pulse  # noqa: E402
from .sonar import Ping, Scan, Sonar, SonarConfig  # noqa: E402
from .tracer import TraceSettings  # noqa: E402
from .trajectory import OdometryDrift, Trajectory  # noqa: E402
from .transducer import Transducer  # noqa: E402
from .voxelmap import VoxelMap, VoxelMapSettings, colourise  # noqa: E402

__all__ = ["AcousticMaterial", "AcousticScene", "ArrayGeometry", "ArrayLayout", "CameraModel",
           "CameraRenderer", "DatasetSpec", "Detection", "OdometryDrift", "Trajectory",
           "open_dataset", "render_dataset", "OfdmSonar", "Schedule", "code_set", "VoxelMap",
           "VoxelMapSettings", "colourise",
           "DetectionSettings", "Medium", "PRESETS", "Ping", "Pose", "Pulse", "Scan", "SceneError",
           "Sonar", "SonarConfig", "TraceSettings", "Transducer", "angles_from_direction",
           "direction_from_angles", "direction_from_fov_angles", "fov_angles", "load_scene",
           "preset"]
__version__ = "0.1.0"
