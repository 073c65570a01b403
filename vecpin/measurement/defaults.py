"""The noise model's default values (SI), in a module that imports nothing heavy: the
command line shows them in its help without loading the kinematics."""
from __future__ import annotations

import math

DEFAULT_LINEAR_SIGMA = 0.006e-3            # m, axis repeatability (Paper I measured 18 µm mean incl. the tracker)
DEFAULT_ROTARY_SIGMA = math.radians(0.0015)  # rad
DEFAULT_CARTESIAN_SIGMA = 0.02e-3          # m, static tracker variance (Table 3.2 uses 25 µm)
DEFAULT_BALLBAR_SIGMA = 2.5e-6             # m, telescoping ball bar (Table 3.2: 1e-8 in^2)
