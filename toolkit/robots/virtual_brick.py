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
import threading
import time
from dataclasses import dataclass
from typing import Any

from .virtual_brick_commands import COMMAND_MODULE_ID, TICK_OFFSET, VirtualBrick
from .virtual_brick_protocol import Frame, incomplete_telegram, split_telegrams
from .virtual_brick_world import BrickConfig, BrickWorld

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
_TICK_S = 0.005  # wall seconds between clock ticks of a free-running brick
_POLL_S = 0.05  # wall seconds between checks of the serving loop (stop, a dropped link coming back)


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
        """Carry out the link faults due at the current brick time (each kind its own way,
        `toolkit.robots.brick_faults.LinkFault`); True when the link dropped."""
        faults = self.world.faults
        return bool(faults) and faults.carry_out(self.world.time_s, self)

    def stall(self, for_s: float) -> None:
        """Answer nothing for `for_s` wall-clock seconds (a stalled brick; the reply owed comes late)."""
        self._stalled_until = max(self._stalled_until, time.monotonic() + for_s)

    def drop_link(self, down_s: float) -> None:
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
