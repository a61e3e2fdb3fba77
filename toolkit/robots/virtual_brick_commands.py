"""The virtual NXT brick's commands: each telegram executed against a `BrickWorld` (`VirtualBrick`).

`toolkit.robots.virtual_brick` serves it over TCP; this module answers the direct and system commands
listed there, with the firmware's statuses for what it does not support.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Callable

from .virtual_brick_protocol import TYPE_SYSTEM, Direct, Frame, Status, System, error_reply, ok_reply
from .virtual_brick_world import BrickWorld, SensorType

__all__ = ["COMMAND_MODULE_ID", "TICK_OFFSET", "VirtualBrick"]

_log = logging.getLogger("toolkit.robots.virtual_brick")

COMMAND_MODULE_ID = 0x00010001
"""Module id of the NXT firmware's command module, whose IO map holds the system tick."""
TICK_OFFSET = 20
"""Offset of the tick (u32, ms) in the command module's IO map."""

_PROTOCOL_VERSION = (1, 124)  # (major, minor), as the LEGO firmware 1.31 reports
_FIRMWARE_VERSION = (1, 31)
_SLEEP_TIMEOUT_MS = 600_000
_FREE_FLASH = 110_000


class _BadTelegram(Exception):
    def __init__(self, status: int) -> None:
        super().__init__(f"status {status:#04x}")
        self.status = status


class VirtualBrick:
    """Executes NXT telegrams against a `BrickWorld` (one instance per server, shared by clients).

    Parameters
    ----------
    world : BrickWorld
        The simulated robot.
    """

    def __init__(self, world: BrickWorld) -> None:
        self.world = world
        self.name = world.config.name
        self.telegrams = 0
        self.errors = 0
        self.tones = 0
        self._client: object = None  # the connection whose telegram is being executed
        self._owners: dict[int, object] = {}  # output port -> the connection that set it going
        self._handlers: dict[tuple[int, int], Callable[[bytes], bytes]] = {
            (0, Direct.PLAY_TONE): self._play_tone,
            (0, Direct.SET_OUTPUT_STATE): self._set_output_state,
            (0, Direct.SET_INPUT_MODE): self._set_input_mode,
            (0, Direct.GET_OUTPUT_STATE): self._get_output_state,
            (0, Direct.GET_INPUT_VALUES): self._get_input_values,
            (0, Direct.RESET_INPUT_SCALED_VALUE): self._input_port_only,
            (0, Direct.RESET_MOTOR_POSITION): self._reset_motor_position,
            (0, Direct.GET_BATTERY_LEVEL): lambda t: struct.pack("<H", self.world.config.battery_mv),
            (0, Direct.STOP_SOUND_PLAYBACK): lambda t: b"",
            (0, Direct.KEEP_ALIVE): lambda t: struct.pack("<I", _SLEEP_TIMEOUT_MS),
            (0, Direct.LS_GET_STATUS): self._ls_get_status,
            (0, Direct.LS_WRITE): self._ls_write,
            (0, Direct.LS_READ): self._ls_read,
            (0, Direct.START_PROGRAM): self._fail(Status.REQUEST_FAILED),
            (0, Direct.STOP_PROGRAM): self._fail(Status.NO_ACTIVE_PROGRAM),
            (0, Direct.PLAY_SOUND_FILE): self._fail(Status.REQUEST_FAILED),
            (0, Direct.MESSAGE_WRITE): self._fail(Status.NO_ACTIVE_PROGRAM),
            (0, Direct.MESSAGE_READ): self._fail(Status.NO_ACTIVE_PROGRAM),
            (0, Direct.GET_CURRENT_PROGRAM_NAME): self._fail(Status.NO_ACTIVE_PROGRAM),
            (1, System.VERSIONS): self._versions,
            (1, System.DEVICE_INFO): self._device_info,
            (1, System.SET_BRICK_NAME): self._set_brick_name,
            (1, System.BT_GET_ADDRESS): lambda t: bytes(7) + bytes(1),
            (1, System.IOMAP_READ): self._iomap_read,
            (1, System.OPEN_READ): self._fail(Status.FILE_NOT_FOUND),
            (1, System.OPEN_READ_LINEAR): self._fail(Status.FILE_NOT_FOUND),
            (1, System.OPEN_APPEND_DATA): self._fail(Status.FILE_NOT_FOUND),
            (1, System.DELETE): self._fail(Status.FILE_NOT_FOUND),
            (1, System.FIND_FIRST): self._fail(Status.FILE_NOT_FOUND),
            (1, System.FIND_NEXT): self._fail(Status.ILLEGAL_HANDLE),
            (1, System.CLOSE): self._fail(Status.ILLEGAL_HANDLE),
            (1, System.READ): self._fail(Status.ILLEGAL_HANDLE),
            (1, System.FIND_FIRST_MODULE): self._fail(Status.MODULE_NOT_FOUND),
            (1, System.FIND_NEXT_MODULE): self._fail(Status.ILLEGAL_HANDLE),
            (1, System.CLOSE_MODULE_HANDLE): self._fail(Status.ILLEGAL_HANDLE),
        }

    # -- dispatch ---------------------------------------------------------------------------------
    def handle(self, frame: Frame, client: object = None) -> bytes | None:
        """Execute one telegram from connection `client`; return the reply bytes, or None when the
        sender wants none."""
        self.telegrams += 1
        data = frame.data
        wants = frame.wants_reply
        try:
            if frame.kind != "telegram":  # cut short (a known opcode) or not a command at all
                raise _BadTelegram(Status.INSANE_PACKET if frame.truncated else Status.UNKNOWN_OPCODE)
            handler = self._handlers.get((data[0] & TYPE_SYSTEM, data[1]))
            if handler is None:
                raise _BadTelegram(Status.UNKNOWN_OPCODE)
            with self.world.lock:
                if wants:
                    self.world.advance()
                self._client = client
                payload = handler(data)
        except _BadTelegram as exc:
            self.errors += 1
            _log.debug("telegram %s refused with status %#04x", data.hex(), exc.status)
            return error_reply(frame.opcode, exc.status) if wants else None
        except (struct.error, IndexError, ValueError) as exc:  # malformed arguments
            self.errors += 1
            _log.debug("telegram %s malformed: %s", data.hex(), exc)
            return error_reply(frame.opcode, Status.INSANE_PACKET) if wants else None
        except Exception:  # a fault of the simulation itself: refuse the telegram, keep serving
            self.errors += 1
            _log.exception("telegram %s failed", data.hex())
            return error_reply(frame.opcode, Status.BAD_ARGUMENTS) if wants else None
        return ok_reply(frame.opcode, payload) if wants else None

    @staticmethod
    def _fail(status: int) -> Callable[[bytes], bytes]:
        def refuse(_: bytes) -> bytes:
            raise _BadTelegram(status)

        return refuse

    def _output_port(self, t: bytes) -> int:
        if t[2] > 2:
            raise _BadTelegram(Status.OUT_OF_RANGE)
        return t[2]

    def _input_port(self, t: bytes) -> int:
        if t[2] > 3:
            raise _BadTelegram(Status.OUT_OF_RANGE)
        return t[2]

    def _input_port_only(self, t: bytes) -> bytes:
        self._input_port(t)
        return b""

    # -- direct commands --------------------------------------------------------------------------
    def _play_tone(self, t: bytes) -> bytes:
        struct.unpack_from("<HH", t, 2)
        self.tones += 1
        return b""

    def _set_output_state(self, t: bytes) -> bytes:
        port = t[2]
        power, mode, regulation, turn_ratio, run_state, limit = struct.unpack_from("<bBBbBI", t, 3)
        ports = [0, 1, 2] if port == 0xFF else [self._output_port(t)]
        for p in ports:
            self.world.command_motor(p, power, mode, regulation, turn_ratio, run_state, limit)
            if self.world.motors[p].driven:
                self._owners[p] = self._client
            else:  # braked or idled: nobody's motion any more
                self._owners.pop(p, None)
        return b""

    def owned(self, client: object) -> list[int]:
        """Output ports whose motion connection `client` started."""
        return [p for p, c in self._owners.items() if c is client]

    def release(self, client: object) -> list[int]:
        """Connection `client` has gone: brake the motors it set going (when the config says so).

        Returns the output ports it owned. Motors started by other connections are left alone.
        """
        with self.world.lock:
            ports = [p for p, c in self._owners.items() if c is client]
            for p in ports:
                del self._owners[p]
            if ports and self.world.config.brake_on_disconnect:
                self.world.stop_motors(ports)
        return ports

    def _get_output_state(self, t: bytes) -> bytes:
        port = self._output_port(t)
        m = self.world.motors[port]
        tacho, block, rotation = m.counts()
        return struct.pack("<BbBBbBIiii", port, m.power, m.mode, m.regulation, m.turn_ratio, m.run_state,
                           m.tacho_limit, tacho, block, rotation)

    def _reset_motor_position(self, t: bytes) -> bytes:
        m = self.world.motors[self._output_port(t)]
        if t[3]:
            m.block_origin = m.position
        else:
            m.rotation_origin = m.position
        return b""

    def _set_input_mode(self, t: bytes) -> bytes:
        inp = self.world.inputs[self._input_port(t)]
        inp.sensor_type, inp.mode = t[3], t[4]
        inp.rx, inp.status = b"", 0
        return b""

    def _get_input_values(self, t: bytes) -> bytes:
        port = self._input_port(t)
        inp = self.world.inputs[port]
        digital = inp.sensor_type in (SensorType.LOW_SPEED, SensorType.LOW_SPEED_9V)
        raw = 0 if digital else 1023  # an open analog input reads full scale
        valid = inp.sensor_type != SensorType.NO_SENSOR
        return struct.pack("<B??BBHHhh", port, valid, False, inp.sensor_type, inp.mode, raw, raw, raw, raw)

    def _lowspeed_port(self, t: bytes) -> int:
        port = self._input_port(t)
        if self.world.inputs[port].sensor_type not in (SensorType.LOW_SPEED, SensorType.LOW_SPEED_9V):
            raise _BadTelegram(Status.CHANNEL_NOT_CONFIGURED)
        return port

    def _ls_write(self, t: bytes) -> bytes:
        port = self._lowspeed_port(t)
        tx_len, rx_len = t[3], t[4]
        tx = t[5:5 + tx_len]
        if len(tx) != tx_len or not 1 <= tx_len <= 16 or rx_len > 16:
            raise _BadTelegram(Status.ILLEGAL_SIZE)
        self.world.sonar_transaction(port, tx, rx_len)
        return b""

    def _ls_get_status(self, t: bytes) -> bytes:
        inp = self.world.inputs[self._lowspeed_port(t)]
        if inp.status:
            raise _BadTelegram(inp.status)
        if inp.pending:
            inp.pending -= 1
            raise _BadTelegram(Status.PENDING)
        return bytes((len(inp.rx),))

    def _ls_read(self, t: bytes) -> bytes:
        inp = self.world.inputs[self._lowspeed_port(t)]
        if inp.status:
            status, inp.status = inp.status, 0
            raise _BadTelegram(status)
        if inp.pending:
            raise _BadTelegram(Status.PENDING)
        rx, inp.rx = inp.rx, b""
        return bytes((len(rx),)) + rx.ljust(16, b"\0")

    # -- system commands --------------------------------------------------------------------------
    def _versions(self, t: bytes) -> bytes:
        (pmaj, pmin), (fmaj, fmin) = _PROTOCOL_VERSION, _FIRMWARE_VERSION
        return bytes((pmin, pmaj, fmin, fmaj))

    def _device_info(self, t: bytes) -> bytes:
        name = self.name.encode("ascii", "replace")[:14].ljust(15, b"\0")
        return name + bytes(7) + bytes(4) + struct.pack("<I", _FREE_FLASH)

    def _set_brick_name(self, t: bytes) -> bytes:
        raw = t[2:17].split(b"\0", 1)[0]
        try:
            self.name = raw.decode("ascii")[:14]
        except UnicodeDecodeError:
            raise _BadTelegram(Status.OUT_OF_RANGE) from None
        return b""

    def _iomap_read(self, t: bytes) -> bytes:
        module, offset, size = struct.unpack_from("<IHH", t, 2)
        if module != COMMAND_MODULE_ID:
            raise _BadTelegram(Status.MODULE_NOT_FOUND)
        if size > 58:
            raise _BadTelegram(Status.ILLEGAL_SIZE)
        iomap = bytearray(offset + size + 4)
        if offset <= TICK_OFFSET + 3 and offset + size > TICK_OFFSET:
            tick = int(self.world.time_s * 1000.0) & 0xFFFFFFFF
            iomap[TICK_OFFSET:TICK_OFFSET + 4] = struct.pack("<I", tick)
        return struct.pack("<IH", module, size) + bytes(iomap[offset:offset + size])
