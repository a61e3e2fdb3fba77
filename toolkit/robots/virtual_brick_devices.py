"""The devices inside the virtual NXT brick: its configuration, its motors, the ultrasonic sensor and
the input ports, with the firmware's constants they answer to.

`toolkit.robots.virtual_brick_world.BrickWorld` puts them on a simulated robot (see that module for
the motor model and the clock); every name here is re-exported from there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Annotated

from pydantic import Field, model_validator

from ..world import RobotGeometry
from ..world.typed import Positive, Real, Whole, typed_dataclass, worded

__all__ = ["US_CMD_CONTINUOUS", "US_CMD_EVENT", "US_CMD_OFF", "US_CMD_RESET", "US_CMD_SINGLE_SHOT", "US_I2C_ADDRESS",
           "US_REG_COMMAND", "US_REG_DISTANCE", "US_REG_INTERVAL", "BrickConfig", "InputPort", "Motor", "MotorMode",
           "RunState", "SensorType", "UltrasonicSensor"]


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


Port = Annotated[Whole, Field(ge=0, le=2)]
"""A motor output of the brick (0, 1, 2: A, B, C)."""


@typed_dataclass()
class BrickConfig:
    """Physical constants and wiring of the simulated robot.

    Attributes
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

    geometry: RobotGeometry = Field(default_factory=RobotGeometry)
    left_port: Port = 0
    right_port: Port = 1
    turret_port: Port = 2
    sonar_port: Whole = Field(default=3, ge=0, le=3)
    deg_per_s_per_power: Positive = 8.0
    accel_deg_s2: Positive = 6000.0
    coast_decel_deg_s2: Positive = 2000.0
    substep_s: Positive = 0.005
    time_factor: Positive = 1.0
    max_step_s: Positive = 0.02
    free_run: bool | None = None
    i2c_pending_polls: Whole = Field(default=0, ge=0, le=20)
    wheel_slip: Real = Field(default=0.0, ge=0, lt=0.5)
    brake_decel_deg_s2: Positive | None = None
    latency_s: Real | None = Field(default=None, gt=0, le=1)
    battery_mv: Whole = 8000
    name: str = Field(default="nxtnav-virtual", max_length=14)
    brake_on_disconnect: bool = True
    reassembly_s: Positive = 0.25

    @model_validator(mode="after")
    def _ports_differ(self) -> BrickConfig:
        if len({self.left_port, self.right_port, self.turret_port}) == 3:
            return self
        raise worded("motor ports must be three different values of 0, 1, 2; got "
                     f"{(self.left_port, self.right_port, self.turret_port)}")


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
