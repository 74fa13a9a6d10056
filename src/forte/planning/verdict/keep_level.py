"""The verdict's ``keep_level`` requirement (``path.keep_level``, :mod:`forte.planning.tasks.keep_level`):
the tool axis within ``max_tilt`` of the world axis at every sample of the plan, the waypoints and
the executed spline between them (:mod:`forte.planning.verdict.motion_samples`), on the exact angle

    ``tilt_k = arccos(w . R_k a)``  (Pinocchio's forward kinematics of the sample),

which the NLP keeps at its waypoints by the smooth ``w . R a >= cos(max_tilt)``
(:mod:`forte.planning.nlp.keep_level_rows`): between waypoints only this check sees it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from forte.planning.tasks.keep_level import tilt_angles
from forte.planning.verdict.requirement_base import Context, Measure, Requirement

#: Tilt (deg) the executed motion may show beyond ``max_tilt``: the rows hold at the waypoints to
#: IPOPT's tolerance (a cosine within 1e-8 is a few microradians off near a 10-degree limit).
KEEP_LEVEL_SLACK_DEG = 1e-4


@dataclass(frozen=True)
class TiltLimit(Requirement):
    """The end effector's tool axis within ``max_tilt`` (deg) of the world axis at every sample;
    nothing for a task without ``keep_level``."""

    name: ClassVar[str] = "keep_level"

    def measures(self, ctx: Context) -> list[Measure]:
        keep = ctx.keep_level
        if keep is None:
            return []
        tilt = np.degrees(tilt_angles(keep, ctx.samples.ee[:, :3, :3]))
        return [Measure(tilt, float(np.degrees(keep.max_tilt)) + KEEP_LEVEL_SLACK_DEG, "deg",
                        f"the end effector's {keep.tool_name} axis tilts from world {keep.world_name} "
                        "beyond max_tilt_deg")]
