"""Discrete commands: names bound to library targets (003 section 5.1.1).

003 section 5.1.1 lets the operator start an automated motion with a discrete command ("go to the
pile", "go back to the bunk") instead of pointing at a target: the machine knows the places and
selects the motion. A *command set* (a YAML file, format in docs/commands.md) binds command names
to targets:

* ``target: [x, y, z]``: a tip point (m, base frame);
* ``point: NAME``: a named tip point of the scene;
* ``region: NAME``: a named region of the scene, its centre (the region is the box of tip positions
  where the crane works there, :class:`~motionlib.model.scene.Region`);

each with the selection utility (``time``, ``energy`` or ``robust``, 003 eqs. 5.6-5.7; the file's
default unless the command gives its own) and optionally its own acceptance limits ``L1``, ``L2``
(003 eqs. 5.3-5.4) and, for ``robust``, ``sigma_m`` and ``v_manual_m_s``. :meth:`CommandSet.select`
ranks the library's trajectories for a command from the current configuration, as
:meth:`Library.select_checked <motionlib.library.store.Library.select_checked>` with the bound
target and parameters.

Reading is strict (:class:`motionlib.schema.Section`): unknown and duplicate keys, wrong types,
NaN, names the scene does not have, targets outside the plausible range or below the scene's
ground, and a file written for another scene are errors naming the file and the dotted key.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import COORDINATE_M, Plausible, as_vec3, short
from ..errors import InputError
from ..model.scene import MAX_NAME_LENGTH, Scene
from ..schema import Section, check_count, load_yaml, read_plausibility
from .selection import SelectionResult, Utility
from .store import Library

#: A command name: letters, digits, ``-``, ``_``, ``.`` (it is a cell of a stick script's ``command`` column).
NAME_PATTERN = re.compile(r"[A-Za-z0-9_.-]+")
#: Largest number of commands in a set.
MAX_COMMANDS = 1_000
#: ``L1``, ``L2`` and ``sigma_m`` of a command (m, or metre-like for ``L2``): from a millimetre to 10 m.
LIMIT_M = Plausible(1e-3, 10.0, 1e-6, 1e5, "m")
#: ``v_manual_m_s`` of a command (m/s): a crawl to a fast crane tip.
SPEED_M_S = Plausible(0.01, 5.0, 1e-6, 1e3, "m/s")
#: Binding keys of a command: exactly one of them.
BINDINGS: tuple[str, ...] = ("target", "point", "region")
#: Optional selection parameters of a command -> plausible range.
PARAMETERS: dict[str, Plausible] = {"L1": LIMIT_M, "L2": LIMIT_M, "sigma_m": LIMIT_M, "v_manual_m_s": SPEED_M_S}


@dataclass(frozen=True)
class Command:
    """One named command.

    Attributes
    ----------
    name : str
    target_p : tuple of 3 float
        The bound tip target (m, base frame).
    binding : str
        ``target``, ``point`` or ``region``: how the file binds it.
    ref : str
        The scene point or region name (``""`` for an explicit target).
    utility : Utility
        Selection utility (003 eqs. 5.6-5.7).
    selection : dict of str to float
        ``L1``, ``L2``, ``sigma_m``, ``v_manual_m_s`` the command sets (the others take the library defaults).
    """

    name: str
    target_p: tuple[float, float, float]
    binding: str
    ref: str
    utility: Utility
    selection: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class CommandSet:
    """A validated command set (see the module docstring and docs/commands.md).

    Attributes
    ----------
    name : str
    scene_name : str
        The scene the set is written for (its points and regions).
    commands : dict of str to Command
        In file order.
    source : str or None
        File it was read from.
    """

    name: str
    scene_name: str
    commands: dict[str, Command]
    source: str | None = None

    @classmethod
    def load(cls, path: str | Path, scene: Scene) -> CommandSet:
        """Read and validate a command-set file against ``scene`` (a library's :attr:`Library.scene`).

        Raises
        ------
        ModelFileError
            Missing or malformed file, a scene other than ``scene``, an unknown point or region, a
            target outside the plausible range or below the ground; the message names the file and key.
        """
        path = Path(path)
        return cls.from_dict(load_yaml(path), scene, str(path))

    @classmethod
    def from_dict(cls, data: Any, scene: Scene, file: str = "<commands>") -> CommandSet:
        """Validate the mapping of a command-set file (see :meth:`load`)."""
        top = Section(data, file)
        read_plausibility(top)
        name = _name(top, "name")
        scene_name = _name(top, "scene")
        if scene_name != scene.name:
            top.fail(
                "scene",
                f"the commands are written for scene {short(scene_name)}, the library's scene is {short(scene.name)}",
            )
        default = Utility(top.string("utility", Utility.TIME.value, choices=tuple(u.value for u in Utility)))
        table = top.section("commands")
        check_count(top, "commands", table.data, MAX_COMMANDS)
        if not table.data:
            top.fail("commands", "expected at least one command")
        commands = {}
        for key in list(table.data):
            if not isinstance(key, str) or not NAME_PATTERN.fullmatch(key) or len(key) > MAX_NAME_LENGTH:
                table.fail(
                    str(key),
                    f"expected a command name of letters, digits, '-', '_' and '.' (at most "
                    f"{MAX_NAME_LENGTH} characters), got {short(key)}",
                )
            commands[key] = _read_command(table.section(key), key, scene, default)
        table.done()
        top.done()
        return cls(name, scene_name, commands, None if file.startswith("<") else file)

    def command(self, name: str) -> Command:
        """The command ``name``; :class:`InputError` naming the known commands otherwise."""
        if name not in self.commands:
            where = f"{self.source}: " if self.source else ""
            raise InputError(f"{where}no command {short(name)}; known commands: {', '.join(self.commands)}")
        return self.commands[name]

    def select(self, library: Library, name: str, current_q: Any = None, max_candidates: int = 10) -> SelectionResult:
        """Rank ``library``'s trajectories for command ``name`` from ``current_q`` (003 eqs. 5.3-5.7).

        :meth:`Library.select_checked <motionlib.library.store.Library.select_checked>` with the command's
        target, utility and selection parameters.

        Parameters
        ----------
        library : Library
            Built for this set's scene (checked by name).
        name : str
        current_q : array_like, shape (4,), optional
            Current configuration (rad, rad, rad, m); None skips the start filter (eq. 5.4).
        max_candidates : int
        """
        if library.scene_name != self.scene_name:
            raise InputError(
                f"commands {self.name!r} are for scene {self.scene_name!r}, library {library.path} for "
                f"scene {library.scene_name!r}"
            )
        cmd = self.command(name)
        return library.select_checked(
            np.asarray(cmd.target_p), current_q, cmd.utility.value, max_candidates=max_candidates, **cmd.selection
        )


def _name(sec: Section, key: str) -> str:
    value = sec.string(key)
    if not value.strip() or len(value) > MAX_NAME_LENGTH:
        sec.fail(key, f"expected a non-empty name of at most {MAX_NAME_LENGTH} characters, got {short(value)}")
    return value


def _read_command(sec: Section, name: str, scene: Scene, default: Utility) -> Command:
    given = [k for k in BINDINGS if sec.has(k)]
    if len(given) != 1:
        sec.fail("", f"expected exactly one of {', '.join(BINDINGS)}, got {', '.join(given) or 'none'}")
    binding = given[0]
    ref = ""
    if binding == "target":
        target = as_vec3(sec.vector("target", 3, plausible=COORDINATE_M))
    else:
        ref = sec.string(binding)
        table = scene.points if binding == "point" else {r.name: r.center for r in scene.regions}
        if ref not in table:
            sec.fail(
                binding,
                f"scene {short(scene.name)} has no {binding} {short(ref)} (known: "
                f"{short(', '.join(table) or 'none', 400)})",
            )
        target = as_vec3(table[ref])
    if target[2] < scene.ground_z:
        sec.fail(
            binding, f"expected a tip target above the ground (z >= {scene.ground_z:g} m), got z = {target[2]:g} m"
        )
    utility = Utility(sec.string("utility", default.value, choices=tuple(u.value for u in Utility)))
    selection = {}
    for key, plausible in PARAMETERS.items():
        value = sec.number(key, None, gt=0.0, plausible=plausible)
        if value is not None:
            selection[key] = value
    if utility is not Utility.ROBUST:
        for key in ("sigma_m", "v_manual_m_s"):
            if key in selection:
                sec.fail(key, f"applies to the robust utility only; this command selects by {utility.value}")
    sec.done()
    return Command(name, target, binding, ref, utility, selection)
