"""A ROS message serialized by hand, as XCDR1 (what rmw_fastrtps writes: 8-byte values aligned to 8) or XCDR2
(PLAIN_CDR2, which another middleware may send: no value aligned beyond 4, encapsulation 0x0007), little-endian, from
the message's own field list (rosidl's get_fields_and_field_types). The viewer's tests feed both to its decoder."""

from __future__ import annotations

import re
import struct

PRIMITIVES = {
    "boolean": "?",
    "octet": "B",
    "uint8": "B",
    "int8": "b",
    "char": "B",
    "uint16": "H",
    "int16": "h",
    "uint32": "I",
    "int32": "i",
    "uint64": "Q",
    "int64": "q",
    "float": "f",
    "double": "d",
}
HEADERS = {1: b"\x00\x01\x00\x00", 2: b"\x00\x07\x00\x00"}


def serialized(message, version: int) -> bytes:
    """The message's bytes in XCDR `version` (1 or 2), little-endian, with the encapsulation header."""
    writer = _Writer(8 if version == 1 else 4)
    writer.message(message)
    return HEADERS[version] + bytes(writer.data)


class _Writer:
    def __init__(self, largest_alignment: int) -> None:
        self.data = bytearray()
        self.largest = largest_alignment

    def _align(self, size: int) -> None:
        self.data += b"\x00" * (-len(self.data) % min(size, self.largest))

    def primitive(self, kind: str, value) -> None:
        code = PRIMITIVES[kind]
        size = struct.calcsize(code)
        self._align(size)
        self.data += struct.pack("<" + code, value)

    def string(self, text: str) -> None:
        encoded = text.encode() + b"\x00"
        self.primitive("uint32", len(encoded))
        self.data += encoded

    def message(self, message) -> None:
        for name, kind in message.get_fields_and_field_types().items():
            self.value(kind, getattr(message, name))

    def value(self, kind: str, value) -> None:
        sequence = re.fullmatch(r"sequence<(.+?)(?:, \d+)?>", kind)
        array = re.fullmatch(r"(.+)\[(\d+)\]", kind)
        if sequence:
            self.primitive("uint32", len(value))
            for item in value:
                self.value(sequence[1], item)
        elif array:
            for item in value:
                self.value(array[1], item)
        elif kind in PRIMITIVES:
            self.primitive(kind, value)
        elif kind == "string":
            self.string(value)
        else:
            self.message(value)
