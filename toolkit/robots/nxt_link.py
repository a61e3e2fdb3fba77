"""Reaching an NXT brick: the links nxtnav opens itself, finding a brick, and naming what went wrong.

nxt-python talks to a brick through a link object (``send``, ``recv``, ``close``, ``bsize``, ``type``)
that its `nxt.brick.Brick` is built on. For the socket and Bluetooth backends nxtnav opens that link
itself (`SocketLink`, `BluetoothLink`) and hands nxt-python's locator a backend object that yields
bricks on them (`nxt.locator.find` takes backend objects as well as names). So nxtnav holds its own
handle on the socket under each brick (`link_of`): to give up on a reply after the reply timeout and
to let a broken connection go without a goodbye, without reaching into nxt-python's private
attributes. USB bricks come from nxt-python's own backend; their link needs neither.

nxt-python (GPL-3.0, extra ``nxt``) is imported only when a brick is looked for (`import_nxt`).
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import socket
import struct
import warnings
import weakref
from collections.abc import Iterator
from types import ModuleType
from typing import Any

from ..world import RobotError

__all__ = ["BACKENDS", "BluetoothLink", "BrickLink", "SocketLink", "describe_failure", "find_brick", "import_nxt",
           "link_broken", "link_of"]

BACKENDS = ("usb", "bluetooth", "socket")
"""The nxt-python backends `find_brick` accepts."""

_CONNECTION_TYPE_QUERY = 0x98  # the socket link's question: which link does the server have
_GOODBYE = 0x99  # the socket link's closing byte
_RFCOMM_CHANNEL = 1  # the NXT's Bluetooth serial port

_LINKS: weakref.WeakKeyDictionary[Any, BrickLink] = weakref.WeakKeyDictionary()


def link_of(brick: Any) -> BrickLink | None:
    """The link `find_brick` opened under `brick`, or None for a brick found some other way."""
    return _LINKS.get(brick)


def import_nxt() -> ModuleType:
    """nxt-python, imported on first use; a clear error when the extra is missing."""
    try:
        nxt = importlib.import_module("nxt")
        for sub in ("nxt.locator", "nxt.motor", "nxt.sensor", "nxt.error", "nxt.brick"):
            importlib.import_module(sub)
    except ImportError as exc:
        raise RobotError(f"nxt-python is not installed ({exc}); install it with: pip install 'nxtnav[nxt]'") \
            from None
    return nxt


def link_broken(exc: BaseException) -> bool:
    """Whether `exc` means the link itself failed (closed, reset, timed out, the USB device gone)."""
    return isinstance(exc, OSError | EOFError | struct.error)


def describe_failure(exc: BaseException) -> str:
    """One line naming what went wrong with the link or the command."""
    if isinstance(exc, struct.error | EOFError | ConnectionError | BrokenPipeError):
        return f"lost the connection to the brick ({type(exc).__name__}: {exc or 'no reply'})"
    if isinstance(exc, OSError):
        return f"link error ({exc.strerror or exc})"
    text = str(exc) or type(exc).__name__
    return f"{type(exc).__name__}: {text}"


# -- the links -------------------------------------------------------------------------------------
class BrickLink:
    """A connection to one brick: its kind (`type`, as nxt-python names it) and, where nxtnav opened
    it, the socket under it.

    Parameters
    ----------
    raw : socket or None
        The connected socket (a `socket.socket` or a PyBluez ``BluetoothSocket``); None for a link
        nxt-python opened (USB), which needs no timeout and no hang-up of its own.
    kind : str
        ``usb``, ``bluetooth`` or ``ip`` followed by the server's own link (``ipvirtual``, ``ipusb``).
    """

    bsize = 60
    """Largest block (bytes) nxt-python sends in one message over this link."""

    def __init__(self, raw: Any, kind: str) -> None:
        self._raw = raw
        self.type = kind

    @property
    def open(self) -> bool:
        """Whether the socket is still held (False after `close` or `drop`, and for USB)."""
        return self._raw is not None

    def set_reply_timeout(self, timeout_s: float | None) -> None:
        """Give up on a reply after `timeout_s` seconds (None: wait for ever)."""
        if self._raw is not None:
            self._raw.settimeout(timeout_s)

    def drop(self) -> None:
        """Close the socket without a goodbye (the other end is gone or not answering); a later
        `close` (nxt-python's, when the brick is closed or collected) then does nothing."""
        raw, self._raw = self._raw, None
        if raw is not None:
            with contextlib.suppress(OSError):
                raw.close()

    def close(self) -> None:
        """Say goodbye where the link has a way to, and close the socket."""
        if self._raw is not None:
            self._goodbye()
            self.drop()

    def _goodbye(self) -> None:
        """Tell the other end the connection ends (nothing by default)."""

    def send(self, data: bytes) -> None:
        raise NotImplementedError

    def recv(self) -> bytes:
        raise NotImplementedError


class SocketLink(BrickLink):
    """A brick behind a brick server (`nxtnav brick serve`, nxt-python's ``nxt-server``), over TCP."""

    bsize = 60

    @classmethod
    def connect(cls, host: str, port: int, timeout_s: float | None = None) -> SocketLink:
        """Connect to the server at `host`:`port` and ask which link it has; within `timeout_s`
        seconds when given (a server that accepts but does not answer would otherwise hold us for ever)."""
        raw = socket.create_connection((host, port), timeout=timeout_s)
        link = cls(raw, "ip")
        try:
            link.send(bytes((_CONNECTION_TYPE_QUERY,)))
            kind = link.recv()
            if not kind:
                raise ConnectionResetError("the server closed the connection")
        except BaseException:
            raw.close()
            raise
        link.type = "ip" + kind.decode("ascii", "replace")
        return link

    def send(self, data: bytes) -> None:
        self._raw.send(data)

    def recv(self) -> bytes:
        return bytes(self._raw.recv(1024))

    def _goodbye(self) -> None:
        self._raw.send(bytes((_GOODBYE,)))


class BluetoothLink(BrickLink):
    """A brick over Bluetooth (RFCOMM): every message goes with its length in two bytes."""

    bsize = 118

    def send(self, data: bytes) -> None:
        self._raw.send(struct.pack("<H", len(data)) + data)

    def recv(self) -> bytes:
        (size,) = struct.unpack("<H", self._raw.recv(2))
        return bytes(self._raw.recv(size))


def _opened(nxt: ModuleType, link: BrickLink) -> Any:
    """An nxt-python brick on `link`, remembered for `link_of`."""
    brick = nxt.brick.Brick(link)
    _LINKS[brick] = link
    return brick


class _SocketBackend:
    """nxt-python backend object: the brick behind one server, on a `SocketLink` of ours."""

    def __init__(self, nxt: ModuleType, host: str, port: int, timeout_s: float | None) -> None:
        self._nxt, self._host, self._port, self._timeout_s = nxt, host, port, timeout_s

    def find(self, **_filters: Any) -> Iterator[Any]:
        yield _opened(self._nxt, SocketLink.connect(self._host, self._port, self._timeout_s))


class _BluetoothBackend:
    """nxt-python backend object: paired bricks in reach (or the one at `host`), on `BluetoothLink`s."""

    def __init__(self, nxt: ModuleType, bluetooth: ModuleType) -> None:
        self._nxt, self._bt = nxt, bluetooth

    def _candidates(self, host: str | None, name: str | None) -> list[tuple[str, str | None]]:
        if host is not None:
            return [(host, None)]
        try:
            found = self._bt.discover_devices(lookup_names=name is not None)
        except OSError:  # PyBluez's BluetoothError is an OSError: no adapter, adapter off
            return []
        return [tuple(d) for d in found] if name is not None else [(d, None) for d in found]

    def find(self, host: str | None = None, name: str | None = None, **_filters: Any) -> Iterator[Any]:
        for address, device_name in self._candidates(host, name):
            if host is None and name is not None and device_name != name:
                continue
            raw = self._bt.BluetoothSocket(self._bt.RFCOMM)
            try:
                raw.connect((address, _RFCOMM_CHANNEL))
            except OSError:  # not in reach, not paired: try the next one
                raw.close()
                continue
            yield _opened(self._nxt, BluetoothLink(raw, "bluetooth"))


class _UsbBackend:
    """nxt-python's own USB backend, its bricks remembered for `link_of` (a USB link has no socket)."""

    def __init__(self, nxt: ModuleType) -> None:
        self._inner = importlib.import_module("nxt.backend.usb").get_backend()

    def find(self, **filters: Any) -> Iterator[Any]:
        for brick in self._inner.find(**filters):
            _LINKS[brick] = BrickLink(None, "usb")
            yield brick


def _backend(nxt: ModuleType, backend: str, host: str, port: int, timeout_s: float | None) -> list[Any]:
    """The backend objects for `nxt.locator.find` (none for Bluetooth without PyBluez)."""
    if backend == "socket":
        return [_SocketBackend(nxt, host, port, timeout_s)]
    if backend == "bluetooth":
        try:
            return [_BluetoothBackend(nxt, importlib.import_module("bluetooth"))]
        except Exception:  # not installed, or a platform PyBluez does not support
            return []
    return [_UsbBackend(nxt)]


# -- finding a brick -------------------------------------------------------------------------------
def _no_brick_message(backend: str, host: str | None, port: int | None, detail: str = "") -> str:
    extra = f" ({detail})" if detail else ""
    if backend == "usb":
        return ("no NXT brick found over USB" + extra + ". Check: the brick is switched on and the USB cable "
                "plugged in; your user may open the device (install the udev rule from docs/hardware.md, "
                "then unplug and replug the brick); libusb-1.0 is installed; no other program (another "
                "nxt-python, NXT-G, BricxCC) holds the brick")
    if backend == "bluetooth":
        missing = importlib.util.find_spec("bluetooth") is None
        return ("no NXT brick found over Bluetooth" + extra + ". Check: "
                + ("PyBluez is installed (pip install pybluez); " if missing else "")
                + "Bluetooth is on in the brick's menu and on this computer; the brick is paired "
                "(bluetoothctl pair <address>, PIN 1234) and within range; give its address with --bt-address")
    return (f"no brick server at {host}:{port}" + extra + ". Start one with `nxtnav brick serve --port "
            f"{port}` (the virtual brick) or `nxt-server` on the computer with the brick, and check the "
            "host and port")


def _failure_detail(exc: Exception) -> str | None:
    """What to add to the no-brick message for `exc`; None when it is not about finding the brick."""
    kind = type(exc).__name__
    if kind == "NoBackendError":
        return "pyusb finds no libusb backend: install libusb-1.0"
    if getattr(exc, "errno", None) == 13 or isinstance(exc, PermissionError):
        return "permission denied on the USB device"
    if isinstance(exc, ConnectionRefusedError):
        return ""
    if isinstance(exc, OSError | ValueError):
        return f"{kind}: {exc or 'no answer'}"
    return None


def find_brick(backend: str, *, host: str | None = None, port: int | None = None, name: str | None = None,
               address: str | None = None, timeout_s: float | None = None) -> Any:
    """Connect to one brick with nxt-python's locator; failures become a `RobotError` with the fixes.

    Parameters
    ----------
    backend : {"usb", "bluetooth", "socket"}
        How to reach the brick.
    host, port : str, int
        The brick server of the socket backend (default 127.0.0.1:2727).
    name : str or None
        Only accept a brick with this name.
    address : str or None
        Bluetooth address of the brick (``00:16:53:xx:xx:xx``).
    timeout_s : float or None
        Socket backend: give up after this many seconds on a server that does not answer (None:
        wait for ever).
    """
    if backend not in BACKENDS:
        raise RobotError(f"unknown NXT backend {backend!r}; known: {', '.join(BACKENDS)}")
    nxt = import_nxt()
    host = host or "127.0.0.1"
    port = 2727 if port is None else int(port)
    kwargs: dict[str, Any] = {}
    if name:
        kwargs["name"] = name
    if address:
        kwargs["host"] = address
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ResourceWarning)  # a USB device pyusb gave up on
            # usb/bluetooth read nxt-python's own config file (~/.nxt-python.conf: name, host)
            config = None if backend == "socket" else "default"
            return nxt.locator.find(backends=_backend(nxt, backend, host, port, timeout_s), config=config, **kwargs)
    except nxt.locator.BrickNotFoundError:
        raise RobotError(_no_brick_message(backend, host, port)) from None
    except Exception as exc:
        detail = _failure_detail(exc)
        if detail is None:
            raise
        raise RobotError(_no_brick_message(backend, host, port, detail)) from None
