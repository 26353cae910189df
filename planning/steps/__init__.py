"""Step planning (seed: capture-point step path): steering, gaits, reference and potential step paths, LIP capture
points, and selection by Eq. 1."""

from planning.steps.gait import GAIT_NAMES, GAITS, Gait, GaitClock, Schedule, get_gait
from planning.steps.lip import (
    GRAVITY_MPS2,
    PathBatch,
    TouchdownStates,
    capture_point,
    capture_point_relative,
    lip_omega,
    lip_predict,
    predict_batch,
    predict_touchdown_states,
    project_to_support,
    state_omega,
)
from planning.steps.planner import StepPlanner, StepPlannerParams
from planning.steps.potential import Constraints, Octagon, PotentialParams, Screening, potential_step_paths, screen_paths
from planning.steps.reference import ReferenceParams, body_motion, reference_step_path
from planning.steps.select import (
    Selection,
    SelectionParams,
    WeightPresets,
    Weights,
    score_components,
    score_path,
    score_paths,
    select_step_path,
)
from planning.steps.state import (
    BodyMotion,
    SteeringCommand,
    StepMaps,
    StepPath,
    StepRobot,
    WalkState,
    standing_state,
)
from planning.steps.steering import SteeringFilter, SteeringParams

__all__ = [
    "GAITS",
    "GAIT_NAMES",
    "GRAVITY_MPS2",
    "BodyMotion",
    "Constraints",
    "Gait",
    "GaitClock",
    "Octagon",
    "PathBatch",
    "PotentialParams",
    "ReferenceParams",
    "Schedule",
    "Screening",
    "Selection",
    "SelectionParams",
    "SteeringCommand",
    "SteeringFilter",
    "SteeringParams",
    "StepMaps",
    "StepPath",
    "StepPlanner",
    "StepPlannerParams",
    "StepRobot",
    "TouchdownStates",
    "WalkState",
    "WeightPresets",
    "Weights",
    "body_motion",
    "capture_point",
    "capture_point_relative",
    "get_gait",
    "lip_omega",
    "lip_predict",
    "potential_step_paths",
    "predict_batch",
    "predict_touchdown_states",
    "project_to_support",
    "reference_step_path",
    "score_components",
    "score_path",
    "score_paths",
    "screen_paths",
    "select_step_path",
    "standing_state",
    "state_omega",
]
