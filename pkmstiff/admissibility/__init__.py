"""Admissibility layer: the checks of spec App. B with reason codes, collision geometry and the pose pipeline
(IK, Jacobians, joint angles and every check for arrays of poses)."""

from pkmstiff.admissibility.checks import ALL_CHECKS, Admissibility, CheckResult, Reason, reason_names
from pkmstiff.admissibility.pipeline import PoseEvaluation, check_admissibility, evaluate_poses

__all__ = ["ALL_CHECKS", "Admissibility", "CheckResult", "PoseEvaluation", "Reason", "check_admissibility",
           "evaluate_poses", "reason_names"]
