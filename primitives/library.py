"""The primitive library: entries (id, label, shape, parameters, goal, learning record), a versioned JSON format, validation and queries.

Two families of entries: ``paper`` primitives (one 100 s rollout to a Fig. 6 goal of the tracked
point) and ``lattice`` primitives (short centroid translations and turns in place, for planners
that chain them; primitives/lattice.py). Format version 2 added the lattice fields, version 3
the periodic gait's lattice fields (``cycles``, ``swept_joints``); older files still load
(version 1 entries are all ``paper``).

A file is read whole and validated before a ``Library`` exists: a corrupt, truncated, foreign
or newer file raises ``LibraryError`` with the reason; there is never a half-loaded library.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Iterator, Sequence
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from primitives.params import Kind, ParameterSpace
from primitives.shapes import is_shape
from sim.controls import GAIT_AMPLITUDE, GAIT_CYCLE, Control, PeriodicGait
from sim.rollout import JointMode, RolloutConfig

if TYPE_CHECKING:
    from primitives.coverage import Coverage

FORMAT: Literal["screwsnake-primitive-library"] = "screwsnake-primitive-library"
FORMAT_VERSION = 3
BUNDLED = "default_library.json"

Finite = Annotated[float, Field(allow_inf_nan=False)]
Vec2 = tuple[Finite, Finite]
Vec3 = tuple[Finite, Finite, Finite]
Vec4 = tuple[Finite, Finite, Finite, Finite]
Family = Literal["paper", "lattice"]
Reference = Literal["head", "centroid"]


class LibraryError(ValueError):
    """A library file that cannot be used, with the reason."""


class Frozen(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RolloutSettings(Frozen):
    duration: Finite = 100.0
    dt: Finite = 1.0
    joint_mode: JointMode = "paper"

    def config(self) -> RolloutConfig:
        return RolloutConfig(self.duration, self.dt, self.joint_mode)


class Primitive(Frozen):
    """One learned motor primitive: parameters that carry the robot from the start pose
    (0, 0, ψ = 0) to ``goal`` (a start-frame displacement) in one rollout of ``rollout``.

    Lattice entries: ``goal`` is the target displacement of the ``reference`` point (the body
    centroid) and ``turn`` the target Δψ (rad); ``end_pose`` is where the tracked point really
    lands (start frame, dx, dy, dψ) and ``swept`` the tracked-point poses along the way (start
    and end included), both from one rollout of the stored parameters for ``rollout.duration``.
    A periodic lattice entry runs ``cycles`` whole gait cycles from its phases, then holds its
    start shape to the end of its last control tick, and ``swept_joints`` holds the joints at
    each swept pose (a fixed shape's are its ``joints`` throughout: the list stays empty).
    """

    id: Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")]
    label: str | None = None
    shape: str
    space: Kind
    theta: Vec4
    joints: Vec3 | None = None
    phases: Vec3 | None = None
    goal: Vec2
    end: Vec2
    cost: Finite
    learner: str
    settings: dict[str, Any] = Field(default_factory=dict)
    seed: int
    updates: int
    rollouts: int
    curve: list[Finite] = Field(default_factory=list)
    rollout: RolloutSettings = Field(default_factory=RolloutSettings)
    family: Family = "paper"
    reference: Reference = "head"
    turn: Finite = 0.0
    end_pose: Vec3 | None = None
    swept: list[Vec3] = Field(default_factory=list)
    cycles: Annotated[int, Field(ge=0)] = 0
    swept_joints: list[Vec3] = Field(default_factory=list)

    @model_validator(mode="after")
    def _consistent(self) -> Primitive:
        if not is_shape(self.shape):
            raise ValueError(f"shape: unknown {self.shape!r}")
        if self.periodic != (self.phases is not None) or self.periodic == (self.joints is not None):
            raise ValueError(
                "a periodic primitive has phases and no joints; a fixed one joints only"
            )
        if self.family == "lattice" and (self.end_pose is None or len(self.swept) < 2):
            raise ValueError("a lattice primitive has an end_pose and at least two swept poses")
        if self.swept_joints and len(self.swept_joints) != len(self.swept):
            raise ValueError("swept_joints: one joint vector per swept pose")
        if self.cycles and not (self.periodic and self.family == "lattice"):
            raise ValueError("cycles: only a periodic lattice primitive runs whole gait cycles")
        return self

    @property
    def periodic(self) -> bool:
        return self.space == "U3"

    @property
    def direction(self) -> float:
        """Direction of the goal in the start frame, degrees counter-clockwise from +x."""
        return math.degrees(math.atan2(self.goal[1], self.goal[0]))

    @property
    def distance(self) -> float:
        return math.hypot(*self.goal)

    @property
    def name(self) -> str:
        return self.label or self.id

    def parameter_space(self) -> ParameterSpace:
        return ParameterSpace(self.space, self.joints or (0.0, 0.0, 0.0))

    def params(self) -> np.ndarray:
        """U = [θ̇1..4, φ1..3] (eq. 15), or [θ̇, ϕ] for a periodic primitive."""
        return np.array([*self.theta, *(self.phases or self.joints or (0.0, 0.0, 0.0))])

    @property
    def gait_time(self) -> float:
        """Model seconds of a periodic lattice entry's whole gait cycles (∞: the gait never
        stops, as the paper's periodic primitives run)."""
        return self.cycles * GAIT_CYCLE if self.cycles else math.inf

    @property
    def rest_joints(self) -> tuple[float, float, float]:
        """The joints at the start (and, for whole gait cycles, the end): the held shape, or
        the gait's φ(0) = A sin ϕ."""
        if self.phases is not None:
            a, b, c = (GAIT_AMPLITUDE * math.sin(p) for p in self.phases)
            return (a, b, c)
        return self.joints or (0.0, 0.0, 0.0)

    def control(self, t0: float = 0.0) -> Control:
        """The entry's control, its gait started at model time ``t0``."""
        if self.periodic:
            return PeriodicGait.of(
                self.theta, self.phases or (0.0, 0.0, 0.0), t0=t0, t_end=t0 + self.gait_time
            )
        return ParameterSpace("U2").control(self.params())


class LibraryFile(Frozen):
    format: Literal["screwsnake-primitive-library"]
    version: int
    code_version: str
    entries: list[Primitive]

    @model_validator(mode="after")
    def _unique(self) -> LibraryFile:
        names = [e.id for e in self.entries] + [e.label for e in self.entries if e.label]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"entries: duplicate ids or labels {sorted(dup)}")
        return self


class Library:
    """An immutable, validated set of primitives with lookups by id, label, shape and goal."""

    def __init__(self, entries: Iterable[Primitive], code_version: str = "") -> None:
        self.file = LibraryFile(
            format=FORMAT, version=FORMAT_VERSION, code_version=code_version, entries=list(entries)
        )
        self._by_name = {e.id: e for e in self.file.entries}
        self._of_shape: dict[tuple[str, Family | None], tuple[Primitive, ...]] = {}
        self._by_name.update({e.label: e for e in self.file.entries if e.label})
        self._version: str | None = None

    def __len__(self) -> int:
        return len(self.file.entries)

    def __iter__(self) -> Iterator[Primitive]:
        return iter(self.file.entries)

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def get(self, name: str) -> Primitive:
        """An entry by id or paper label (``P1s``); ``KeyError`` names what is missing."""
        try:
            return self._by_name[name]
        except KeyError:
            raise KeyError(f"primitive {name!r} is not in the library") from None

    def shapes(self) -> list[str]:
        return sorted({e.shape for e in self})

    def of_shape(self, shape: str, family: Family | None = "paper") -> list[Primitive]:
        """Entries of ``shape`` of one family (paper by default, as the generalisers and the
        paper's move actions expect), or of every family with ``family=None``."""
        key = (shape, family)
        got = self._of_shape.get(key)
        if got is None:  # the entries never change: asked every tick by the reactive moves
            got = self._of_shape[key] = tuple(
                e for e in self if e.shape == shape and family in (None, e.family)
            )
        return list(got)

    def paper(self) -> list[Primitive]:
        """The paper-family entries, in library order."""
        return [e for e in self if e.family == "paper"]

    def lattice(self, shape: str) -> list[Primitive]:
        """The lattice entries of ``shape``, in library (catalogue) order: translations by
        distance then body angle, then turns from −45° to +45°."""
        return self.of_shape(shape, "lattice")

    def lattice_shapes(self) -> list[str]:
        """Shapes that have lattice primitives."""
        return sorted({e.shape for e in self if e.family == "lattice"})

    def covers(self, joints: Sequence[float], tolerance: float | None = None) -> Coverage:
        """Whether the library covers the body shape ``joints`` for the paper's moves: a library
        shape within the joint tolerance, or interpolable between library shapes
        (primitives/coverage.py). A lattice planner asks ``lattice_covers`` instead."""
        from primitives.coverage import JOINT_TOLERANCE, covers

        tol = JOINT_TOLERANCE if tolerance is None else tolerance
        return covers(joints, self.shapes(), tol)

    def lattice_covers(self, joints: Sequence[float], tolerance: float | None = None) -> Coverage:
        """Whether a shape with lattice primitives is within ``tolerance`` (max-abs, rad;
        default ``LATTICE_TOLERANCE``) of ``joints``: the only cover a lattice planner may use,
        since a lattice motion's recorded end holds for its own joints alone (a blend of
        shapes, or a shape further off, lands elsewhere: primitives/coverage.py)."""
        from primitives.coverage import LATTICE_TOLERANCE, nearest_shape

        tol = LATTICE_TOLERANCE if tolerance is None else tolerance
        held: dict[str, tuple[float, float, float]] = {}
        for e in self:
            if e.family == "lattice" and e.joints is not None:
                held.setdefault(e.shape, e.joints)
        return nearest_shape(joints, held, tol)

    def with_entries(self, entries: Iterable[Primitive]) -> Library:
        """A new library: these entries after this one's (ids already here are kept as they
        are: the same shape learned twice from the same seed gives the same entries)."""
        added = [e for e in entries if e.id not in self._by_name]
        return Library([*self.file.entries, *added], self.file.code_version)

    @property
    def version(self) -> str:
        """The SHA-256 of the library's JSON: what the store records as its version."""
        if self._version is None:
            self._version = hashlib.sha256(self.to_json().encode()).hexdigest()
        return self._version

    def nearest(self, displacement: tuple[float, float], shape: str) -> Primitive:
        """The paper entry of ``shape`` whose start-frame goal is closest to ``displacement``."""
        candidates = self.of_shape(shape)
        if not candidates:
            raise KeyError(f"no primitive of shape {shape!r} in the library")
        d = np.asarray(displacement, dtype=float)
        return min(candidates, key=lambda e: float(np.linalg.norm(np.asarray(e.goal) - d)))

    # -- persistence ---------------------------------------------------------------------
    def to_json(self) -> str:
        return json.dumps(self.file.model_dump(mode="json"), indent=1, sort_keys=True) + "\n"

    def save(self, path: Path) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(self.to_json())
        tmp.replace(path)  # atomic: readers never see a half-written file
        return path

    @classmethod
    def from_json(cls, text: str, source: str = "library") -> Library:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise LibraryError(
                f"{source}: not valid JSON ({exc.msg} at line {exc.lineno})"
            ) from exc
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise LibraryError(
                f"{source}: not a screwsnake primitive library (format != {FORMAT!r})"
            )
        version = data.get("version")
        if not isinstance(version, int) or version > FORMAT_VERSION or version < 1:
            raise LibraryError(
                f"{source}: format version {version!r} is not supported (this code reads 1..{FORMAT_VERSION})"
            )
        try:
            file = LibraryFile.model_validate(data)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(str(p) for p in first["loc"])
            raise LibraryError(f"{source}: invalid at {where}: {first['msg']}") from exc
        return cls(file.entries, file.code_version)

    @classmethod
    def load(cls, path: Path) -> Library:
        try:
            text = path.read_text()
        except OSError as exc:
            raise LibraryError(f"{path}: cannot read ({exc.strerror})") from exc
        return cls.from_json(text, str(path))


def bundled_library_path() -> Path:
    return Path(str(resources.files("primitives") / "data" / BUNDLED))


def load_bundled() -> Library:
    return Library.load(bundled_library_path())
