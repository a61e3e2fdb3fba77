"""The simulated robot behind the virtual NXT brick: motors, turret, ultrasonic sensor and the truth.

`BrickWorld` holds the true pose of a differential-drive robot in a `Map`, three NXT motors (two
drive wheels and the sensor turret) and the ultrasonic sensor. Motors follow the commands the
firmware accepts (power, mode flags, run state, tacho limit): a driven motor turns at
``power * deg_per_s_per_power`` deg/s, reached with a bounded acceleration, and a tacho-limited motor
slows down to stop exactly at its limit; a braked motor holds; an unpowered motor coasts to a stop.
The wheels move the robot (exact arc integration); the robot disc never passes through a wall: a
step that would touch one ends at the contact (found with the shared `CollisionChecker`), the
wheels stall there, and the contact counts as one collision.

The clock
---------
Brick time advances when a client waits on the brick (every telegram that wants a reply, see
`advance`), and in real time also on its own (``free_run``): by the wall time since the previous
advance times ``time_factor``, but by at most ``max_step_s``. The cap keeps fast simulations
faithful when the machine is busy: a client that is descheduled does not come back to find its
robot far along its path, unwatched. Telegrams that need no reply
(set output state, set input mode) act at the current brick instant, so two motors started by two
consecutive commands start together, as they do on a brick.
"""

from __future__ import annotations

import json
import logging
import math
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numpy as np

from ..world import (
    CollisionChecker,
    ConfigError,
    Map,
    Pose,
    RngLike,
    RobotError,
    RobotGeometry,
    SonarModel,
    as_rng,
    wrap_angle,
)
from .brick_faults import FaultSchedule
from .sim import simulated_sonar

__all__ = [
    "BrickConfig",
    "BrickWorld",
    "Motor",
    "MotorMode",
    "RunState",
    "SensorType",
    "UltrasonicSensor",
]

_log = logging.getLogger(__name__)


class MotorMode:
    """Output mode flags."""

    ON = 0x01
    BRAKE = 0x02
    REGULATED = 0x04


class RunState:
    """Output run states."""

    IDLE = 0x00
    RAMP_UP = 0x10
    RUNNING = 0x20
    RAMP_DOWN = 0x40


class SensorType:
    """Input sensor types the brick distinguishes."""

    NO_SENSOR = 0x00
    LOW_SPEED = 0x0A
    LOW_SPEED_9V = 0x0B


@dataclass(frozen=True)
class BrickConfig:
    """Physical constants and wiring of the simulated robot.

    Parameters
    ----------
    geometry : RobotGeometry
        True robot constants: disc radius, wheel diameter, track width, turret gearing and sensor
        offset (cm). A calibration test gives the brick different values from the client's profile.
    left_port, right_port, turret_port : int
        Output ports (0 = A, 1 = B, 2 = C) of the left wheel, right wheel and turret motors. A positive
        power drives a wheel forward and turns the turret counter-clockwise.
    sonar_port : int
        Input port of the ultrasonic sensor (0 = port 1 ... 3 = port 4).
    deg_per_s_per_power : float
        Motor speed per unit of power (deg/s); 8 gives 800 deg/s at full power, a loaded NXT motor.
    accel_deg_s2 : float
        Largest motor acceleration (deg/s^2) when speeding up or slowing to a tacho limit.
    coast_decel_deg_s2 : float
        Deceleration of an unpowered (coasting) motor (deg/s^2).
    substep_s : float
        Integration step (brick seconds).
    time_factor : float
        Brick seconds per wall second (> 1 runs faster than real time).
    max_step_s : float
        Largest brick-time advance at one exchange (s), see the module docstring.
    free_run : bool or None
        Whether brick time also advances while no client talks (a server thread ticks the clock every
        few milliseconds), as on a real brick. None: only in real time or slower (time_factor <= 1),
        where scripts that sleep while the motors run expect them to keep turning.
    i2c_pending_polls : int
        How many status polls after an I2C read request still answer "transaction pending", as a
        real bus does for a few milliseconds (0 = the answer is ready at once).
    wheel_slip : float
        Standard deviation of the fraction by which a drive wheel's ground travel differs from its
        tacho count; drawn per wheel for every new motor command (0 = no slip).
    brake_decel_deg_s2 : float or None
        None: ideal regulation, a tacho-limited motor stops exactly on its limit and a brake stops a
        motor at once. A number: the motor runs at speed up to its limit and then brakes at this
        deceleration (deg/s^2), overshooting by speed^2 / (2 * decel) as a real NXT motor does.
    latency_s : float or None
        Brick seconds that one telegram wanting a reply costs: the link's round trip (a few
        milliseconds over USB, tens over Bluetooth). Set, brick time advances by exactly this per
        such telegram and never with the wall clock, so robot times are reproducible and do not
        depend on the machine's load; None: the wall-clock rule of the module docstring.
    battery_mv : int
        Battery voltage reported (mV).
    name : str
        Brick name (at most 14 characters).
    brake_on_disconnect : bool
        True: when the connection that started a motor's motion goes away, that motor is braked (a
        safety net of the simulator). False: the motors run on after a lost link, as a real NXT's
        firmware keeps them running when the USB or Bluetooth link drops; only their tacho limits
        stop them (what `toolkit.robots.nxt.NxtRobot` relies on).
    reassembly_s : float
        Wall-clock seconds the server waits for the rest of a telegram that TCP delivered in pieces
        before it answers the piece as a malformed telegram (0.25 s: far longer than any gap inside
        one write on a working link, short enough that a client which really sent half a telegram
        hears back quickly).
    """

    geometry: RobotGeometry = field(default_factory=RobotGeometry)
    left_port: int = 0
    right_port: int = 1
    turret_port: int = 2
    sonar_port: int = 3
    deg_per_s_per_power: float = 8.0
    accel_deg_s2: float = 6000.0
    coast_decel_deg_s2: float = 2000.0
    substep_s: float = 0.005
    time_factor: float = 1.0
    max_step_s: float = 0.02
    free_run: bool | None = None
    i2c_pending_polls: int = 0
    wheel_slip: float = 0.0
    brake_decel_deg_s2: float | None = None
    latency_s: float | None = None
    battery_mv: int = 8000
    name: str = "nxtnav-virtual"
    brake_on_disconnect: bool = True
    reassembly_s: float = 0.25

    def __post_init__(self) -> None:
        ports = (self.left_port, self.right_port, self.turret_port)
        if len(set(ports)) != 3 or not all(p in (0, 1, 2) for p in ports):
            raise ConfigError(f"motor ports must be three different values of 0, 1, 2; got {ports}")
        if self.sonar_port not in (0, 1, 2, 3):
            raise ConfigError(f"sonar_port must be 0..3, got {self.sonar_port}")
        for k in ("deg_per_s_per_power", "accel_deg_s2", "coast_decel_deg_s2", "substep_s", "time_factor",
                  "max_step_s", "brake_decel_deg_s2", "reassembly_s"):
            v = getattr(self, k)
            if v is None and k == "brake_decel_deg_s2":
                continue
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ConfigError(f"BrickConfig.{k} must be a positive number, got {v!r}")
        if self.latency_s is not None and not (math.isfinite(self.latency_s) and 0 < self.latency_s <= 1):
            raise ConfigError(f"BrickConfig.latency_s must be in (0, 1] s or None, got {self.latency_s!r}")
        if not (isinstance(self.i2c_pending_polls, int) and 0 <= self.i2c_pending_polls <= 20):
            raise ConfigError(f"BrickConfig.i2c_pending_polls must be 0..20, got {self.i2c_pending_polls!r}")
        if not (math.isfinite(self.wheel_slip) and 0 <= self.wheel_slip < 0.5):
            raise ConfigError(f"BrickConfig.wheel_slip must be in [0, 0.5), got {self.wheel_slip!r}")
        if len(self.name.encode("ascii", "replace")) > 14:
            raise ConfigError(f"brick name must be at most 14 characters, got {self.name!r}")


@dataclass
class Motor:
    """One NXT output: the commanded state and the mechanics (angles in degrees)."""

    power: int = 0
    mode: int = 0
    regulation: int = 0
    turn_ratio: int = 0
    run_state: int = RunState.IDLE
    tacho_limit: int = 0
    position: float = 0.0
    speed: float = 0.0
    goal_origin: float = 0.0
    block_origin: float = 0.0
    rotation_origin: float = 0.0

    @property
    def driven(self) -> bool:
        """Whether the firmware is powering the motor toward a speed."""
        return bool(self.mode & MotorMode.ON) and self.run_state != RunState.IDLE and self.power != 0

    @property
    def moving(self) -> bool:
        return self.speed != 0.0 or self.driven

    def command(self, power: int, mode: int, regulation: int, turn_ratio: int, run_state: int,
                tacho_limit: int) -> None:
        """Apply a SET_OUTPUT_STATE: a new goal counted from the current position."""
        self.power = max(-100, min(100, int(power)))
        self.mode, self.regulation, self.turn_ratio = int(mode), int(regulation), int(turn_ratio)
        self.run_state, self.tacho_limit = int(run_state), int(tacho_limit)
        self.goal_origin = self.position

    def stop(self) -> None:
        """Brake to a standstill now (what the brick does when its client vanishes)."""
        self.power, self.mode, self.regulation = 0, MotorMode.ON | MotorMode.BRAKE, 0
        self.run_state, self.tacho_limit, self.speed = RunState.IDLE, 0, 0.0

    def counts(self) -> tuple[int, int, int]:
        """(tacho count, block tacho count, rotation count), whole degrees."""
        return (round(self.position), round(self.position - self.block_origin),
                round(self.position - self.rotation_origin))

    def step(self, dt: float, cfg: BrickConfig) -> float:
        """Advance `dt` brick seconds; return the angle turned (deg)."""
        a = cfg.accel_deg_s2
        exact = cfg.brake_decel_deg_s2 is None
        if self.driven:
            sign = 1.0 if self.power > 0 else -1.0
            target = self.power * cfg.deg_per_s_per_power
            remaining = math.inf
            if self.tacho_limit > 0:
                remaining = self.tacho_limit - sign * (self.position - self.goal_origin)
                if remaining <= 1e-9:
                    self._reach_limit(exact)
                    return self.step(dt, cfg) if self.speed else 0.0
                if exact:  # ideal regulation: slow down to stop on the limit
                    target = sign * min(abs(target), math.sqrt(2.0 * a * remaining) + a * dt)
            new_speed = self.speed + max(-a * dt, min(a * dt, target - self.speed))
            turned = 0.5 * (self.speed + new_speed) * dt
            self.speed = new_speed
            if sign * turned >= remaining:
                turned = sign * remaining
                self._reach_limit(exact)
            self.position += turned
            return turned
        if self.mode & MotorMode.ON and self.mode & MotorMode.BRAKE:
            if exact or cfg.brake_decel_deg_s2 is None:
                self.speed = 0.0
                return 0.0
            return self._slow(dt, cfg.brake_decel_deg_s2)
        if self.speed == 0.0:
            return 0.0
        return self._slow(dt, cfg.coast_decel_deg_s2)

    def _slow(self, dt: float, decel: float) -> float:
        d = decel * dt
        new_speed = 0.0 if abs(self.speed) <= d else self.speed - math.copysign(d, self.speed)
        turned = 0.5 * (self.speed + new_speed) * dt
        if new_speed == 0.0 and self.speed != 0.0:  # stops within the step
            turned = 0.5 * self.speed * abs(self.speed) / decel
        self.speed = new_speed
        self.position += turned
        return turned

    def _reach_limit(self, exact: bool) -> None:
        """The tacho limit is reached: the firmware reports idle; an ideal motor stops on the spot,
        a real one brakes (or coasts) past the limit."""
        self.run_state = RunState.IDLE
        if exact:
            self.speed = 0.0


# The LEGO ultrasonic sensor's I2C registers (device address 0x02). The identification strings are
# read as blocks starting at their own addresses (the 8-byte type string at 0x10 overlaps the
# one-byte factory constants at 0x11-0x13 and the units string at 0x14, as on the real sensor);
# every other address is a plain byte register. Measurement registers are filled by `BrickWorld`.
_US_IDENT = {0x00: b"V1.0\0\0\0\0", 0x08: b"LEGO\0\0\0\0", 0x10: b"Sonar\0\0\0", 0x14: b"10E-2m\0"}
US_I2C_ADDRESS = 0x02
US_REG_INTERVAL = 0x40
US_REG_COMMAND = 0x41
US_REG_DISTANCE = 0x42
US_CMD_OFF, US_CMD_SINGLE_SHOT, US_CMD_CONTINUOUS, US_CMD_EVENT, US_CMD_RESET = 0, 1, 2, 3, 4


@dataclass
class UltrasonicSensor:
    """The sensor's registers (a 256-byte I2C register file) and its measuring mode."""

    registers: bytearray = field(default_factory=lambda: bytearray(256))
    readings: int = 0

    def __post_init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.registers[:] = bytes(256)
        self.registers[0x12] = 1  # factory scale factor
        self.registers[0x13] = 1  # factory scale divisor
        self.registers[0x51] = 1  # actual scale factor
        self.registers[0x52] = 1  # actual scale divisor
        self.registers[US_REG_INTERVAL] = 1
        self.registers[US_REG_COMMAND] = US_CMD_CONTINUOUS
        self.registers[US_REG_DISTANCE:US_REG_DISTANCE + 8] = bytes([255] * 8)

    @property
    def command(self) -> int:
        return self.registers[US_REG_COMMAND]

    def read(self, reg: int, n: int) -> bytes:
        """What an I2C read of `n` bytes starting at register `reg` returns."""
        if reg in _US_IDENT:
            return _US_IDENT[reg][:n].ljust(n, b"\0")
        return bytes(self.registers[reg:min(256, reg + n)]).ljust(n, b"\0")

    def store(self, distance_cm: int) -> None:
        """Store one measurement: the first echo, later echo slots empty (255)."""
        self.registers[US_REG_DISTANCE] = max(0, min(255, int(distance_cm)))
        self.registers[US_REG_DISTANCE + 1:US_REG_DISTANCE + 8] = bytes([255] * 7)
        self.readings += 1


@dataclass
class InputPort:
    """An input port: its configured type and mode, and the pending low-speed (I2C) transaction."""

    sensor_type: int = SensorType.NO_SENSOR
    mode: int = 0
    rx: bytes = b""
    status: int = 0
    pending: int = 0


class BrickWorld:
    """The robot, its motors and sensors, the clock and the truth log of the virtual brick.

    Parameters
    ----------
    map : Map
        The world the robot drives in.
    pose : Pose
        True start pose; must be collision-free for the robot disc.
    config : BrickConfig
        Wiring and physical constants.
    sonar : SonarModel or str
        Sonar model answering distance reads, or its name (``ideal`` or ``nxt``, see
        `toolkit.robots.sim.simulated_sonar`); a fitted profile's `NxtSonar` is passed as a model.
    sensor_noise : float
        Noise (cm) of the ``ideal`` sonar given by name; the ``nxt`` sonar's comes from its model.
    rng : None, int or Generator
        Seed of the sonar noise.
    log : path, text file or None
        Truth log: one JSON object per line after every robot motion (see `log_record`).
    clock : callable or None
        Wall clock in seconds (default `time.monotonic`); tests may pass their own.
    faults : FaultSchedule, optional
        Scheduled faults (`toolkit.robots.brick_faults`); the world carries out those of the sensor
        and the wheels, the server those of the link.
    """

    def __init__(
        self,
        map: Map,
        pose: Pose,
        config: BrickConfig | None = None,
        *,
        sonar: SonarModel | str = "ideal",
        sensor_noise: float = 1.0,
        rng: RngLike = None,
        log: str | Path | IO[str] | None = None,
        clock: Callable[[], float] | None = None,
        faults: FaultSchedule | None = None,
    ) -> None:
        self.map = map
        self.faults = faults if faults is not None else FaultSchedule()
        self.config = config or BrickConfig()
        self.geometry = self.config.geometry
        self.checker = CollisionChecker(map, self.geometry.radius_cm)
        if not self.checker.point_free(pose.xy):
            raise RobotError(
                f"start pose ({pose.x:g}, {pose.y:g}) puts the robot (radius {self.geometry.radius_cm:g} cm) "
                f"in collision or outside map {map.name!r}"
            )
        self.sonar = simulated_sonar(sonar, sensor_noise)
        self.rng = as_rng(rng)
        self._slip_rng = self.rng.spawn(1)[0]
        self._slip = [0.0, 0.0, 0.0]
        self.lock = threading.RLock()
        self._clock: Callable[[], float] = clock if clock is not None else time.monotonic
        self._pose = pose
        self.motors = [Motor(), Motor(), Motor()]
        self.inputs = [InputPort(), InputPort(), InputPort(), InputPort()]
        self.ultrasonic = UltrasonicSensor()
        self.time_s = 0.0
        self._last_wall = float(self._clock())
        self.collisions = 0
        self.in_contact = False
        self.motions = 0
        self._was_moving = False
        self._free_budget = 0.0
        self._own_log = False
        self._log: IO[str] | None
        if log is None or hasattr(log, "write"):
            self._log = log  # type: ignore[assignment]
        else:
            self._log = open(log, "a", encoding="utf-8")
            self._own_log = True

    # -- truth ------------------------------------------------------------------------------------
    @property
    def pose(self) -> Pose:
        """The true pose of the robot (cm, rad)."""
        with self.lock:
            return self._pose

    @property
    def true_pose(self) -> Pose:
        """The true pose (`pose`): the world is a `toolkit.world.TruthSource` for mission reports."""
        return self.pose

    @property
    def turret_angle(self) -> float:
        """Sensor direction relative to the robot heading (rad)."""
        return math.radians(self.motors[self.config.turret_port].position / self.geometry.turret_gear_ratio)

    @property
    def free_running(self) -> bool:
        """Whether the clock should also tick without client traffic (see `BrickConfig.free_run`)."""
        if self.config.latency_s is not None:
            return False  # time is counted in telegrams
        fr = self.config.free_run
        return self.config.time_factor <= 1.0 if fr is None else bool(fr)

    @property
    def moving(self) -> bool:
        """Whether any motor is turning or powered."""
        with self.lock:
            return any(m.moving for m in self.motors)

    def log_record(self) -> dict[str, object]:
        """The truth-log record: brick time (s), pose [x, y, heading_deg] and collisions so far."""
        p = self._pose
        return {"t": round(self.time_s, 4), "pose": [round(p.x, 4), round(p.y, 4), round(p.heading_deg, 4)],
                "collisions": self.collisions}

    # -- the clock --------------------------------------------------------------------------------
    def advance(self) -> float:
        """Advance brick time to now (see the module docstring); return the brick seconds added."""
        with self.lock:
            now = float(self._clock())
            if self.config.latency_s is not None:
                dt = self.config.latency_s
            else:
                dt = min(max(0.0, now - self._last_wall) * self.config.time_factor, self.config.max_step_s)
            self._last_wall = now
            self.run_for(dt)
            return dt

    def run_for(self, dt: float) -> None:
        """Integrate the mechanics for `dt` brick seconds."""
        with self.lock:
            h = self.config.substep_s
            left = dt
            while left > 1e-12:
                step = min(h, left)
                self._substep(step)
                left -= step
                self.time_s += step
            self._note_motion_end()

    def _substep(self, dt: float) -> None:
        cfg = self.config
        turned = [m.step(dt, cfg) if m.moving else 0.0 for m in self.motors]
        dl_deg, dr_deg = turned[cfg.left_port], turned[cfg.right_port]
        if dl_deg == 0.0 and dr_deg == 0.0:
            return
        self._was_moving = True
        per_deg = self.geometry.wheel_circumference_cm / 360.0
        dl = dl_deg * per_deg * (1.0 + self._slip[cfg.left_port])
        dr = dr_deg * per_deg * (1.0 + self._slip[cfg.right_port])
        ds = 0.5 * (dl + dr)
        dth = (dr - dl) / self.geometry.track_width_cm
        p = self._pose
        mid = p.theta + 0.5 * dth
        start = p.xy
        end = start + ds * np.array([math.cos(mid), math.sin(mid)])
        frac = 1.0
        if abs(ds) > 0:
            self._free_budget -= abs(ds)
            if self._free_budget < 0:
                frac = self.checker.first_contact(start, end)
                if frac >= 1.0:
                    self._free_budget = max(0.0, float(self.checker.clearance(end)) - 1e-6)
        if frac < 1.0:
            end = start + frac * (end - start)
            if not self.in_contact:
                self.collisions += 1
                _log.info("collision at (%.2f, %.2f), %d so far", end[0], end[1], self.collisions)
            self.in_contact = True
            self._free_budget = 0.0
            # the wheels stall against the wall: only the travelled part shows on the tachos
            for port, d in ((cfg.left_port, dl_deg), (cfg.right_port, dr_deg)):
                m = self.motors[port]
                m.position -= (1.0 - frac) * d
                m.speed = 0.0
        elif abs(ds) > 0:
            self.in_contact = False
        self._pose = Pose(float(end[0]), float(end[1]), float(wrap_angle(p.theta + frac * dth)))

    def _note_motion_end(self) -> None:
        cfg = self.config
        wheels_moving = self.motors[cfg.left_port].moving or self.motors[cfg.right_port].moving
        if self._was_moving and not wheels_moving:
            self._was_moving = False
            self.motions += 1
            if self._log is not None:
                self._log.write(json.dumps(self.log_record()) + "\n")
                self._log.flush()

    # -- commands ---------------------------------------------------------------------------------
    def command_motor(self, port: int, power: int, mode: int, regulation: int, turn_ratio: int, run_state: int,
                      tacho_limit: int) -> None:
        """SET_OUTPUT_STATE on output `port` (0-2); a new drive command draws the wheel's slip."""
        with self.lock:
            m = self.motors[port]
            m.command(power, mode, regulation, turn_ratio, run_state, tacho_limit)
            wheels = (self.config.left_port, self.config.right_port)
            if port in wheels and m.driven:
                fraction = self.faults.slip(port, wheels, self.time_s)
                slip = self.config.wheel_slip
                if fraction is not None:  # a motor-slip fault: the ground travel is this fraction of the tachos'
                    self._slip[port] = fraction - 1.0
                else:
                    self._slip[port] = float(self._slip_rng.normal(0.0, slip)) if slip > 0 else 0.0

    def stop_all(self) -> None:
        """Brake every motor now."""
        self.stop_motors(range(len(self.motors)))

    def stop_motors(self, ports: Iterable[int]) -> None:
        """Brake the motors on outputs `ports` now (the client that started them vanished)."""
        with self.lock:
            for p in ports:
                self.motors[p].stop()
            self._note_motion_end()

    def measure_sonar(self) -> int:
        """One ultrasonic reading (whole cm, 255 = no echo) along the turret's absolute heading."""
        with self.lock:
            p = self._pose
            heading = p.theta + self.turret_angle
            direction = np.array([math.cos(heading), math.sin(heading)])
            origin = p.xy + self.geometry.sensor_offset_cm * direction
            r = float(np.asarray(self.sonar.measure(self.map.walls, origin, np.array([heading]), self.rng))[0])
            value = 255 if not math.isfinite(r) or r >= 255 else max(0, round(r))
            return self.faults.sonar(value, self.time_s) if self.faults else value

    def driven_ports(self) -> list[int]:
        """Output ports whose motor the firmware is powering now."""
        with self.lock:
            return [p for p, m in enumerate(self.motors) if m.driven]

    def sonar_transaction(self, port: int, tx: bytes, rx_len: int) -> None:
        """Start an I2C transaction on input `port` (LS_WRITE); the result waits for LS_READ."""
        with self.lock:
            inp = self.inputs[port]
            inp.rx, inp.status = b"", 0
            powered = inp.sensor_type == SensorType.LOW_SPEED_9V
            if port != self.config.sonar_port or not powered or len(tx) < 2 or tx[0] != US_I2C_ADDRESS:
                inp.status = 0xDD  # nothing answers on the bus
                return
            us = self.ultrasonic
            reg = tx[1]
            if len(tx) > 2:
                for i, value in enumerate(tx[2:]):
                    addr = reg + i
                    if addr in (US_REG_INTERVAL, US_REG_COMMAND):
                        us.registers[addr] = value
                if reg <= US_REG_COMMAND < reg + len(tx) - 2:
                    if us.command == US_CMD_RESET:
                        us.reset()
                    elif us.command == US_CMD_SINGLE_SHOT:
                        us.store(self.measure_sonar())
            if rx_len > 0:
                if reg <= US_REG_DISTANCE + 7 and reg + rx_len > US_REG_DISTANCE and us.command == US_CMD_CONTINUOUS:
                    us.store(self.measure_sonar())
                inp.rx = us.read(reg, rx_len)
                inp.pending = self.config.i2c_pending_polls

    def close(self) -> None:
        """Stop the motors and close the truth log if this world opened it."""
        with self.lock:
            self.stop_all()
            if self._own_log and self._log is not None:
                self._log.close()
                self._log = None
