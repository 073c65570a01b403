"""What a model kind's kinematics return: the tool tip (:class:`ModelTip`) and points fixed
on the table (:class:`ModelPoints`), with their Jacobians, in the frame asked for."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vecpin.errors import InputError

FRAMES = ("base", "workpiece")


class ModelTip(NamedTuple):
    """tip (N,3) [m] in the frame asked for; J_b (N,3,P); J_q (N,3,n) total d tip / d q;
    tool_dir (N,3) unit tool direction; rotation (N,3,3): tool link orientation, which
    is d tip / d target offset (offsets are in the tool link frame)."""

    tip: np.ndarray
    J_b: np.ndarray | None
    J_q: np.ndarray | None
    tool_dir: np.ndarray
    rotation: np.ndarray | None = None


class ModelPoints(NamedTuple):
    """Points fixed in the model's workpiece frame (table nests), in the base frame:
    xyz (N,3) [m]; J_b (N,3,P); J_q (N,3,n); J_p (N,3,3) d xyz / d p_wp."""

    xyz: np.ndarray
    J_b: np.ndarray | None
    J_q: np.ndarray | None
    J_p: np.ndarray | None


def check_frame(frame: str) -> str:
    if frame not in FRAMES:
        raise InputError(f"frame '{frame}': 'base' (the machine frame a floor tracker sees) or 'workpiece' "
                         "(the table frame compensation corrects)")
    return frame
