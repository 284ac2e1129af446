"""Minimal writers of ArduPilot DataFlash (.bin) and PX4 ULog (.ulg) logs, for the tests.

Neither pymavlink nor pyulog has a writer that starts from nothing (pymavlink's
``DFReader.make_msgbuf`` needs an open log; pyulog's ``ULog.write_ulog`` re-writes a log
it has parsed), so these are small encoders written from the two formats' specs.  The
tests read what they write back through the real libraries, which is the check that the
encoders are right.

**DataFlash** (ArduPilot ``AP_Logger``): a stream of messages, each
``0xA3 0x95 <type byte> <payload>``, little-endian, no padding.  Type 128 is ``FMT``,
whose payload ``Type:B Length:B Name:char[4] Format:char[16] Columns:char[64]`` defines
another type (``Length`` counts the 3 header bytes).  Format letters used here:
``Q`` uint64, ``B`` uint8, ``f`` float32 (ArduPilot's ``LOG_*`` tables use the same).

**ULog** (PX4 ``docs/en/dev_log/ulog_file_format.md``): a 16-byte header (``ULog``,
``0x01 0x12 0x35``, version byte, uint64 start time in microseconds), then messages
``uint16 size, uint8 type, payload`` (``size`` counts the payload only): flag bits
``B`` (required first for version 1), format ``F`` (``name:type field;type field;...``),
add-logged ``A`` (``uint8 multi_id, uint16 msg_id, name``) and data ``D``
(``uint16 msg_id`` then the fields packed in format order).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

DATAFLASH_HEAD = b"\xa3\x95"
ULOG_MAGIC = b"ULog\x01\x12\x35"

_DF_STRUCT = {
    "Q": "Q",
    "q": "q",
    "B": "B",
    "b": "b",
    "f": "f",
    "d": "d",
    "I": "I",
    "i": "i",
    "H": "H",
    "h": "h",
    "n": "4s",
    "N": "16s",
    "Z": "64s",
}

# ArduPilot's own definitions (ArduCopter/Log.cpp, AC_AttitudeControl/LogStructure.h).
SIDS = ("SIDS", "QBfffffff", "TimeUS,Ax,Mag,FSt,FSp,TFin,TC,TR,TFout")
SIDD = ("SIDD", "Qfffffffff", "TimeUS,Time,Targ,F,Gx,Gy,Gz,Ax,Ay,Az")
UNIT = ("UNIT", "QbZ", "TimeUS,Id,Label")  # AP_Logger: unit id character -> unit
FMTU = ("FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds")  # per-column unit ids of a type
RATE = ("RATE", "Qfffffffffffff", "TimeUS,RDes,R,ROut,PDes,P,POut,YDes,Y,YOut,ADes,A,AOut,AOutSlew")
ATT = ("ATT", "QffffffffB", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF")  # deg


class DataFlashWriter:
    """Build a DataFlash log in memory: :meth:`define` types, :meth:`write` messages."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self._types: dict[str, tuple[int, struct.Struct, tuple[str, ...]]] = {}
        self._next_type = 0x81

    def define(self, name: str, fmt: str, columns: str) -> None:
        body = struct.Struct("<" + "".join(_DF_STRUCT[c] for c in fmt))
        type_id = self._next_type
        self._next_type += 1
        self._types[name] = (type_id, body, tuple(columns.split(",")))
        fmt_body = struct.pack(
            "<BB4s16s64s", type_id, 3 + body.size, name.encode(), fmt.encode(), columns.encode()
        )
        self._buf += DATAFLASH_HEAD + bytes([0x80]) + fmt_body

    def type_id(self, name: str) -> int:
        return self._types[name][0]

    def write(self, name: str, **fields: float | bytes) -> None:
        """One message; string fields (``n``, ``N``, ``Z``) take bytes."""
        type_id, body, columns = self._types[name]
        values = [fields.get(c, 0) for c in columns]
        self._buf += DATAFLASH_HEAD + bytes([type_id]) + body.pack(*values)

    def to_bytes(self) -> bytes:
        return bytes(self._buf)


class ULogWriter:
    """Build a version-1 ULog in memory: :meth:`topic` subscriptions, then :meth:`write`.

    Format messages belong to the definitions section, which ends at the first
    add-logged message, so they are kept apart and written before the data section."""

    _CODES = {"uint64_t": "Q", "uint8_t": "B", "float": "f", "int32_t": "i", "double": "d"}

    def __init__(self, start_us: int = 0) -> None:
        self._header = ULOG_MAGIC + bytes([1]) + struct.pack("<Q", start_us)
        flags = bytes(8) + bytes(8) + struct.pack("<3Q", 0, 0, 0)
        self._definitions = self._message(b"B", flags)
        self._data = bytearray()
        self._topics: dict[str, tuple[int, struct.Struct, tuple[str, ...]]] = {}
        self._defined: set[str] = set()

    @staticmethod
    def _message(kind: bytes, payload: bytes) -> bytearray:
        return bytearray(struct.pack("<H", len(payload)) + kind + payload)

    def info(self, key: str, value: str) -> None:
        k = f"char[{len(value)}] {key}".encode()
        self._definitions += self._message(b"I", bytes([len(k)]) + k + value.encode())

    def topic(self, name: str, fields: Sequence[tuple[str, str]], multi_id: int = 0) -> None:
        """Define and subscribe ``name`` with ``(type, field)`` pairs, e.g.
        ``("float[3]", "xyz")``; the first must be ``("uint64_t", "timestamp")``."""
        if name not in self._defined:
            text = name + ":" + "".join(f"{t} {f};" for t, f in fields)
            self._definitions += self._message(b"F", text.encode())
            self._defined.add(name)
        codes, names = [], []
        for t, f in fields:
            base, _, count = t.partition("[")
            n = int(count.rstrip("]")) if count else 1
            codes.append(self._CODES[base] * n)
            names += [f] if not count else [f"{f}[{i}]" for i in range(n)]
        msg_id = len(self._topics)
        self._topics[f"{name}/{multi_id}"] = (
            msg_id,
            struct.Struct("<" + "".join(codes)),
            tuple(names),
        )
        self._data += self._message(b"A", struct.pack("<BH", multi_id, msg_id) + name.encode())

    def write(self, name: str, multi_id: int = 0, **values: float) -> None:
        """One sample; array elements are keywords like ``xyz_0`` for ``xyz[0]``."""
        msg_id, body, names = self._topics[f"{name}/{multi_id}"]
        flat = [values.get(n.replace("[", "_").replace("]", ""), 0) for n in names]
        self._data += self._message(b"D", struct.pack("<H", msg_id) + body.pack(*flat))

    def to_bytes(self) -> bytes:
        return bytes(self._header + self._definitions + self._data)


# PX4 topic layouts (msg/VehicleAngularVelocity.msg, VehicleTorqueSetpoint.msg,
# ActuatorControls.msg before v1.14); pyulog names array elements "xyz[0]", ...
ANGULAR_VELOCITY = [
    ("uint64_t", "timestamp"),
    ("uint64_t", "timestamp_sample"),
    ("float[3]", "xyz"),
    ("float[3]", "xyz_derivative"),
]
TORQUE_SETPOINT = [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"), ("float[3]", "xyz")]
ATTITUDE = [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"), ("float[4]", "q")]  # msg/VehicleAttitude.msg
ACTUATOR_CONTROLS = [
    ("uint64_t", "timestamp"),
    ("uint64_t", "timestamp_sample"),
    ("float[8]", "control"),
]
