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
from pathlib import Path
from typing import IO

import numpy as np

from ..world import (
    CollisionChecker,
    Map,
    Pose,
    RngLike,
    RobotError,
    SonarModel,
    as_rng,
    wrap_angle,
)
from .brick_faults import FaultSchedule
from .sim import simulated_sonar
from .virtual_brick_devices import (
    US_CMD_CONTINUOUS,
    US_CMD_RESET,
    US_CMD_SINGLE_SHOT,
    US_I2C_ADDRESS,
    US_REG_COMMAND,
    US_REG_DISTANCE,
    US_REG_INTERVAL,
    BrickConfig,
    InputPort,
    Motor,
    MotorMode,
    RunState,
    SensorType,
    UltrasonicSensor,
)

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
