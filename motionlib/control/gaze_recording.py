"""A recorded head stream with its operator's head-to-gaze calibration, and the selection it gives (003 Paper III).

A *gaze file* (YAML, format in docs/commands.md) holds what the machine knows when the operator
gives a gaze-selected command: the head orientation stream of the IMU on the operator's head
(``samples``: time, head yaw, head pitch), the operator's calibrated head-to-gaze model
(:class:`~motionlib.control.gaze.HeadGazeModel`: ``model`` with ``A``, ``b``, ``residual_cov``,
``n_samples``; or ``calibration``: measured head angles while looking at known points, fitted with
:meth:`HeadGazeModel.calibrate <motionlib.control.gaze.HeadGazeModel.calibrate>`), the eye point and the
height of what the operator looks at. The command is given at the stream's last sample:
:meth:`GazeRecording.estimate` is :func:`~motionlib.control.gaze.estimate_target` at that head
orientation, and :func:`select_by_gaze` ranks the library's trajectories for the estimate with the
estimate's covariance in 003 eq. 5.7 (the ``robust`` utility).

Reading is strict (:class:`motionlib.schema.Section`): unknown and duplicate keys, wrong types, NaN,
times that do not increase, angles or positions outside their plausible ranges, a covariance that is
not symmetric positive semi-definite, and an eye point not above the height looked at are errors
naming the file and the dotted key.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import COORDINATE_M, Plausible, short
from ..errors import InputError, NoSelectionError
from ..library.selection import SelectionResult, Utility
from ..library.store import Library
from ..schema import Section, check_count, check_number_list, load_yaml, read_plausibility
from .gaze import GazeEstimate, HeadGazeModel, estimate_target, gaze_angles

#: Head yaw (rad): a full turn either way.
YAW_RAD = Plausible(-2 * math.pi, 2 * math.pi, -1e3, 1e3, "rad")
#: Head pitch (rad): between straight down and straight up.
PITCH_RAD = Plausible(-math.pi / 2, math.pi / 2, -math.pi / 2, math.pi / 2, "rad")
#: Entries of the model's gain ``A`` (gaze per head angle).
GAIN = Plausible(-10.0, 10.0, -1e3, 1e3, "")
#: The model's offset ``b`` (rad).
OFFSET_RAD = Plausible(-1.0, 1.0, -math.pi, math.pi, "rad")
#: Diagonal of the residual covariance (rad^2): up to a 1-rad standard deviation.
VARIANCE_RAD2 = Plausible(0.0, 1.0, 0.0, 100.0, "rad^2")
#: Sample times (s): up to a day.
TIME_S = Plausible(0.0, 86_400.0, 0.0, 1e7, "s")
#: Height of the tip target above the point looked at (m).
TIP_ABOVE_M = Plausible(0.0, 10.0, -1e3, 1e3, "m")
#: Largest number of stream samples (a day at 100 Hz) and of calibration pairs.
MAX_SAMPLES = 10_000_000
MAX_CALIBRATION = 10_000


@dataclass(frozen=True)
class GazeRecording:
    """A validated gaze file (see the module docstring).

    Attributes
    ----------
    eye : ndarray, shape (3,)
        The operator's eye point (m, base frame).
    z_look : float
        Height (m) of what the operator looks at.
    tip_above_m : float
        The tip target's height above the point looked at (m).
    model : HeadGazeModel
    t : ndarray, shape (n,)
        Sample times (s), strictly increasing.
    head : ndarray, shape (n, 2)
        Head yaw and pitch (rad).
    source : str or None
    """

    eye: np.ndarray
    z_look: float
    tip_above_m: float
    model: HeadGazeModel
    t: np.ndarray
    head: np.ndarray
    source: str | None = None

    @classmethod
    def load(cls, path: str | Path) -> GazeRecording:
        """Read a gaze file.

        Raises
        ------
        ModelFileError
            Missing or malformed file; the message names the file and the key.
        """
        path = Path(path)
        return cls.from_dict(load_yaml(path), str(path))

    @classmethod
    def from_dict(cls, data: Any, file: str = "<gaze>") -> GazeRecording:
        """Validate the mapping of a gaze file (see :meth:`load`)."""
        top = Section(data, file)
        read_plausibility(top)
        eye = np.array(top.vector("eye", 3, plausible=COORDINATE_M))
        z_look = top.number("z_look", plausible=COORDINATE_M)
        if not z_look < eye[2]:
            top.fail("z_look", f"expected a height below the eye point's z = {eye[2]:g} m, got {z_look:g} m")
        tip_above = top.number("tip_above_m", 0.0, plausible=TIP_ABOVE_M)
        if top.has("model") == top.has("calibration"):
            top.fail("model", "expected exactly one of model (the calibrated parameters) and calibration (samples)")
        model = (
            _read_model(top.section("model"))
            if top.has("model")
            else _read_calibration(top.section("calibration"), eye)
        )
        t, head = _read_samples(top)
        top.done()
        return cls(eye, z_look, tip_above, model, t, head, None if file.startswith("<") else file)

    @property
    def command_head(self) -> np.ndarray:
        """Head yaw and pitch (2,) (rad) when the command is given: the stream's last sample."""
        return self.head[-1]

    def estimate(self) -> GazeEstimate:
        """The target estimate and its covariance at the command (:func:`~motionlib.control.gaze.estimate_target`).

        Raises
        ------
        InputError
            The estimated gaze does not look down to the height looked at.
        """
        return estimate_target(self.model, self.command_head, self.eye, self.z_look, self.tip_above_m)


class GazeSelectionStatus(enum.Enum):
    """Outcome of :func:`select_by_gaze`."""

    OK = "ok"
    NO_ESTIMATE = "no_estimate"  # the estimated gaze does not come down to the height looked at
    NO_SELECTION = "no_selection"  # no library trajectory serves the estimate (the selection's status says why)


@dataclass(frozen=True)
class GazeSelection:
    """Result of :func:`select_by_gaze`.

    Attributes
    ----------
    status : GazeSelectionStatus
    message : str
        One line.
    estimate : GazeEstimate or None
        The target estimate and its covariance (None with NO_ESTIMATE).
    selection : SelectionResult or None
        The ranked trajectories (None with NO_ESTIMATE).
    """

    status: GazeSelectionStatus
    message: str
    estimate: GazeEstimate | None
    selection: SelectionResult | None

    @property
    def ok(self) -> bool:
        return self.status is GazeSelectionStatus.OK

    def raise_for_status(self, where: str = "") -> GazeSelection:
        """Return self when a trajectory was selected, else raise :class:`NoSelectionError` (``where``: a prefix)."""
        if not self.ok:
            raise NoSelectionError(f"{where}: {self.message}" if where else self.message)
        return self

    def checked(self, where: str = "") -> tuple[GazeEstimate, SelectionResult]:
        """The estimate and the selection of a result that selected a trajectory (:meth:`raise_for_status` first)."""
        self.raise_for_status(where)
        if self.estimate is None or self.selection is None:
            raise RuntimeError("a gaze selection that is ok has an estimate and a selection")
        return self.estimate, self.selection


def select_by_gaze(
    library: Library,
    recording: GazeRecording,
    current_q: Any = None,
    utility: Utility | str = Utility.ROBUST,
    **kw: Any,
) -> GazeSelection:
    """Select ``library``'s trajectory for the target the operator looks at (003 section 5.3, eq. 5.7, Paper III).

    The estimate of :meth:`GazeRecording.estimate` is the selection's target; with the ``robust``
    utility its covariance ``J S_g J^T`` is the error model of eq. 5.7 (``covariance`` of
    :meth:`SelectionIndex.select <motionlib.library.selection.SelectionIndex.select>`).

    Parameters
    ----------
    library : Library
    recording : GazeRecording
    current_q : array_like, shape (4,), optional
        Current configuration (rad, rad, rad, m); None skips the start filter (eq. 5.4).
    utility : {"robust", "time", "energy"}
        ``time`` and ``energy`` take the estimate as the target and leave its covariance out.
    **kw
        ``L1``, ``L2``, ``v_manual_m_s``, ``max_candidates`` of the selection.
    """
    util = Utility.parse(utility)
    try:
        estimate = recording.estimate()
    except InputError as exc:
        return GazeSelection(
            GazeSelectionStatus.NO_ESTIMATE, f"no target estimate from the head at the command: {exc}", None, None
        )
    if util is Utility.ROBUST:
        kw["covariance"] = estimate.covariance
    selection = library.select_checked(estimate.p_est, current_q, util.value, **kw)
    where = ", ".join(f"{v:.3f}" for v in estimate.p_est)
    status = GazeSelectionStatus.OK if selection.ok else GazeSelectionStatus.NO_SELECTION
    return GazeSelection(status, f"gaze estimate ({where}) m: {selection.message}", estimate, selection)


def _read_model(sec: Section) -> HeadGazeModel:
    a = _matrix2(sec, "A", GAIN)
    if abs(np.linalg.det(a)) < 1e-9:
        sec.fail("A", f"expected an invertible gain matrix, got {a.tolist()}")
    b = np.array(sec.vector("b", 2, plausible=OFFSET_RAD))
    cov = _matrix2(sec, "residual_cov")
    for i in range(2):
        sec.check_plausible(f"residual_cov[{i}][{i}]", float(cov[i, i]), VARIANCE_RAD2)
    if cov[0, 1] != cov[1, 0] or cov[0, 1] ** 2 > cov[0, 0] * cov[1, 1]:
        sec.fail("residual_cov", f"expected a symmetric positive semi-definite matrix, got {cov.tolist()}")
    n = sec.raw("n_samples")
    if isinstance(n, bool) or not isinstance(n, int) or not 4 <= n <= MAX_CALIBRATION:
        sec.fail(
            "n_samples",
            f"expected the number of calibration samples, an integer in [4, {MAX_CALIBRATION}], got {short(n)}",
        )
    sec.done()
    return HeadGazeModel(a, b, cov, n)


def _read_calibration(sec: Section, eye: np.ndarray) -> HeadGazeModel:
    head = _angle_pairs(sec, "head", MAX_CALIBRATION)
    targets = np.array(
        [
            check_number_list(sec, f"targets[{i}]", p, 3, COORDINATE_M)
            for i, p in enumerate(_rows(sec, "targets", 3, MAX_CALIBRATION))
        ]
    )
    if head.shape[0] != targets.shape[0] or head.shape[0] < 4:
        sec.fail(
            "targets",
            f"expected one target per head sample, at least 4; got {targets.shape[0]} targets and "
            f"{head.shape[0]} head samples",
        )
    sec.done()
    try:
        return HeadGazeModel.calibrate(head, gaze_angles(eye, targets))
    except InputError as exc:
        sec.fail("targets", str(exc))


def _read_samples(top: Section) -> tuple[np.ndarray, np.ndarray]:
    rows = _rows(top, "samples", 3, MAX_SAMPLES)
    data = np.empty((len(rows), 3))
    for i, row in enumerate(rows):
        key = f"samples[{i}]"
        values = check_number_list(top, key, row, 3)
        for j, (what, plausible) in enumerate((("time", TIME_S), ("yaw", YAW_RAD), ("pitch", PITCH_RAD))):
            top.check_plausible(f"{key}[{j}]", values[j], plausible, f"{what}: ")
        if i and not values[0] > data[i - 1, 0]:
            top.fail(f"{key}[0]", f"expected times that increase, got {values[0]:g} s after {data[i - 1, 0]:g} s")
        data[i] = values
    return data[:, 0], data[:, 1:]


def _matrix2(sec: Section, key: str, plausible: Plausible | None = None) -> np.ndarray:
    """A (2, 2) matrix written as two rows of two numbers."""
    rows = _rows(sec, key, 2)
    if len(rows) != 2:
        sec.fail(key, f"expected a 2 x 2 matrix (two rows of two numbers), got {len(rows)} rows")
    return np.array([check_number_list(sec, f"{key}[{i}]", row, 2, plausible) for i, row in enumerate(rows)])


def _angle_pairs(sec: Section, key: str, max_items: int) -> np.ndarray:
    out = []
    for i, row in enumerate(_rows(sec, key, 2, max_items)):
        yaw, pitch = check_number_list(sec, f"{key}[{i}]", row, 2)
        sec.check_plausible(f"{key}[{i}][0]", yaw, YAW_RAD, "yaw: ")
        sec.check_plausible(f"{key}[{i}][1]", pitch, PITCH_RAD, "pitch: ")
        out.append((yaw, pitch))
    return np.array(out)


def _rows(sec: Section, key: str, size: int, max_items: int = 2) -> list[Any]:
    """The list at ``key`` (of at least one row; rows of ``size`` numbers are checked by the caller)."""
    value = sec.raw(key)
    if not isinstance(value, list) or not value:
        sec.fail(key, f"expected a list of [{', '.join(['number'] * size)}] rows, got {short(value)}")
    check_count(sec, key, value, max_items)
    return value
