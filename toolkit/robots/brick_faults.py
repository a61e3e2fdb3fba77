"""Faults the virtual brick can be told to make, on a schedule and from a seed, so every one is reproducible.

A fault is written ``KIND:AT_S[:ARG]`` (``nxtnav brick serve --fault``, repeatable):

``drop-link:AT_S:DOWN_S``
    At brick time AT_S the brick cuts every connection and its port refuses new ones for DOWN_S
    wall-clock seconds; the simulated world (the robot's true pose, the motors' counts) goes on.
``stall:AT_S:DUR_S``
    At brick time AT_S the brick stops answering for DUR_S wall-clock seconds, then answers again
    (the reply it owed comes late).
``sonar-stuck:AT_S:DUR_S``
    From brick time AT_S the ultrasonic sensor repeats its last reading for DUR_S brick seconds.
``sonar-garbage:P`` or ``sonar-garbage:AT_S:P``
    Each reading (from the start, or from brick time AT_S) is replaced with probability P by a random
    value from 0 to 255.
``motor-slip:AT_S:FRACTION``
    The first motion of the wheels commanded at or after brick time AT_S (a drive, or a turn on the
    spot) moves the robot only FRACTION of what their tachometers count (wheels that skid on a
    slippery floor).

Every kind is a registered class (`FAULT_CLASSES`) that holds its own rules: what its ARG is and which
values it takes (`FaultKind.arg_ok`), the range ``nxtnav bench faults`` draws it from
(`FaultKind.draw_range`), and what it does on the brick, by the family it belongs to: a `LinkFault`
is carried out by the server (`LinkFault.carry_out`), a `SonarFault` changes the sensor's readings
(`SonarFault.reading`), a `WheelFault` the travel of the wheels (`WheelFault.take`). A kind of one's own
is one subclass with a ``name`` (see `SonarFault` and ``docs/howto/fault.md``): once its module is
imported, ``KIND:AT_S:ARG`` schedules it like the kinds above; an unknown KIND is an error that lists
the known ones.

AT_S is in the brick's robot time, the clock ``--time-factor`` speeds up; the durations of a dropped
link or a stalled brick are wall-clock seconds, since a client waits for its brick in wall-clock time;
a stuck sensor's duration is robot time, like the readings it spoils.

`FaultSchedule` holds the faults of one brick, the random stream of the garbage readings, and what
happened: when each fault fired (brick and wall time) and how often it acted (readings spoiled,
motions slipped, connections cut, replies held). A test waits for a fault with `FaultSchedule.wait`
instead of sleeping.

>>> f = parse_fault("drop-link:20:3")
>>> f.kind, f.at_s, f.arg
('drop-link', 20.0, 3.0)
>>> parse_fault("sonar-garbage:0.05").at_s
0.0
"""

from __future__ import annotations

import logging
import math
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from ..world import ConfigError, Registry, RngLike, as_rng

__all__ = ["FAULT_CLASSES", "FAULT_KINDS", "LINK_FAULTS", "SONAR_FAULTS", "SONAR_FAULT_PLUGINS", "Fault", "FaultKind",
           "FaultSchedule", "Fired", "LinkControl", "LinkFault", "SonarFault", "WheelFault", "fault_class",
           "known_fault_kinds", "parse_fault"]

_log = logging.getLogger(__name__)
_MAX_WAIT_S = 3600.0
_BUILT_IN: list[str] = []  # the kinds this module defines, in the order it defines them


class FaultKind(ABC):
    """A kind of fault: its name, its ARG's rule, its draw range for the bench, and (by its family) its effect.

    A concrete kind subclasses one of the families `LinkFault`, `SonarFault` or `WheelFault` and sets
    ``name`` in its body (the KIND of ``KIND:AT_S:ARG``; that registers it in `FAULT_CLASSES`). The
    `FaultSchedule` builds one instance per scheduled fault of the kind, so an instance may keep state.

    Parameters
    ----------
    fault : Fault
        The scheduled fault (its ``at_s`` and ``arg``).
    """

    name: ClassVar[str]
    arg_name: ClassVar[str] = "ARG"
    """What ARG is, as messages name it (``DUR_S``, ``P``, ``CM``, ...)."""
    arg_rule: ClassVar[str] = "a finite number"
    """The rule `arg_ok` applies, in words (``"a probability in (0, 1]"``)."""
    at_optional: ClassVar[bool] = False
    """Whether ``KIND:ARG`` alone is accepted, for AT_S = 0 (``sonar-garbage:0.05``)."""
    draw_range: ClassVar[tuple[float, float] | None] = None
    """The range ``nxtnav bench faults`` draws ARG from uniformly (None: the bench cannot draw this kind)."""
    drawn_from_start: ClassVar[bool] = False
    """Whether the bench schedules a drawn fault of this kind at brick time 0 rather than inside the run."""
    acts_on: ClassVar[str | None] = None
    """What the family carries the fault out on ("link", "sensor", "wheels"), set by the family."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" not in cls.__dict__:
            return
        if ":" in cls.name or (cls.__module__ != __name__ and cls.name in _BUILT_IN):
            raise ConfigError(f"fault kind {cls.name!r} is a built-in kind's name or has a colon")
        if cls.acts_on is None:
            raise ConfigError(f"fault kind {cls.name!r} must subclass LinkFault, SonarFault or WheelFault "
                              "(what it acts on)")
        FAULT_CLASSES.add(cls.name, cls)
        if cls.__module__ == __name__:
            _BUILT_IN.append(cls.name)

    def __init__(self, fault: Fault) -> None:
        self.fault = fault

    @classmethod
    def arg_ok(cls, arg: float) -> bool:
        """Whether `arg` is an allowed ARG (default: any finite number)."""
        return math.isfinite(arg)


FAULT_CLASSES: Registry[FaultKind] = Registry("fault kind")
"""Every fault kind (`FaultKind` subclasses, the built-in ones and one's own), by name."""
SONAR_FAULT_PLUGINS = FAULT_CLASSES
"""The registry of fault kinds under its first name (it held the sensor kinds of one's own)."""


def known_fault_kinds() -> list[str]:
    """The registered kinds: the built-in ones in their order, then those of one's own by name."""
    return [*_BUILT_IN, *(k for k in FAULT_CLASSES.names() if k not in _BUILT_IN)]


def fault_class(kind: str) -> type[FaultKind]:
    """The class of fault kind `kind`; `ConfigError` lists the known kinds for any other name."""
    if kind not in FAULT_CLASSES:
        raise ConfigError(f"unknown fault kind {kind!r}; known: {', '.join(known_fault_kinds())}")
    return FAULT_CLASSES.get(kind)


# -- the link ---------------------------------------------------------------------------------------
class LinkControl(Protocol):
    """What a link fault may do to the server that carries it out (`toolkit.robots.virtual_brick.BrickServer`)."""

    def drop_link(self, down_s: float) -> None:
        """Cut every connection and refuse new ones for `down_s` wall-clock seconds."""

    def stall(self, for_s: float) -> None:
        """Answer nothing for `for_s` wall-clock seconds."""


class LinkFault(FaultKind):
    """A fault of the link: its ARG is wall-clock seconds, and the server carries it out once, when due."""

    acts_on = "link"
    arg_rule = f"in (0, {_MAX_WAIT_S:g}] wall-clock seconds"

    @classmethod
    def arg_ok(cls, arg: float) -> bool:
        return math.isfinite(arg) and 0 < arg <= _MAX_WAIT_S

    @abstractmethod
    def carry_out(self, link: LinkControl) -> bool:
        """Do the fault to `link` now; True when the connections dropped (the reply owed never leaves)."""


class DropLink(LinkFault):
    """``drop-link:AT_S:DOWN_S``: every connection cut, the port closed for DOWN_S wall-clock seconds."""

    name = "drop-link"
    arg_name = "DOWN_S"
    draw_range = (0.5, 10.0)  # Bluetooth coming back, a cable plugged in again

    def carry_out(self, link: LinkControl) -> bool:
        _log.info("fault %s: the link drops for %g s", self.fault.text, self.fault.arg)
        link.drop_link(self.fault.arg)
        return True


class Stall(LinkFault):
    """``stall:AT_S:DUR_S``: the brick answers nothing for DUR_S wall-clock seconds (the reply owed comes late)."""

    name = "stall"
    arg_name = "DUR_S"
    draw_range = (0.5, 6.0)  # shorter or longer than the robot's 3 s reply timeout

    def carry_out(self, link: LinkControl) -> bool:
        _log.info("fault %s: the brick stops answering for %g s", self.fault.text, self.fault.arg)
        link.stall(self.fault.arg)
        return False


# -- the sensor -------------------------------------------------------------------------------------
class SonarFault(FaultKind):
    """A fault kind of the virtual brick's ultrasonic sensor (built in, or a plug-in of one's own).

    A subclass sets ``name`` in its body (the KIND of ``KIND:AT_S:ARG``; that registers it in
    `FAULT_CLASSES`), ``arg_name`` and ``arg_rule`` (what ARG is, for messages), may narrow `arg_ok`,
    and implements `reading`. The `FaultSchedule` builds one instance per scheduled fault of the kind
    (so it may keep state) and, for every reading at or after AT_S, asks it for the reading the sensor
    gives instead; the fault has fired (and acted once more) at every reading it returns.

    What the suite and the brick demand of one (``docs/howto/fault.md`` shows one that passes):

    - ``name`` differs from the built-in kinds (`FAULT_KINDS`) and has no colon;
    - `reading` returns a whole number of cm in 0..255 (255: no echo) or None (left alone), and draws
      every random number from the `rng` it is given (the schedule's seeded stream), so that a seed
      gives the same readings every time;
    - a bad ARG is refused by `arg_ok`, so ``parse_fault`` says ``ARG_NAME must be ARG_RULE``.

    Set `draw_range` for ``nxtnav bench faults`` to draw the kind.
    """

    acts_on = "sensor"

    @abstractmethod
    def reading(self, value: int, time_s: float, rng: np.random.Generator) -> int | None:
        """The reading (whole cm, 0..255) the sensor gives instead of `value` at brick time `time_s` (s, at
        or after the fault's AT_S), or None when the fault leaves this reading alone."""

    def seen(self, reading: int) -> None:
        """Told the reading the sensor gave, after every reading (before AT_S too); default: nothing."""


class SonarStuck(SonarFault):
    """``sonar-stuck:AT_S:DUR_S``: from brick time AT_S the sensor repeats its last reading for DUR_S brick s."""

    name = "sonar-stuck"
    arg_name = "DUR_S"
    arg_rule = "> 0 brick seconds"
    draw_range = (1.0, 7.0)  # real stuck arcs span 50-250 degrees: 1.4-6.9 s at 27 ms a degree

    def __init__(self, fault: Fault) -> None:
        super().__init__(fault)
        self._last: int | None = None
        self._held: int | None = None
        self._holding = False

    @classmethod
    def arg_ok(cls, arg: float) -> bool:
        return math.isfinite(arg) and arg > 0

    def reading(self, value: int, time_s: float, rng: np.random.Generator) -> int | None:
        if time_s >= self.fault.at_s + self.fault.arg:
            return None
        if not self._holding:
            self._held, self._holding = self._last, True
        return self._held

    def seen(self, reading: int) -> None:
        self._last = reading


class SonarGarbage(SonarFault):
    """``sonar-garbage:[AT_S:]P``: each reading (from AT_S, default 0) is replaced with probability P by a
    random value from 0 to 255."""

    name = "sonar-garbage"
    arg_name = "P"
    arg_rule = "a probability in (0, 1]"
    at_optional = True
    draw_range = (0.02, 0.3)
    drawn_from_start = True

    @classmethod
    def arg_ok(cls, arg: float) -> bool:
        return 0 < arg <= 1

    def reading(self, value: int, time_s: float, rng: np.random.Generator) -> int | None:
        return int(rng.integers(0, 256)) if rng.random() < self.fault.arg else None


# -- the wheels -------------------------------------------------------------------------------------
class WheelFault(FaultKind):
    """A fault of the drive wheels: it changes how far the robot moves for the tacho travel of a motion."""

    acts_on = "wheels"

    @abstractmethod
    def take(self, port: int, wheels: tuple[int, int], time_s: float) -> tuple[float, bool] | None:
        """For the motion commanded now on drive wheel `port` (at or after AT_S; `wheels`: the left and
        right output ports), the fraction of its tacho travel that moves the robot and whether the fault
        has now acted once more; None when the fault leaves this motion alone."""


class MotorSlip(WheelFault):
    """``motor-slip:AT_S:FRACTION``: the first motion of the wheels commanded at or after AT_S (a drive, or a
    turn on the spot) moves the robot only FRACTION of what their tachometers count."""

    name = "motor-slip"
    arg_name = "FRACTION"
    arg_rule = "a fraction in [0, 1]"
    draw_range = (0.5, 0.9)

    def __init__(self, fault: Fault) -> None:
        super().__init__(fault)
        self._taken: set[int] = set()

    @classmethod
    def arg_ok(cls, arg: float) -> bool:
        return 0 <= arg <= 1

    def take(self, port: int, wheels: tuple[int, int], time_s: float) -> tuple[float, bool] | None:
        if port in self._taken or len(self._taken) >= len(wheels):
            return None
        self._taken.add(port)
        return self.fault.arg, len(self._taken) == len(wheels)


FAULT_KINDS = tuple(_BUILT_IN)
"""Every fault the virtual brick makes without a plug-in, in the order this module defines them."""
LINK_FAULTS = tuple(k for k in FAULT_KINDS if issubclass(FAULT_CLASSES.get(k), LinkFault))
"""Built-in faults of the link: their durations are wall-clock seconds, and the server carries them out."""
SONAR_FAULTS = tuple(k for k in FAULT_KINDS if issubclass(FAULT_CLASSES.get(k), SonarFault))
"""Built-in faults of the ultrasonic sensor."""


@dataclass(frozen=True)
class Fault:
    """One scheduled fault.

    Attributes
    ----------
    kind : str
        A registered fault kind (`known_fault_kinds`).
    at_s : float
        Brick time (s) at which it fires.
    arg : float
        Its argument: link down or stall time (wall s), stuck time (brick s), garbage probability, or
        the fraction of the tacho travel a slipping motion drives (the kind's `FaultKind.arg_name`).
    """

    kind: str
    at_s: float
    arg: float

    def __post_init__(self) -> None:
        cls = fault_class(self.kind)
        if not (math.isfinite(self.at_s) and self.at_s >= 0):
            raise ConfigError(f"fault {self.kind}: AT_S must be a time >= 0 s, got {self.at_s!r}")
        if not cls.arg_ok(self.arg):
            raise ConfigError(f"fault {self.kind}: {cls.arg_name} must be {cls.arg_rule}, got {self.arg!r}")

    @property
    def text(self) -> str:
        """The fault as it is written on the command line."""
        return f"{self.kind}:{self.at_s:g}:{self.arg:g}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "at_s": self.at_s, "arg": self.arg}


def parse_fault(text: str) -> Fault:
    """A `Fault` from ``KIND:AT_S[:ARG]`` (see the module docstring); `ConfigError` says what is wrong."""
    parts = [p.strip() for p in str(text).split(":")]
    kind = parts[0]
    if kind not in FAULT_CLASSES:
        raise ConfigError(f"fault {text!r}: unknown kind {kind!r}; known: {', '.join(known_fault_kinds())}")
    cls = FAULT_CLASSES.get(kind)
    numbers = parts[1:]
    shape = f"{kind}:AT_S:{cls.arg_name}"
    if cls.at_optional:
        shape = f"{kind}:[AT_S:]{cls.arg_name}"
        if len(numbers) == 1:
            numbers = ["0", numbers[0]]
    if len(numbers) != 2:
        raise ConfigError(f"fault {text!r}: expected {shape}")
    values = []
    for name, v in zip(("AT_S", cls.arg_name), numbers, strict=True):
        try:
            values.append(float(v))
        except ValueError:
            raise ConfigError(f"fault {text!r}: {name} must be a number, got {v!r}") from None
    try:
        return Fault(kind, values[0], values[1])
    except ConfigError as exc:
        raise ConfigError(f"fault {text!r}: {str(exc).split(': ', 1)[1]}") from None


@dataclass(frozen=True)
class Fired:
    """When a fault fired: brick time (s) and the wall clock (`time.monotonic`, s)."""

    time_s: float
    wall_s: float


class FaultSchedule:
    """The faults of one virtual brick and what they did (see the module docstring).

    Parameters
    ----------
    faults : sequence of Fault or str
        The faults (parsed when given as text).
    rng : None, int or Generator
        Seed of the garbage readings.
    on_fire : callable, optional
        Told ``(fault, fired)`` the moment each fault fires (from the brick's threads).
    """

    def __init__(self, faults: Sequence[Fault | str] = (), rng: RngLike = None,
                 on_fire: Callable[[Fault, Fired], None] | None = None) -> None:
        self.faults = tuple(f if isinstance(f, Fault) else parse_fault(f) for f in faults)
        self.on_fire = on_fire
        self._rng = as_rng(rng)
        self._lock = threading.Lock()
        self._events = [threading.Event() for _ in self.faults]
        self.fired: list[Fired | None] = [None] * len(self.faults)
        self.acted = [0] * len(self.faults)
        self._kinds = [fault_class(f.kind)(f) for f in self.faults]

    def __bool__(self) -> bool:
        return bool(self.faults)

    def _fire(self, i: int, time_s: float) -> None:
        if self.fired[i] is None:
            fired = self.fired[i] = Fired(float(time_s), time.monotonic())
            if self.on_fire is not None:
                self.on_fire(self.faults[i], fired)
            self._events[i].set()

    def _act(self, i: int, time_s: float) -> None:
        self._fire(i, time_s)
        self.acted[i] += 1

    def kind(self, index: int) -> FaultKind:
        """The instance of its kind that carries out fault `index` (its rules and its state)."""
        return self._kinds[index]

    # -- the link ---------------------------------------------------------------------------------
    def due(self, time_s: float, kinds: Sequence[str] | None = None) -> list[int]:
        """Indices of the link faults (`LinkFault`; only those of `kinds` when given) whose time has come at
        brick time `time_s` and that had not fired yet; they count as fired now (the caller carries them
        out, `carry_out`)."""
        with self._lock:
            out = [i for i, f in enumerate(self.faults)
                   if isinstance(self._kinds[i], LinkFault) and (kinds is None or f.kind in kinds)
                   and self.fired[i] is None and time_s >= f.at_s]
            for i in out:
                self._act(i, time_s)
            return out

    def carry_out(self, time_s: float, link: LinkControl) -> bool:
        """Carry out on `link` the link faults due at brick time `time_s`; True when one dropped the link."""
        dropped = False
        for i in self.due(time_s):
            kind = self._kinds[i]
            assert isinstance(kind, LinkFault)
            dropped |= kind.carry_out(link)
        return dropped

    def wait(self, index: int, timeout: float | None = None) -> bool:
        """Block until fault `index` has fired (or `timeout` seconds); True when it has."""
        return self._events[index].wait(timeout)

    # -- the sensor -------------------------------------------------------------------------------
    def sonar(self, value: int, time_s: float) -> int:
        """The reading the sensor gives at brick time `time_s` when the sonar model measured `value`: every
        sensor fault (`SonarFault`) at or after its time may replace it, in the order they were scheduled."""
        with self._lock:
            out = value
            sensor = [(i, k) for i, k in enumerate(self._kinds) if isinstance(k, SonarFault)]
            for i, kind in sensor:
                if time_s < self.faults[i].at_s:
                    continue
                changed = kind.reading(out, time_s, self._rng)
                if changed is not None:
                    self._act(i, time_s)
                    out = int(min(max(round(changed), 0), 255))
            for _, kind in sensor:
                kind.seen(out)
            return out

    # -- the wheels -------------------------------------------------------------------------------
    def slip(self, port: int, wheels: tuple[int, int], time_s: float) -> float | None:
        """The fraction of its tacho travel that drive wheel `port` moves the robot for the motion
        commanded now, when a wheel fault (`WheelFault`, such as motor-slip) takes it (None: no fault).
        `wheels` are the left and right output ports."""
        with self._lock:
            for i, kind in enumerate(self._kinds):
                if not isinstance(kind, WheelFault) or time_s < self.faults[i].at_s:
                    continue
                taken = kind.take(port, wheels, time_s)
                if taken is None:
                    continue
                self._fire(i, time_s)
                if taken[1]:
                    self.acted[i] += 1
                return taken[0]
            return None

    # -- reporting --------------------------------------------------------------------------------
    def to_dict(self) -> list[dict[str, Any]]:
        """Per fault: its spec, when it fired (brick s; null when it did not) and how often it acted."""
        return [{**f.to_dict(), "fired_at_s": None if fired is None else fired.time_s, "acted": n}
                for f, fired, n in zip(self.faults, self.fired, self.acted, strict=True)]
