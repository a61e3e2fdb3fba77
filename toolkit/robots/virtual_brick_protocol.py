"""The wire formats the virtual NXT brick speaks.

Two layers, both documented by LEGO and by nxt-python:

* nxt-python's socket protocol (the ``nxt-server`` link): the client sends raw bytes; a lone
  ``0x98`` asks for the connection type (the answer is ASCII text), a lone ``0x99`` closes the link,
  and everything else is a raw NXT telegram. Telegrams are not length-prefixed on this link, so the
  server cuts a received chunk into telegrams by the known length of each command
  (`split_telegrams`).
* LEGO telegrams: byte 0 is the type (``0x00`` direct command, ``0x01`` system command, ``| 0x80``
  when no reply is wanted), byte 1 the opcode, then little-endian arguments. A reply is
  ``0x02, opcode, status`` followed by the reply arguments; status 0 means success.

Only the framing and the byte layouts live here; what the commands do is `virtual_brick_world`.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass

__all__ = [
    "CONNECTION_CLOSE",
    "CONNECTION_TYPE",
    "TYPE_DIRECT",
    "TYPE_NO_REPLY",
    "TYPE_REPLY",
    "TYPE_SYSTEM",
    "Direct",
    "Frame",
    "Status",
    "System",
    "error_reply",
    "expected_length",
    "incomplete_telegram",
    "ok_reply",
    "split_telegrams",
]

CONNECTION_TYPE = 0x98
"""Socket-link control byte: the client asks what kind of link the server has."""
CONNECTION_CLOSE = 0x99
"""Socket-link control byte: the client says goodbye."""

TYPE_DIRECT = 0x00
TYPE_SYSTEM = 0x01
TYPE_REPLY = 0x02
TYPE_NO_REPLY = 0x80


class Direct:
    """Direct-command opcodes (LEGO Bluetooth Developer Kit, appendix 2)."""

    START_PROGRAM = 0x00
    STOP_PROGRAM = 0x01
    PLAY_SOUND_FILE = 0x02
    PLAY_TONE = 0x03
    SET_OUTPUT_STATE = 0x04
    SET_INPUT_MODE = 0x05
    GET_OUTPUT_STATE = 0x06
    GET_INPUT_VALUES = 0x07
    RESET_INPUT_SCALED_VALUE = 0x08
    MESSAGE_WRITE = 0x09
    RESET_MOTOR_POSITION = 0x0A
    GET_BATTERY_LEVEL = 0x0B
    STOP_SOUND_PLAYBACK = 0x0C
    KEEP_ALIVE = 0x0D
    LS_GET_STATUS = 0x0E
    LS_WRITE = 0x0F
    LS_READ = 0x10
    GET_CURRENT_PROGRAM_NAME = 0x11
    MESSAGE_READ = 0x13


class System:
    """System-command opcodes (LEGO Bluetooth Developer Kit, appendix 1)."""

    OPEN_READ = 0x80
    OPEN_WRITE = 0x81
    READ = 0x82
    WRITE = 0x83
    CLOSE = 0x84
    DELETE = 0x85
    FIND_FIRST = 0x86
    FIND_NEXT = 0x87
    VERSIONS = 0x88
    OPEN_WRITE_LINEAR = 0x89
    OPEN_READ_LINEAR = 0x8A
    OPEN_WRITE_DATA = 0x8B
    OPEN_APPEND_DATA = 0x8C
    FIND_FIRST_MODULE = 0x90
    FIND_NEXT_MODULE = 0x91
    CLOSE_MODULE_HANDLE = 0x92
    IOMAP_READ = 0x94
    IOMAP_WRITE = 0x95
    SET_BRICK_NAME = 0x98
    BT_GET_ADDRESS = 0x9A
    DEVICE_INFO = 0x9B
    DELETE_USER_FLASH = 0xA0
    POLL_COMMAND_LENGTH = 0xA1
    POLL_COMMAND = 0xA2


class Status:
    """Reply status bytes the virtual brick uses (the NXT firmware's codes)."""

    OK = 0x00
    PENDING = 0x20
    FILE_NOT_FOUND = 0x87
    MODULE_NOT_FOUND = 0x90
    OUT_OF_BOUNDS = 0x91
    ILLEGAL_HANDLE = 0x93
    REQUEST_FAILED = 0xBD
    UNKNOWN_OPCODE = 0xBE
    INSANE_PACKET = 0xBF
    OUT_OF_RANGE = 0xC0
    BUS_ERROR = 0xDD
    CHANNEL_NOT_CONFIGURED = 0xE0
    NO_ACTIVE_PROGRAM = 0xEC
    ILLEGAL_SIZE = 0xED
    BAD_ARGUMENTS = 0xFF


# Request lengths (bytes, including type and opcode). A callable computes the length of a variable
# command from its first bytes (it may return None while those bytes are still missing).
_Length = int | Callable[[bytes], int | None]


def _with_count(fixed: int, at: int, width: int = 1) -> Callable[[bytes], int | None]:
    def length(data: bytes) -> int | None:
        if len(data) < at + width:
            return None
        count = data[at] if width == 1 else struct.unpack_from("<H", data, at)[0]
        return fixed + count

    return length


_DIRECT_LENGTHS: dict[int, _Length] = {
    Direct.START_PROGRAM: 22,
    Direct.STOP_PROGRAM: 2,
    Direct.PLAY_SOUND_FILE: 23,
    Direct.PLAY_TONE: 6,
    Direct.SET_OUTPUT_STATE: 12,
    Direct.SET_INPUT_MODE: 5,
    Direct.GET_OUTPUT_STATE: 3,
    Direct.GET_INPUT_VALUES: 3,
    Direct.RESET_INPUT_SCALED_VALUE: 3,
    Direct.MESSAGE_WRITE: _with_count(4, 3),
    Direct.RESET_MOTOR_POSITION: 4,
    Direct.GET_BATTERY_LEVEL: 2,
    Direct.STOP_SOUND_PLAYBACK: 2,
    Direct.KEEP_ALIVE: 2,
    Direct.LS_GET_STATUS: 3,
    Direct.LS_WRITE: _with_count(5, 3),
    Direct.LS_READ: 3,
    Direct.GET_CURRENT_PROGRAM_NAME: 2,
    Direct.MESSAGE_READ: 5,
}

_SYSTEM_LENGTHS: dict[int, _Length] = {
    System.OPEN_READ: 22,
    System.OPEN_WRITE: 26,
    System.READ: 5,
    System.CLOSE: 3,
    System.DELETE: 22,
    System.FIND_FIRST: 22,
    System.FIND_NEXT: 3,
    System.VERSIONS: 2,
    System.OPEN_WRITE_LINEAR: 26,
    System.OPEN_READ_LINEAR: 22,
    System.OPEN_WRITE_DATA: 26,
    System.OPEN_APPEND_DATA: 22,
    System.FIND_FIRST_MODULE: 22,
    System.FIND_NEXT_MODULE: 3,
    System.CLOSE_MODULE_HANDLE: 3,
    System.IOMAP_READ: 10,
    System.IOMAP_WRITE: _with_count(10, 8, width=2),
    System.SET_BRICK_NAME: 17,
    System.BT_GET_ADDRESS: 2,
    System.DEVICE_INFO: 2,
    System.DELETE_USER_FLASH: 2,
    System.POLL_COMMAND_LENGTH: 3,
    System.POLL_COMMAND: 4,
}


def expected_length(data: bytes) -> int | None:
    """Length of the telegram at the start of `data`, or None when it cannot be known.

    None means the opcode is unknown (or a variable-length header is cut short): the caller then
    treats the rest of the chunk as one telegram.
    """
    if len(data) < 2:
        return None
    kind = data[0] & ~TYPE_NO_REPLY
    table = _DIRECT_LENGTHS if kind == TYPE_DIRECT else _SYSTEM_LENGTHS if kind == TYPE_SYSTEM else None
    if table is None or data[1] not in table:
        return None
    rule = table[data[1]]
    return rule if isinstance(rule, int) else rule(data)


@dataclass(frozen=True)
class Frame:
    """One unit cut from the byte stream.

    Attributes
    ----------
    kind : {"type", "close", "telegram", "garbage"}
        A connection-type query, a close request, a telegram of the right length, or bytes that
        are not a well-formed telegram (too short, unknown type or opcode).
    data : bytes
        The bytes of this unit.
    """

    kind: str
    data: bytes

    @property
    def wants_reply(self) -> bool:
        """Whether the sender waits for a reply (telegrams and garbage without the no-reply bit)."""
        if self.kind not in ("telegram", "garbage") or not self.data:
            return False
        return self.data[0] not in (TYPE_DIRECT | TYPE_NO_REPLY, TYPE_SYSTEM | TYPE_NO_REPLY)

    @property
    def truncated(self) -> bool:
        """Whether these bytes start a known command but stop before its end (or hold one byte)."""
        if len(self.data) < 2:
            return True
        n = expected_length(self.data)
        if n is None:
            kind = self.data[0] & ~TYPE_NO_REPLY
            table = _DIRECT_LENGTHS if kind == TYPE_DIRECT else _SYSTEM_LENGTHS if kind == TYPE_SYSTEM else {}
            return self.data[1] in table  # a variable-length header cut short
        return n > len(self.data)

    @property
    def opcode(self) -> int:
        return self.data[1] if len(self.data) > 1 else 0


def split_telegrams(chunk: bytes) -> list[Frame]:
    """Cut a received chunk into control bytes and telegrams.

    A chunk normally holds exactly one unit (the client sends one telegram at a time), but a
    telegram that needs no reply may arrive glued to the next one. Bytes that cannot be framed
    become one trailing ``garbage`` frame.
    """
    frames: list[Frame] = []
    i = 0
    while i < len(chunk):
        rest = chunk[i:]
        first = rest[0]
        if first == CONNECTION_TYPE:
            frames.append(Frame("type", rest[:1]))
            i += 1
            continue
        if first == CONNECTION_CLOSE:
            frames.append(Frame("close", rest[:1]))
            i += 1
            continue
        n = expected_length(rest)
        if n is None or n > len(rest):
            frames.append(Frame("garbage", rest))
            break
        frames.append(Frame("telegram", rest[:n]))
        i += n
    return frames


def incomplete_telegram(data: bytes) -> bool:
    """Whether `data` is the start of a command telegram whose rest has not arrived yet.

    True for a lone command-type byte and for a known command (fixed or variable length) cut short:
    TCP may deliver any write in pieces, so the receiver keeps these bytes and waits for the rest.
    """
    if not data or (data[0] & ~TYPE_NO_REPLY) not in (TYPE_DIRECT, TYPE_SYSTEM):
        return False
    return Frame("garbage", data).truncated


def ok_reply(opcode: int, payload: bytes = b"") -> bytes:
    """A success reply: ``0x02, opcode, 0x00`` then `payload`."""
    return bytes((TYPE_REPLY, opcode & 0xFF, Status.OK)) + payload


def error_reply(opcode: int, status: int) -> bytes:
    """A failure reply carrying only the status byte (clients check the status first)."""
    return bytes((TYPE_REPLY, opcode & 0xFF, status & 0xFF))
