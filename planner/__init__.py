"""qsplan planner: quasistatic planar contact-mode prediction after Trinkle & Zeng (1994).

NumPy/SciPy only; imports no simulator and no plotting library.
"""

from planner.errors import DegenerateError, FileFormatError, InputError, QsplanError
from planner.model.geometry import wrench_matrix
from planner.model.layout import FeatureContact, Motion, Surface, finger, surface
from planner.model.modes import Mode, candidate_count, enumerate_modes
from planner.model.system import Contact, JointControl, System
from planner.model.workpiece import WorkpieceGeometry
from planner.predict.feasibility import Prediction, Status, feasible_modes
from planner.predict.stages import FeasibleMode

__all__ = [
    "Contact",
    "DegenerateError",
    "FeasibleMode",
    "FeatureContact",
    "FileFormatError",
    "InputError",
    "JointControl",
    "Mode",
    "Motion",
    "Prediction",
    "QsplanError",
    "Status",
    "Surface",
    "System",
    "WorkpieceGeometry",
    "candidate_count",
    "enumerate_modes",
    "feasible_modes",
    "finger",
    "surface",
    "wrench_matrix",
]
