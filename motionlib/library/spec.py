"""Motion-library specifications (``libraries/*.yaml``, docs/library-spec.md).

A spec names the crane, the scene, the planner options and the motion groups of a
library; :meth:`LibrarySpec.entries` expands it into the planning queries of the
library, the set Q of 003 eq. 5.2: trajectories from start configurations ``C`` to
target points ``P``. Each motion group has

* ``starts``: named start configurations of the scene, or explicit ``{name, q}``;
* ``targets``: explicit tip points (named points of the scene or ``[x, y, z]``)
  and grids over scene regions with an xy spacing and a list of tip heights;
* ``loaded``: whether the grapple carries a log.

Entries are expanded in a fixed order (motion group, then start, then target:
points first, then grids; grids by height, then x, then y), numbered from 0. Every
entry has a key (``motion|start|target``) and a planner seed derived from the spec
seed and that key (:func:`entry_seed`), so an entry's trajectory does not depend
on which worker plans it or when.

Reading is strict (:class:`motionlib.schema.Section`): unknown and duplicate keys,
wrong types, unknown scene names and duplicate entries are errors naming the file and
the dotted key. Everything that sizes the work is bounded: the number of entries
(:data:`MAX_ENTRIES`), the grid spacing and the planner options (:data:`PLANNER_RANGES`);
``plausibility: relaxed`` at the top level widens these ranges to their numeric limits.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import COORDINATE_M, Plausible, short
from ..errors import ModelFileError
from ..model.crane_model import JOINT_NAMES
from ..model.kinematics import Crane
from ..model.scene import MAX_ITEMS, MAX_NAME_LENGTH
from ..schema import Section, check_count, check_number_list, load_yaml, read_plausibility

SEED_MAX = 2**32 - 2
"""Largest planner seed (OMPL seeds are uint32; motionlib passes seed + 1)."""

#: Number of entries of a spec: 10^5 plans take about a day on 32 cores; a relaxed spec may have 10^6.
MAX_ENTRIES = Plausible(1, 100_000, 1, 1_000_000, "entries")
#: Grid spacing (m).
GRID_SPACING_M = Plausible(0.01, 100.0, 1e-4, 1e4, "m")
#: Ranges of the planner options (``planner.<key>``, ``planner.redundancy.<key>``); an option not
#: listed has :data:`OTHER_FLOAT` or :data:`OTHER_INT`. Time limits and iteration counts size the work,
#: sample periods and spacings the memory.
PLANNER_RANGES: dict[str, Plausible] = {
    "time_limit_s": Plausible(1e-3, 600.0, 1e-3, 86_400.0, "s"),
    "max_checks": Plausible(100, 1_000_000, 1, 100_000_000, "checks"),
    "dt_s": Plausible(1e-3, 0.05, 1e-4, 1.0, "s"),
    "verify_tip_spacing_m": Plausible(1e-3, 0.5, 1e-4, 10.0, "m"),
    "check_step_m": Plausible(1e-3, 1.0, 1e-4, 10.0, "m"),
    "clearance_m": Plausible(0.0, 2.0, 0.0, 100.0, "m"),
    "arm_clearance_m": Plausible(0.0, 2.0, 0.0, 100.0, "m"),
    "reach_margin_rad": Plausible(0.0, 0.5, 0.0, 3.0, "rad"),
    "limit_margin": Plausible(0.0, 0.5, 0.0, 3.0, "rad"),
    "degree": Plausible(1, 20, 1, 50),
    "n_samples": Plausible(2, 1000, 2, 10_000),
    "max_iter": Plausible(1, 10_000, 1, 1_000_000),
    "goal_log_yaw": Plausible(-2 * math.pi, 2 * math.pi, -4 * math.pi, 4 * math.pi, "rad"),
    # the residual swing a plan may leave: from a still grapple to ~30 degrees (the linear pendulum's range)
    "swing_tolerance_rad": Plausible(1e-3, 0.5, 1e-5, 1.5, "rad"),
    # the largest swing during a motion: from a nearly still grapple to the linear pendulum's range
    "swing_peak_rad": Plausible(0.05, 1.0, 1e-3, 1.5, "rad"),
    # the jerk-limiting box of swing shaping: from a fast valve's opening to one period of a 0.5 Hz joint mode
    "jerk_box_s": Plausible(0.01, 2.0, 1e-3, 10.0, "s"),
}
OTHER_FLOAT = Plausible(0.0, 1e3, 0.0, 1e6)
OTHER_INT = Plausible(1, 10_000, 1, 1_000_000)
#: Longest list of grid heights.
MAX_HEIGHTS = 1_000


@dataclass(frozen=True)
class Entry:
    """One planning query of a library.

    Attributes
    ----------
    index : int
        Position in the expanded order (0-based); the entry id of the library file.
    key : str
        ``motion|start|target``: unique within the spec; with the spec seed it fixes the planner seed.
    motion : str
        Name of the motion group.
    start : str
        Name of the start configuration.
    start_q : tuple of 4 float
        Start configuration (rad, rad, rad, m).
    target : str
        Target label: a scene point name, ``x,y,z`` for an explicit point, or
        ``region@x,y,z`` for a grid point (mm precision).
    target_p : tuple of 3 float
        Target tip point in the base frame (m).
    loaded : bool
        The grapple carries a log.
    seed : int
        Planner seed, ``0 <= seed <= SEED_MAX``.
    """

    index: int
    key: str
    motion: str
    start: str
    start_q: tuple[float, float, float, float]
    target: str
    target_p: tuple[float, float, float]
    loaded: bool
    seed: int


@dataclass(frozen=True)
class Grid:
    """A grid of targets over a scene region: xy spacing (m) and tip heights (m, base frame)."""

    region: str
    spacing_m: float
    heights_m: tuple[float, ...]


@dataclass(frozen=True)
class Motion:
    """A motion group: every start to every target, empty or loaded."""

    name: str
    loaded: bool
    starts: tuple[tuple[str, tuple[float, float, float, float]], ...]
    points: tuple[tuple[str, tuple[float, float, float]], ...]
    grids: tuple[Grid, ...]


@dataclass(frozen=True)
class LibrarySpec:
    """A validated library spec (see the module docstring and docs/library-spec.md).

    Attributes
    ----------
    name : str
    description : str
    crane : Crane
    scene : Scene
    seed : int
        Spec seed, from which every entry's planner seed is derived.
    planner : dict
        Planner options (keys of :class:`motionlib.planning.planner.PlanOptions` without
        ``loaded`` and ``seed``; ``redundancy`` a dict of
        :class:`motionlib.planning.redundancy.RedundancyOptions` fields); only the keys given.
    motions : tuple of Motion
    source : str or None
        File the spec was read from.
    plausibility : str
        ``strict`` or ``relaxed`` (the file's ``plausibility`` key).
    """

    name: str
    description: str
    crane: Crane
    scene: Any  # motionlib.model.scene.Scene
    seed: int
    planner: dict[str, Any] = field(default_factory=dict)
    motions: tuple[Motion, ...] = ()
    source: str | None = None
    plausibility: str = "strict"

    # ------------------------------------------------------------------ reading
    @classmethod
    def load(cls, path: str | Path) -> LibrarySpec:
        """Read and validate a spec file; scene and crane paths are relative to it.

        Raises
        ------
        ModelFileError
            Missing or malformed file, unknown scene name, empty or duplicate
            entries; the message names the file and the dotted key.
        """
        path = Path(path)
        return cls.from_dict(load_yaml(path), str(path), base_dir=path.parent)

    @classmethod
    def from_dict(cls, data: Any, file: str = "<spec>", base_dir: str | Path = ".") -> LibrarySpec:
        """Validate the mapping of a spec file (see :meth:`load`)."""
        from ..model.scene import Scene, _load_crane

        base = Path(base_dir)
        top = Section(data, file)
        relaxed = read_plausibility(top)
        name = _nonempty(top, "name")
        description = top.string("description", "")
        scene_rel = _nonempty(top, "scene")
        crane_name = top.string("crane", None)
        seed = _integer(top, "seed", 0, lo=0, hi=SEED_MAX)
        planner = _read_planner(top.section("planner", {}))
        motion_secs = top.sections("motions", max_items=1_000)
        top.done()

        scene_path = base / scene_rel
        if crane_name is None:
            scene = Scene.load(scene_path)
            crane = scene.load_crane()
        else:
            crane = _load_crane(crane_name, file)
            try:
                scene = Scene.load(scene_path, crane=crane)
            except ModelFileError as exc:
                raise ModelFileError(f"{file}: scene: {exc}") from exc
        if not motion_secs:
            top.fail("motions", "expected at least one motion group")
        motions = tuple(_read_motion(sec, scene, crane) for sec in motion_secs)
        names = [m.name for m in motions]
        for i, m in enumerate(names):
            if m in names[:i]:
                top.fail(f"motions[{i}].name", f"duplicate motion name {short(m)}")
        n_entries = sum(_count_entries(m, scene) for m in motions)
        top.check_plausible("motions", n_entries, MAX_ENTRIES, "the number of entries: ")
        spec = cls(name, description, crane, scene, seed, planner, motions, None if file.startswith("<") else file,
                   "relaxed" if relaxed else "strict")
        spec.entries(file)  # reject duplicate entries now, naming the motion group
        return spec

    # ------------------------------------------------------------------ entries
    def entries(self, file: str | None = None) -> list[Entry]:
        """The planning queries, in the deterministic order of the module docstring.

        Returns
        -------
        list of Entry
            ``entries[i].index == i``.
        """
        out: list[Entry] = []
        seen: dict[str, int] = {}
        for m_i, motion in enumerate(self.motions):
            targets = list(motion.points)
            for grid in motion.grids:
                targets.extend(_grid_targets(self.scene.region(grid.region), grid))
            for start_name, q in motion.starts:
                for label, p in targets:
                    key = f"{motion.name}|{start_name}|{label}"
                    if key in seen:
                        raise ModelFileError(
                            f"{file or self.source or '<spec>'}: motions[{m_i}]: duplicate entry {short(key)} "
                            f"(the same start and target twice)"
                        )
                    seen[key] = len(out)
                    seed = entry_seed(self.seed, key)
                    out.append(Entry(len(out), key, motion.name, start_name, q, label, p, motion.loaded, seed))
        return out

    def plan_options(self, loaded: bool = False, seed: int = 0) -> Any:
        """The :class:`motionlib.planning.planner.PlanOptions` of an entry (imports the planner)."""
        return plan_options(self.planner, loaded, seed)

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form, self-contained (crane and scene by name and digest; embedded separately)."""
        return {
            **({"plausibility": self.plausibility} if self.plausibility != "strict" else {}),
            "name": self.name,
            "description": self.description,
            "crane": self.crane.name,
            "crane_digest": self.crane.model.digest,
            "scene": self.scene.name,
            "scene_digest": self.scene.digest,
            "seed": self.seed,
            "planner": self.planner,
            "motions": [
                {
                    "name": m.name,
                    "loaded": m.loaded,
                    "starts": [{"name": n, "q": list(q)} for n, q in m.starts],
                    "points": [{"name": n, "p": list(p)} for n, p in m.points],
                    "grids": [asdict(g) | {"heights_m": list(g.heights_m)} for g in m.grids],
                }
                for m in self.motions
            ],
            "source": self.source,
        }

    @property
    def digest(self) -> str:
        """SHA-256 identifying what a build produces: crane, scene, planner options and every entry."""
        content = {k: v for k, v in self.to_dict().items() if k not in ("source", "description")}
        content["entries"] = [asdict(e) for e in self.entries()]
        text = json.dumps(content, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


#: Planner options whose default in a library differs from :class:`~motionlib.planning.planner.PlanOptions`'s (a
#: spec's ``planner`` mapping overrides them): the joint-space baseline is not verified (a report beside the motion)
#: and the tip-space path is searched only when the joint candidates give no plan (docs/library-spec.md, "planner").
LIBRARY_PLANNER_DEFAULTS: dict[str, Any] = {"jointspace_baseline": False, "tip_path_always": False}


def plan_options(planner: dict[str, Any], loaded: bool = False, seed: int = 0) -> Any:
    """:class:`motionlib.planning.planner.PlanOptions` from a spec's ``planner`` mapping (over
    :data:`LIBRARY_PLANNER_DEFAULTS`), ``loaded`` and ``seed``."""
    from ..planning.planner import PlanOptions
    from ..planning.redundancy import RedundancyOptions

    kw = {**LIBRARY_PLANNER_DEFAULTS, **planner}
    if "redundancy" in kw:
        kw["redundancy"] = RedundancyOptions(**kw["redundancy"])
    return PlanOptions(loaded=loaded, seed=seed, **kw)


def entry_seed(spec_seed: int, key: str) -> int:
    """Planner seed of an entry: the first 8 bytes of SHA-256(``"<spec_seed>/<key>"``) modulo ``SEED_MAX + 1``.

    Depends only on the spec seed and the entry key, not on the entry's position,
    the worker or the scheduling.
    """
    digest = hashlib.sha256(f"{int(spec_seed)}/{key}".encode()).digest()
    return int.from_bytes(digest[:8], "big") % (SEED_MAX + 1)


def grid_points(lower: np.ndarray, upper: np.ndarray, spacing_m: float, heights_m: Any) -> np.ndarray:
    """Points of an xy grid at the given heights, centred in the box ``[lower, upper]``.

    Along x (and y) there are ``n = floor(width / spacing + 1e-9) + 1`` points spaced
    ``spacing_m`` apart, centred on the box centre.

    Parameters
    ----------
    lower, upper : ndarray, shape (3,)
        Box corners (m).
    spacing_m : float
        Grid spacing (m), > 0.
    heights_m : sequence of float
        Tip heights z (m).

    Returns
    -------
    ndarray, shape (n_z * n_x * n_y, 3)
        Ordered by height, then x, then y.
    """
    axes = []
    for i, n in enumerate(grid_shape(lower, upper, spacing_m)):
        centre = 0.5 * float(upper[i] + lower[i])
        axes.append(centre + (np.arange(n) - (n - 1) / 2.0) * spacing_m)
    z, x, y = np.meshgrid(np.asarray(heights_m, dtype=float), axes[0], axes[1], indexing="ij")
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


def grid_shape(lower: np.ndarray, upper: np.ndarray, spacing_m: float) -> tuple[int, int]:
    """Points along x and y of the grid of :func:`grid_points` (computed without building it)."""
    return tuple(int(math.floor(float(upper[i] - lower[i]) / spacing_m + 1e-9)) + 1 for i in range(2))  # type: ignore[return-value]


def _count_entries(motion: Motion, scene: Any) -> int:
    """Entries of a motion group: starts x (points + grid points), counted without expanding the grids."""
    targets = len(motion.points)
    for grid in motion.grids:
        region = scene.region(grid.region)
        n_x, n_y = grid_shape(region.lower, region.upper, grid.spacing_m)
        targets += n_x * n_y * len(grid.heights_m)
    return len(motion.starts) * targets


# ---------------------------------------------------------------- helpers
def _grid_targets(region: Any, grid: Grid) -> list[tuple[str, tuple[float, float, float]]]:
    pts = grid_points(region.lower, region.upper, grid.spacing_m, grid.heights_m)
    pts = np.round(pts, 6) + 0.0  # no -0.0 and no 1e-16 noise in labels, keys or targets
    return [(f"{grid.region}@{_fmt(p)}", (float(p[0]), float(p[1]), float(p[2]))) for p in pts]


def _fmt(p: Any) -> str:
    return ",".join(f"{v + 0.0:.3f}" for v in p)


def _nonempty(sec: Section, key: str) -> str:
    value = sec.string(key)
    if not value.strip():
        sec.fail(key, "expected a non-empty string")
    if len(value) > MAX_NAME_LENGTH:
        sec.fail(key, f"expected at most {MAX_NAME_LENGTH} characters, got {short(value)}")
    return value


def _integer(sec: Section, key: str, default: Any, lo: int | None = None, hi: int | None = None) -> int:
    value = sec.raw(key, default)
    if isinstance(value, bool) or not isinstance(value, int):
        sec.fail(key, f"expected an integer, got {type(value).__name__} {short(value)}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        sec.fail(key, f"expected an integer in [{lo}, {hi}], got {short(value)}")
    return int(value)


#: Options that must be > 0.
_POSITIVE = {"time_limit_s", "dt_s", "verify_tip_spacing_m", "check_step_m", "swing_tolerance_rad", "swing_peak_rad",
             "jerk_box_s"}


def _read_planner(sec: Section) -> dict[str, Any]:
    """Planner options: the fields of :class:`PlanOptions` (but ``loaded``, ``seed``), typed by their defaults."""
    from ..planning.planner import PlanOptions

    return _read_options(sec, PlanOptions(), skip=("loaded", "seed"))


def _read_options(sec: Section, defaults: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    import dataclasses

    out: dict[str, Any] = {}
    for f in dataclasses.fields(defaults):
        if f.name in skip or not sec.has(f.name):
            continue
        default = getattr(defaults, f.name)
        if dataclasses.is_dataclass(default):
            out[f.name] = _read_options(sec.section(f.name), default)
        elif isinstance(default, bool):
            out[f.name] = sec.boolean(f.name)
        elif isinstance(default, int):
            out[f.name] = _integer(sec, f.name, None, lo=1)
            sec.check_plausible(f.name, out[f.name], PLANNER_RANGES.get(f.name, OTHER_INT))
        elif isinstance(default, float):
            bound = {"gt": 0.0} if f.name in _POSITIVE else {"ge": 0.0}
            out[f.name] = sec.number(f.name, **bound, plausible=PLANNER_RANGES.get(f.name, OTHER_FLOAT))
        elif f.name == "goal_log_yaw":  # optional number (default None): the carried log's yaw at the goal
            out[f.name] = sec.number(f.name, plausible=PLANNER_RANGES[f.name])
        elif f.name == "planner":
            from ..planning.path import available_planners

            out[f.name] = sec.string(f.name, choices=available_planners())
        else:
            out[f.name] = sec.string(f.name)
    sec.done()
    return out


def _read_motion(sec: Section, scene: Any, crane: Crane) -> Motion:
    name = _nonempty(sec, "name")
    if "|" in name:
        sec.fail("name", f"expected a name without '|', got {name!r}")
    loaded = sec.boolean("loaded", False)
    starts = _read_starts(sec, scene, crane)
    tsec = sec.section("targets")
    points = _read_points(tsec, scene)
    grids = tuple(_read_grid(g, scene) for g in tsec.sections("grids", []))
    tsec.done()
    sec.done()
    if not points and not grids:
        tsec.fail("", "expected at least one target (points or grids)")
    return Motion(name, loaded, starts, points, grids)


def _require_named(sec: Section, key: str, name: str, known: Any, scene: Any, what: str) -> None:
    """Fail at ``key`` unless ``name`` is among ``known`` (the scene's starts, points or regions)."""
    if name not in known:
        listed = ", ".join(sorted(known)) or "none"
        sec.fail(key, f"scene {scene.name!r} has no {what} {short(name)} (known: {short(listed, 400)})")


def _read_starts(sec: Section, scene: Any, crane: Crane) -> tuple:
    raw = sec.raw("starts")
    if not isinstance(raw, list) or not raw:
        sec.fail("starts", "expected a non-empty list of scene start names or {name, q} mappings")
    check_count(sec, "starts", raw, MAX_ITEMS["starts"])
    out = []
    for i, item in enumerate(raw):
        key = f"starts[{i}]"
        if isinstance(item, str):
            _require_named(sec, key, item, scene.starts, scene, "start")
            out.append((item, tuple(float(v) for v in scene.starts[item])))
            continue
        sub = Section(item, sec.file, sec.key_path(key), sec.relaxed)
        start_name = _nonempty(sub, "name")
        q = sub.vector("q", 4)
        sub.done()
        for j, joint in enumerate(JOINT_NAMES):
            if not crane.q_min[j] <= q[j] <= crane.q_max[j]:
                sub.fail(f"q[{j}]", f"{joint} {q[j]} is outside the limits [{crane.q_min[j]}, {crane.q_max[j]}]")
        out.append((start_name, tuple(q)))
    names = [n for n, _ in out]
    for i, n in enumerate(names):
        if n in names[:i]:
            sec.fail(f"starts[{i}]", f"duplicate start {short(n)}")
    return tuple(out)


def _read_points(tsec: Section, scene: Any) -> tuple:
    raw = tsec.raw("points", [])
    if not isinstance(raw, list):
        tsec.fail("points", "expected a list of scene point names or [x, y, z] points")
    check_count(tsec, "points", raw, MAX_ITEMS["points"])
    out = []
    for i, item in enumerate(raw):
        key = f"points[{i}]"
        if isinstance(item, str):
            _require_named(tsec, key, item, scene.points, scene, "point")
            p = tuple(float(v) for v in scene.points[item])
            out.append((item, p))
        else:
            p = tuple(check_number_list(tsec, key, item, 3, COORDINATE_M))
            out.append((_fmt(p), p))
    return tuple(out)


def _read_grid(sec: Section, scene: Any) -> Grid:
    region_name = _nonempty(sec, "region")
    _require_named(sec, "region", region_name, [r.name for r in scene.regions], scene, "region")
    region = scene.region(region_name)
    spacing = sec.number("spacing", gt=0.0, plausible=GRID_SPACING_M)
    raw_heights = sec.raw("heights", None)
    heights: tuple[float, ...]
    if raw_heights is None:
        heights = (float(region.center[2]),)
    else:
        if not isinstance(raw_heights, list) or not raw_heights:
            sec.fail("heights", "expected a non-empty list of tip heights (m)")
        check_count(sec, "heights", raw_heights, MAX_HEIGHTS)
        heights = tuple(check_number_list(sec, "heights", raw_heights, len(raw_heights)))
        lo, hi = float(region.lower[2]), float(region.upper[2])
        for i, z in enumerate(heights):
            if not lo - 1e-9 <= z <= hi + 1e-9:
                sec.fail(f"heights[{i}]", f"height {z} m is outside region {region_name!r} ({lo} to {hi} m)")
        if len(set(heights)) != len(heights):
            sec.fail("heights", "duplicate heights")
    sec.done()
    return Grid(region_name, spacing, heights)
