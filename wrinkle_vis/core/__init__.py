"""The wrinkle model in numpy and scipy only (no VTK, PyVista or Qt: a test enforces it)."""

from .equations import (
    anisotropy,
    attenuation,
    bulge_height,
    compression,
    compression_operator,
    edge_shrinkage,
    half_period,
    periodic_coordinate,
    shape_function,
)
from .expressions import Expression, paper_expressions
from .face import FIELD_NAMES, FaceModel, FaceState
from .fields import FIELDS, FieldSpec, register_field
from .files import OutputPathError, WriteError
from .layout import Layout, LayoutError, load_layout, save_layout
from .mesh import MeshError, MeshReport, TriangleSurface, subdivide
from .muscle import Muscle, MuscleParameterError, MuscleRegion, waters_radial
from .muscles import LinearMuscle, SheetMuscle
from .params import Parameter, parameter
from .registry import (
    MusclePluginWarning,
    UnknownMuscleTypeError,
    get_muscle_type,
    muscle_from_dict,
    muscle_types,
    register_muscle_type,
)
from .sampling import UndersampledWrinklesWarning, undersampled_muscles, warn_undersampled
from .simulation import Simulation
from .skin import SkinMaterial
from .tracks import (
    ChannelMap,
    Track,
    TrackError,
    TrackMapping,
    TrackWarning,
    default_mapping,
    read_track,
    write_track,
)

__all__ = [
    "ChannelMap",
    "FIELDS",
    "FIELD_NAMES",
    "Expression",
    "FaceModel",
    "FaceState",
    "FieldSpec",
    "Layout",
    "LayoutError",
    "LinearMuscle",
    "MeshError",
    "MeshReport",
    "Muscle",
    "MuscleParameterError",
    "MusclePluginWarning",
    "MuscleRegion",
    "OutputPathError",
    "Parameter",
    "SheetMuscle",
    "Track",
    "TrackError",
    "TrackMapping",
    "TrackWarning",
    "Simulation",
    "SkinMaterial",
    "TriangleSurface",
    "UndersampledWrinklesWarning",
    "UnknownMuscleTypeError",
    "WriteError",
    "anisotropy",
    "attenuation",
    "bulge_height",
    "compression",
    "compression_operator",
    "default_mapping",
    "edge_shrinkage",
    "get_muscle_type",
    "half_period",
    "load_layout",
    "muscle_from_dict",
    "muscle_types",
    "paper_expressions",
    "parameter",
    "periodic_coordinate",
    "read_track",
    "register_field",
    "register_muscle_type",
    "save_layout",
    "shape_function",
    "subdivide",
    "undersampled_muscles",
    "warn_undersampled",
    "waters_radial",
    "write_track",
]
