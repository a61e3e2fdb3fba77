"""The virtual NXT brick: a TCP server speaking nxt-python's socket protocol, backed by the simulator.

Any nxt-python client (its ``nxt-test`` command, `toolkit.robots.nxt.NxtRobot`, your own scripts)
connects with the socket backend (``server_host``/``server_port``) and drives a simulated robot in
a map as it would drive a real brick: motors turn at a realistic speed, the turret carries the
ultrasonic sensor, the sensor answers through its I2C registers from a sonar model, and the true pose
and collisions are logged (see `toolkit.robots.virtual_brick_world`).

Supported commands: the direct commands play tone, set/get output state, reset motor position,
set input mode, get input values, reset input scaled value, get battery level, keep alive, stop
sound, low-speed (I2C) write/read/status; the system commands firmware version, device info,
set brick name, Bluetooth address, and IO-map read of the command module's tick (offset 20 of module
0x00010001, milliseconds of brick time). Program, file, mailbox and module commands answer with
the firmware's "not found" or "no active program" statuses; anything else gets an error status.
Malformed bytes never stop the server. Each motor belongs to the connection that last set it going;
when that connection goes away the motor is braked (unless ``BrickConfig.brake_on_disconnect`` is
False, as on a real NXT), while other clients leaving do not touch it. TCP may cut a telegram into
pieces: each connection keeps an incomplete telegram until the rest of its known length arrives
(for at most `BrickConfig.reassembly_s`, 0.25 s by default). Scheduled faults
(`toolkit.robots.brick_faults`: a dropped link, a stalled brick, a stuck or garbage sensor, slipping
wheels) make the brick misbehave at known brick times, reproducibly.

Example
-------
>>> from toolkit.world import Pose, load_map
>>> server = BrickServer(BrickWorld(load_map("map1"), Pose(20, 20, 0)), port=0)
>>> port = server.start().port
>>> # nxt.locator.find(backends=["socket"], server_host="127.0.0.1", server_port=port)
>>> server.stop()
"""

from __future__ import annotations

import contextlib
import logging
import socket
import socketserver
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .virtual_brick_protocol import (
    TYPE_SYSTEM,
    Direct,
    Frame,
    Status,
    System,
    error_reply,
    incomplete_telegram,
    ok_reply,
    split_telegrams,
)
from .virtual_brick_world import BrickConfig, BrickWorld, SensorType

__all__ = [
    "COMMAND_MODULE_ID",
    "CONNECTION_TYPE_NAME",
    "TICK_OFFSET",
    "BrickConfig",
    "BrickServer",
    "BrickWorld",
    "Departure",
    "VirtualBrick",
]

_log = logging.getLogger(__name__)

CONNECTION_TYPE_NAME = "virtual"
"""What the brick answers to the socket link's connection-type query (clients see ``ipvirtual``)."""
COMMAND_MODULE_ID = 0x00010001
"""Module id of the NXT firmware's command module, whose IO map holds the system tick."""
TICK_OFFSET = 20
"""Offset of the tick (u32, ms) in the command module's IO map."""

_PROTOCOL_VERSION = (1, 124)  # (major, minor), as the LEGO firmware 1.31 reports
_FIRMWARE_VERSION = (1, 31)
_SLEEP_TIMEOUT_MS = 600_000
_FREE_FLASH = 110_000
_TICK_S = 0.005  # wall seconds between clock ticks of a free-running brick
_POLL_S = 0.05  # wall seconds between checks of the serving loop (stop, a dropped link coming back)


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


def _quick_ack(sock: socket.socket) -> None:
    """Acknowledge at once (Linux): nxt-python's socket keeps Nagle's algorithm on, so a command that
    needs no reply followed by one that does would otherwise wait for a delayed ACK (~40 ms)."""
    opt = getattr(socket, "TCP_QUICKACK", None)
    if opt is not None:
        try:
            sock.setsockopt(socket.IPPROTO_TCP, opt, 1)
        except OSError:
            pass


@dataclass(frozen=True)
class Departure:
    """A connection that ended.

    Attributes
    ----------
    time_s : float
        Brick time (s) when it ended.
    cause : {"closed", "cut", "stopped"}
        The client closed it (or vanished), a drop-link fault cut it, or the server stopped.
    driven : tuple of int
        Output ports this connection had set going that were still powered when it ended, before the
        brick braked anything (a careful client brakes its motors before it leaves).
    unbounded : tuple of int
        Those of `driven` running without a tacho limit: on a real NXT they would run until someone
        stops them (a tacho-limited motor stops on its own at its limit).
    """

    time_s: float
    cause: str
    driven: tuple[int, ...]
    unbounded: tuple[int, ...]


class _Handler(socketserver.BaseRequestHandler):
    server: _TCPServer

    def handle(self) -> None:
        sock: socket.socket = self.request
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        owner = self.server.owner
        brick = owner.brick
        peer = self.client_address
        _log.info("client %s connected", peer)
        owner._connected(sock)
        held = b""  # the start of a telegram whose rest has not arrived yet
        try:
            while not owner.stopping:
                sock.settimeout(owner.world.config.reassembly_s if held else None)
                try:
                    chunk = sock.recv(1024)
                    _quick_ack(sock)
                except TimeoutError:  # the rest never came: answer the fragment as the bad telegram it is
                    frames, held = [Frame("garbage", held)], b""
                except OSError:
                    break
                else:
                    if not chunk:
                        break
                    data, held = held + chunk, b""
                    frames = split_telegrams(data)
                    if frames and frames[-1].kind == "garbage" and incomplete_telegram(frames[-1].data):
                        held = frames.pop().data  # TCP cut this telegram: wait for the rest of its length
                if self._serve(sock, frames, brick, owner):
                    break
        except OSError as exc:
            _log.info("client %s: %s", peer, exc)
        finally:
            owner._departed(self, sock)

    def _serve(self, sock: socket.socket, frames: list[Frame], brick: VirtualBrick, owner: BrickServer) -> bool:
        """Answer the frames; True when the connection ends (the client said goodbye, or the link dropped)."""
        for frame in frames:
            if frame.kind == "type":
                owner._hold()
                sock.sendall(CONNECTION_TYPE_NAME.encode("ascii"))
            elif frame.kind == "close":
                return True
            else:
                reply = brick.handle(frame, client=self)
                if owner._link_faults():
                    return True  # the link dropped with this telegram: its reply never leaves
                if reply is not None:
                    owner._hold()
                    sock.sendall(reply)
        return False


class _TCPServer(socketserver.ThreadingTCPServer):
    daemon_threads = True
    block_on_close = False  # closing the listener (a dropped link) must not wait for the connections' threads
    allow_reuse_address = True
    owner: BrickServer

    def verify_request(self, request: Any, client_address: Any) -> bool:
        return not self.owner.down  # a connection that slipped in while the link goes down is closed at once


class BrickServer:
    """Serve a `BrickWorld` on ``host:port`` (port 0 picks a free one) to nxt-python clients.

    The server carries out the link faults of the world's `FaultSchedule` (a dropped link: every
    connection cut and the port closed for a while, then opened again on the same port; a stalled
    brick: no answers for a while) and keeps a `Departure` for every connection that ended.

    Parameters
    ----------
    world : BrickWorld
        The simulated robot.
    host : str
        Address to bind (the loopback interface by default).
    port : int
        TCP port (nxt-python's default is 2727; 0 = any free port, see `port` after `start`).
    """

    def __init__(self, world: BrickWorld, host: str = "127.0.0.1", port: int = 2727) -> None:
        self.world = world
        self.brick = VirtualBrick(world)
        self.stopping = False
        self.departures: list[Departure] = []
        self._server: _TCPServer | None = self._bind(host, port)
        self._address = (host, int(self._server.server_address[1]))
        self._link = threading.Lock()
        self._live: set[socket.socket] = set()
        self._cut: set[socket.socket] = set()
        self._clients = 0
        self._changed = threading.Condition()
        self._down_until = 0.0
        self._stalled_until = 0.0
        self._stopped = threading.Event()
        self._up = threading.Event()
        self._up.set()
        self._thread: threading.Thread | None = None
        self._ticker: threading.Thread | None = None

    def _bind(self, host: str, port: int) -> _TCPServer:
        srv = _TCPServer((host, port), _Handler, bind_and_activate=True)
        srv.owner = self
        srv.timeout = _POLL_S
        return srv

    @property
    def host(self) -> str:
        return self._address[0]

    @property
    def port(self) -> int:
        return self._address[1]

    @property
    def clients(self) -> int:
        """Connections accepted so far."""
        return self._clients

    @property
    def live_connections(self) -> int:
        """Connections open now."""
        with self._link:
            return len(self._live)

    @property
    def down(self) -> bool:
        """Whether the link is down (a drop-link fault): the port refuses connections."""
        return time.monotonic() < self._down_until

    def wait_clients(self, n: int, timeout: float | None = None) -> bool:
        """Block until `n` connections have been accepted in all (or `timeout` seconds); True when they have."""
        with self._changed:
            return self._changed.wait_for(lambda: self._clients >= n, timeout)

    def wait_link_up(self, timeout: float | None = None) -> bool:
        """Block until the port accepts connections again after a dropped link (or `timeout` seconds)."""
        return self._up.wait(timeout)

    def wait_departures(self, n: int, timeout: float | None = None) -> bool:
        """Block until `n` connections have ended in all (or `timeout` seconds); True when they have."""
        with self._changed:
            return self._changed.wait_for(lambda: len(self.departures) >= n, timeout)

    # -- connections ------------------------------------------------------------------------------
    def _connected(self, sock: socket.socket) -> None:
        with self._link:
            self._live.add(sock)
        with self._changed:
            self._clients += 1
            self._changed.notify_all()

    def _departed(self, client: _Handler, sock: socket.socket) -> None:
        """A connection ended: note what it left powered, then brake what it drove (when configured)."""
        with self._link:
            self._live.discard(sock)
            cause = "cut" if sock in self._cut else "stopped" if self.stopping else "closed"
            self._cut.discard(sock)
        with self.world.lock:
            owned = sorted(self.brick.owned(client))
            driven = tuple(p for p in owned if self.world.motors[p].driven)
            unbounded = tuple(p for p in driven if self.world.motors[p].tacho_limit == 0)
            stopped = self.brick.release(client)
            gone = Departure(self.world.time_s, cause, driven, unbounded)
        with self._changed:
            self.departures.append(gone)
            self._changed.notify_all()
        _log.info("client %s gone (%s); motors it drove: %s", client.client_address, cause, stopped or "none")

    # -- link faults ------------------------------------------------------------------------------
    def _link_faults(self) -> bool:
        """Carry out the link faults due at the current brick time; True when the link dropped."""
        faults = self.world.faults
        if not faults:
            return False
        dropped = False
        for i in faults.due(self.world.time_s):
            f = faults.faults[i]
            if f.kind == "stall":
                _log.info("fault %s: the brick stops answering for %g s", f.text, f.arg)
                self._stalled_until = max(self._stalled_until, time.monotonic() + f.arg)
            else:
                _log.info("fault %s: the link drops for %g s", f.text, f.arg)
                self._drop(f.arg)
                dropped = True
        return dropped

    def _drop(self, down_s: float) -> None:
        """Cut every connection and refuse new ones for `down_s` wall-clock seconds."""
        with self._link:
            self._down_until = max(self._down_until, time.monotonic() + down_s)
            self._close_listener()
            for sock in self._live:
                self._cut.add(sock)
                with contextlib.suppress(OSError):
                    sock.shutdown(socket.SHUT_RDWR)

    def _close_listener(self) -> None:
        if self._server is not None:
            self._up.clear()
            with contextlib.suppress(OSError):  # stop listening now, even while the serving loop polls it
                self._server.socket.shutdown(socket.SHUT_RDWR)
            self._server.server_close()
            self._server = None

    def _hold(self) -> None:
        """Wait out a stall of the brick before answering."""
        while not self.stopping:
            left = self._stalled_until - time.monotonic()
            if left <= 0:
                return
            self._stopped.wait(min(left, _POLL_S))

    # -- serving ----------------------------------------------------------------------------------
    def _listener(self) -> _TCPServer | None:
        """The listening server, bound again on the same port once a dropped link is up; None meanwhile."""
        with self._link:
            if self.down or self.stopping:
                self._close_listener()
                return None
            if self._server is None:
                try:
                    self._server = self._bind(*self._address)
                    self._up.set()
                    _log.info("link up again on %s:%d", *self._address)
                except OSError as exc:
                    _log.warning("cannot listen on %s:%d again: %s", *self._address, exc)
            return self._server

    def _serve(self) -> None:
        while not self._stopped.is_set():
            srv = self._listener()
            if srv is None:
                self._stopped.wait(_POLL_S)
                continue
            try:
                srv.handle_request()  # waits up to _POLL_S for one connection
            except (OSError, ValueError):  # the listener was closed under it by a dropped link
                continue

    def start(self) -> BrickServer:
        """Serve in a background thread; returns self."""
        self._thread = threading.Thread(target=self._serve, name=f"virtual-brick-{self.port}", daemon=True)
        self._thread.start()
        self._start_ticker()
        return self

    def _start_ticker(self) -> None:
        if self.world.free_running and self._ticker is None:
            self._ticker = threading.Thread(target=self._tick, name=f"virtual-brick-clock-{self.port}", daemon=True)
            self._ticker.start()

    def _tick(self) -> None:
        while not self._stopped.wait(_TICK_S):
            self.world.advance()
            self._link_faults()

    def serve_forever(self) -> None:
        """Serve in this thread until `stop` (or Ctrl-C in the caller)."""
        self._start_ticker()
        self._serve()

    def stop(self) -> None:
        """Stop serving, brake the motors and close the truth log."""
        self.stopping = True
        self._stopped.set()
        for thread in (self._ticker, self._thread):
            if thread is not None:
                thread.join(timeout=5)
        with self._link:
            self._close_listener()
            for sock in list(self._live):
                with contextlib.suppress(OSError):
                    sock.shutdown(socket.SHUT_RDWR)
        self.world.close()

    def __enter__(self) -> BrickServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
