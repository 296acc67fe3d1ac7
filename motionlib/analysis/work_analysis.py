"""The whole analysis of a recording as one call: states, time distribution, joint usage (and replanning).

:func:`analyze_recording` is what ``motionlib analyze`` runs: it reads the recording, splits it
into the work-cycle states of 003 Table 3.1 (:mod:`.segmentation`), measures how the time is
spent and how the joints are used (:mod:`.work_stats`) and, when asked, replans every
recorded move (:mod:`.replanning`, 003 Paper I).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..model.kinematics import Crane
from ..model.scene import Scene
from .column_map import ColumnMap
from .recording import Recording, read_recording
from .segmentation import Segmentation, SegmentationOptions, segment_recording
from .signals import SPEED_TOLERANCE, joint_speed_ratio
from .work_stats import JointUsage, StateTime, joint_activity, joint_usage, time_distribution


@dataclass
class WorkAnalysis:
    """Result of :func:`analyze_recording`.

    Attributes
    ----------
    recording : Recording
    segmentation : Segmentation
    table : list of StateTime
        003 Table 3.1's columns per state.
    usage : JointUsage
        003 Fig. 3.4's shares.
    activity : ndarray of bool, shape (N, 4)
        Active joint functions per sample (003 Fig. 3.3).
    speed_ratio : ndarray, shape (4,)
        Each joint's largest recorded speed as a fraction of the crane file's limit
        (:func:`~motionlib.analysis.signals.joint_speed_ratio`).
    """

    recording: Recording
    segmentation: Segmentation
    table: list[StateTime]
    usage: JointUsage
    activity: np.ndarray
    speed_ratio: np.ndarray

    @property
    def notes(self) -> list[str]:
        """What the reading and the segmentation changed or left out, and a recording faster than the crane."""
        notes = [*self.recording.notes, *self.segmentation.notes]
        j = int(np.argmax(self.speed_ratio))
        if self.speed_ratio[j] > 1.0 + SPEED_TOLERANCE:
            notes.append(f"the recording moves q{j + 1} at {self.speed_ratio[j]:.2f} times the speed limit of crane "
                         f"{self.recording.crane.name!r} (tolerance {1.0 + SPEED_TOLERANCE:g}): faster than the crane "
                         "file allows; check the crane file and the recording's units")
        return notes

    def to_dict(self) -> dict[str, Any]:
        """Plain data for ``--json`` (NaN as None)."""
        rec = self.recording
        return {
            "recording": rec.source,
            "crane": rec.crane.name,
            "scene": rec.scene.name if rec.scene is not None else None,
            "duration_s": rec.duration_s,
            "samples": int(rec.t.size),
            "grapple_events": len(rec.events),
            "speed_noise_m_s": self.segmentation.noise_m_s,
            "thresholds_m_s": dict(zip(("v_on", "v_off", "v_rest"), self.segmentation.thresholds, strict=True)),
            "joint_speed_ratio": self.speed_ratio.tolist(),
            "notes": self.notes,
            "states": [
                {"state": r.state.value, "label": r.state.label, "n": r.n,
                 "median_s": None if np.isnan(r.median_s) else r.median_s, "total_s": r.total_s, "share": r.share}
                for r in self.table
            ],
            "joint_usage": {
                "from_sticks": self.usage.from_sticks,
                "overall": self.usage.overall.tolist(),
                "manipulation": [None if np.isnan(v) else v for v in self.usage.manipulation.tolist()],
                "per_joint": self.usage.per_joint.tolist(),
            },
            "segments": [
                {"state": s.state.value, "t0": s.t0, "t1": s.t1} for s in self.segmentation.segments
            ],
        }


def analyze_recording(
    recording: str | Path | Recording,
    *,
    crane: Crane | None = None,
    scene: Scene | None = None,
    options: SegmentationOptions | None = None,
    columns: ColumnMap | None = None,
) -> WorkAnalysis:
    """Read and analyse a recording of crane work (see the module docstring).

    Parameters
    ----------
    recording : str, Path or Recording
        A recording file (docs/recording-format.md) or a recording already read.
    crane, scene : Crane, Scene, optional
        Override those the file names.
    options : SegmentationOptions, optional
        The segmentation's cut-off values.
    columns : ColumnMap, optional
        How to read a CSV file's columns (:mod:`.column_map`).
    """
    rec = recording if isinstance(recording, Recording) else read_recording(recording, crane, scene, columns)
    seg = segment_recording(rec, options)
    activity = joint_activity(rec)
    ratio = joint_speed_ratio(rec.crane, rec.t, rec.q).max(axis=0)
    return WorkAnalysis(rec, seg, time_distribution(seg, rec.duration_s), joint_usage(rec, seg, activity), activity,
                        ratio)
