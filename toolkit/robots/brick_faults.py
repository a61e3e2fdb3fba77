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

A fault kind of one's own for the sensor is a `SonarFault` subclass with a ``name`` (see its docstring
and ``docs/howto/fault.md``): once its module is imported, ``KIND:AT_S:ARG`` schedules it like the kinds
above.

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

import math
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..world import ConfigError, Registry, RngLike, as_rng

__all__ = ["FAULT_KINDS", "LINK_FAULTS", "SONAR_FAULTS", "SONAR_FAULT_PLUGINS", "Fault", "FaultSchedule", "Fired",
           "SonarFault", "parse_fault"]

FAULT_KINDS = ("drop-link", "stall", "sonar-stuck", "sonar-garbage", "motor-slip")
"""Every fault the virtual brick can make."""
LINK_FAULTS = ("drop-link", "stall")
"""Faults of the link: their durations are wall-clock seconds, and the server carries them out."""
SONAR_FAULTS = ("sonar-stuck", "sonar-garbage")
"""Faults of the ultrasonic sensor."""

_ARG_NAMES = {"drop-link": "DOWN_S", "stall": "DUR_S", "sonar-stuck": "DUR_S", "sonar-garbage": "P",
              "motor-slip": "FRACTION"}
_MAX_WAIT_S = 3600.0


class SonarFault(ABC):
    """A fault kind of one's own for the virtual brick's ultrasonic sensor (a plug-in).

    A subclass sets ``name`` in its body (the KIND of ``KIND:AT_S:ARG``; that registers it in
    `SONAR_FAULT_PLUGINS`), ``arg_name`` and ``arg_rule`` (what ARG is, for messages), may narrow
    `arg_ok`, and implements `reading`. The `FaultSchedule` builds one instance per scheduled fault of
    the kind (so it may keep state) and, for every reading at or after AT_S, asks it for the reading the
    sensor gives instead; the fault has fired (and acted once more) at every reading it returns.

    What the suite and the brick demand of one (``docs/howto/fault.md`` shows one that passes):

    - ``name`` differs from the built-in kinds (`FAULT_KINDS`) and has no colon;
    - `reading` returns a whole number of cm in 0..255 (255: no echo) or None (left alone), and draws
      every random number from the `rng` it is given (the schedule's seeded stream), so that a seed
      gives the same readings every time;
    - a bad ARG is refused by `arg_ok`, so ``parse_fault`` says ``ARG_NAME must be ARG_RULE``.

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

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__:
            if cls.name in FAULT_KINDS or ":" in cls.name:
                raise ConfigError(f"sonar fault kind {cls.name!r} is a built-in kind's name or has a colon")
            SONAR_FAULT_PLUGINS.add(cls.name, cls)

    def __init__(self, fault: Fault) -> None:
        self.fault = fault

    @classmethod
    def arg_ok(cls, arg: float) -> bool:
        """Whether `arg` is an allowed ARG (default: any finite number)."""
        return math.isfinite(arg)

    @abstractmethod
    def reading(self, value: int, time_s: float, rng: np.random.Generator) -> int | None:
        """The reading (whole cm, 0..255) the sensor gives instead of `value` at brick time `time_s` (s, at
        or after the fault's AT_S), or None when the fault leaves this reading alone."""


SONAR_FAULT_PLUGINS: Registry[SonarFault] = Registry("sonar fault kind")
"""Sensor fault kinds of one's own (`SonarFault` subclasses), by name."""


def _known_kinds() -> list[str]:
    return [*FAULT_KINDS, *SONAR_FAULT_PLUGINS.names()]


def _arg_name(kind: str) -> str:
    return _ARG_NAMES[kind] if kind in _ARG_NAMES else SONAR_FAULT_PLUGINS.get(kind).arg_name


@dataclass(frozen=True)
class Fault:
    """One scheduled fault.

    Attributes
    ----------
    kind : str
        One of `FAULT_KINDS`.
    at_s : float
        Brick time (s) at which it fires.
    arg : float
        Its argument: link down or stall time (wall s), stuck time (brick s), garbage probability, or
        the fraction of the tacho travel a slipping motion drives.
    """

    kind: str
    at_s: float
    arg: float

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS and self.kind not in SONAR_FAULT_PLUGINS:
            raise ConfigError(f"unknown fault kind {self.kind!r}; known: {', '.join(_known_kinds())}")
        if not (math.isfinite(self.at_s) and self.at_s >= 0):
            raise ConfigError(f"fault {self.kind}: AT_S must be a time >= 0 s, got {self.at_s!r}")
        name = _arg_name(self.kind)
        a = self.arg
        if self.kind in SONAR_FAULT_PLUGINS:
            plugin = SONAR_FAULT_PLUGINS.get(self.kind)
            ok, rule = plugin.arg_ok(a), plugin.arg_rule
        elif self.kind in ("drop-link", "stall"):
            ok, rule = math.isfinite(a) and 0 < a <= _MAX_WAIT_S, f"in (0, {_MAX_WAIT_S:g}] wall-clock seconds"
        elif self.kind == "sonar-stuck":
            ok, rule = math.isfinite(a) and a > 0, "> 0 brick seconds"
        elif self.kind == "sonar-garbage":
            ok, rule = 0 < a <= 1, "a probability in (0, 1]"
        else:
            ok, rule = 0 <= a <= 1, "a fraction in [0, 1]"
        if not ok:
            raise ConfigError(f"fault {self.kind}: {name} must be {rule}, got {a!r}")

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
    if kind not in FAULT_KINDS and kind not in SONAR_FAULT_PLUGINS:
        raise ConfigError(f"fault {text!r}: unknown kind {kind!r}; known: {', '.join(_known_kinds())}")
    numbers = parts[1:]
    shape = f"{kind}:AT_S:{_arg_name(kind)}"
    if kind == "sonar-garbage" and len(numbers) == 1:
        numbers = ["0", numbers[0]]
        shape = "sonar-garbage:[AT_S:]P"
    if len(numbers) != 2:
        raise ConfigError(f"fault {text!r}: expected {shape}")
    values = []
    for name, v in zip(("AT_S", _arg_name(kind)), numbers, strict=True):
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
        self._last_reading: int | None = None
        self._stuck_value: dict[int, int | None] = {}
        self._slipped: dict[int, set[int]] = {}
        self._plugins = {i: SONAR_FAULT_PLUGINS.get(f.kind)(f) for i, f in enumerate(self.faults)
                         if f.kind in SONAR_FAULT_PLUGINS}

    def __bool__(self) -> bool:
        return bool(self.faults)

    def _fire(self, i: int, time_s: float) -> None:
        if self.fired[i] is None:
            fired = self.fired[i] = Fired(float(time_s), time.monotonic())
            if self.on_fire is not None:
                self.on_fire(self.faults[i], fired)
            self._events[i].set()

    def due(self, time_s: float, kinds: Sequence[str] = LINK_FAULTS) -> list[int]:
        """Indices of the faults of `kinds` whose time has come at brick time `time_s` and that had not
        fired yet; they count as fired now (the caller carries them out)."""
        with self._lock:
            out = [i for i, f in enumerate(self.faults)
                   if f.kind in kinds and self.fired[i] is None and time_s >= f.at_s]
            for i in out:
                self._fire(i, time_s)
                self.acted[i] += 1
            return out

    def wait(self, index: int, timeout: float | None = None) -> bool:
        """Block until fault `index` has fired (or `timeout` seconds); True when it has."""
        return self._events[index].wait(timeout)

    # -- the sensor -------------------------------------------------------------------------------
    def sonar(self, value: int, time_s: float) -> int:
        """The reading the sensor gives at brick time `time_s` when the sonar model measured `value`."""
        with self._lock:
            out = value
            for i, f in enumerate(self.faults):
                if f.kind == "sonar-stuck" and f.at_s <= time_s < f.at_s + f.arg:
                    if i not in self._stuck_value:
                        self._stuck_value[i] = self._last_reading
                    held = self._stuck_value[i]
                    if held is not None:
                        self._fire(i, time_s)
                        self.acted[i] += 1
                        out = held
                elif f.kind == "sonar-garbage" and time_s >= f.at_s and self._rng.random() < f.arg:
                    self._fire(i, time_s)
                    self.acted[i] += 1
                    out = int(self._rng.integers(0, 256))
                elif i in self._plugins and time_s >= f.at_s:
                    changed = self._plugins[i].reading(out, time_s, self._rng)
                    if changed is not None:
                        self._fire(i, time_s)
                        self.acted[i] += 1
                        out = int(min(max(round(changed), 0), 255))
            self._last_reading = out
            return out

    # -- the wheels -------------------------------------------------------------------------------
    def slip(self, port: int, wheels: tuple[int, int], time_s: float) -> float | None:
        """The fraction of its tacho travel that drive wheel `port` moves the robot for the motion
        commanded now, when a motor-slip fault takes it (None: no fault). A fault takes the next
        command of each of the two `wheels` (left and right output ports) at or after its time."""
        with self._lock:
            for i, f in enumerate(self.faults):
                if f.kind != "motor-slip" or time_s < f.at_s:
                    continue
                taken = self._slipped.setdefault(i, set())
                if port in taken or len(taken) >= len(wheels):
                    continue
                taken.add(port)
                self._fire(i, time_s)
                if len(taken) == len(wheels):
                    self.acted[i] += 1
                return f.arg
            return None

    # -- reporting --------------------------------------------------------------------------------
    def to_dict(self) -> list[dict[str, Any]]:
        """Per fault: its spec, when it fired (brick s; null when it did not) and how often it acted."""
        return [{**f.to_dict(), "fired_at_s": None if fired is None else fired.time_s, "acted": n}
                for f, fired, n in zip(self.faults, self.fired, self.acted, strict=True)]
