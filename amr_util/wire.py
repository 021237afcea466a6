"""A message kept serialized, its changing fields rewritten in place: publishing without converting a message.

rclpy's `Publisher.publish(message)` converts the Python message into its C struct (every nested message checked
and copied) and serializes it: for a nav_msgs/Odometry that conversion costs about twice the DDS write. A node
that publishes the same message each step with only a stamp, a pose and a few counters changed can instead keep
the serialized bytes (CDR, exactly as rmw serializes the message) and overwrite those fields where they lie;
`Publisher.publish(bytes)` then writes them as they are. Subscribers receive the same bytes either way.

Where each field lies is found by serializing the template with two probe values in the field and finding the one
place that holds their bytes (no CDR layout is written out here), and checked once at construction: the bytes with
every field rewritten must deserialize to the message with those values set. (Byte for byte the two may differ in
the alignment padding, which the serializer leaves as it finds it and no reader looks at.) Only fixed-size fields
(numbers and booleans, and the elements of a sequence of numbers whose length stays) can be rewritten: strings and
the lengths of sequences are part of the template.
"""

from __future__ import annotations

import copy
import struct
from collections.abc import Sequence

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message

FORMATS = {
    "boolean": "?",
    "octet": "B",
    "uint8": "B",
    "int8": "b",
    "char": "B",
    "int16": "h",
    "uint16": "H",
    "int32": "i",
    "uint32": "I",
    "int64": "q",
    "uint64": "Q",
    "float": "f",
    "double": "d",
}
"""struct formats of the ROS 2 IDL number types (as get_fields_and_field_types names them)."""


def _parent(message, path: Sequence[str]):
    """The message (or sequence) holding the last part of `path`."""
    for part in path[:-1]:
        message = message[int(part)] if part.isdigit() else getattr(message, part)
    return message


def _kind(message, path: Sequence[str]) -> tuple[str, bool]:
    """(struct format, is a sequence of numbers) of the field at `path`."""
    parent = _parent(message, path)
    fields = type(parent).get_fields_and_field_types()
    name = path[-1]
    if name not in fields:
        raise ValueError(f"{type(parent).__name__} has no field {name!r}")
    declared = fields[name]
    if declared.startswith("sequence<") and declared.endswith(">"):
        element = declared[len("sequence<") : -1]
        if element in FORMATS:
            return FORMATS[element], True
    if declared in FORMATS:
        return FORMATS[declared], False
    raise ValueError(
        f"{'.'.join(path)} is a {declared}: only numbers, booleans and sequences of numbers can be rewritten in place"
    )


def _probes(fmt: str) -> tuple[object, object]:
    """Two values of the format whose bytes differ in every position."""
    if fmt == "?":
        return False, True
    size = struct.calcsize(fmt)
    return tuple(struct.unpack(f"<{fmt}", bytes([pattern] * size))[0] for pattern in (0x11, 0x22))


def _set(message, path: Sequence[str], value, sequence: bool) -> None:
    parent = _parent(message, path)
    if sequence:
        values = list(getattr(parent, path[-1]))
        values[0] = value
        setattr(parent, path[-1], values)
    else:
        setattr(parent, path[-1], value)


class WireMessage:
    """`template` serialized once; `fill(*values)` rewrites `fields` (dotted paths, "transforms.0.header.stamp.sec";
    a sequence of numbers takes a whole array of its length) and returns the bytes to publish."""

    def __init__(self, template, fields: Sequence[str]) -> None:
        self.message_type = type(template)
        self.fields = tuple(fields)
        data = serialize_message(template)
        # a fresh copy, as a subscriber would receive it: no part shared between two fields (two transforms given
        # one stamp object would otherwise move together when probed)
        template = deserialize_message(data, self.message_type)
        self._buffer = bytearray(data)
        endian = "<" if data[1] == 1 else ">"  # the CDR encapsulation: 0x0001 little endian, 0x0000 big
        slots = []
        for field in self.fields:
            path = field.split(".")
            fmt, sequence = _kind(template, path)
            if sequence and not len(getattr(_parent(template, path), path[-1])):
                raise ValueError(f"{field}: an empty sequence cannot be located; give the template its length")
            first, second = _probes(fmt)
            serialized = []
            for value in (first, second):
                probe = copy.deepcopy(template)
                _set(probe, path, value, sequence)
                serialized.append(serialize_message(probe))
            if len(serialized[0]) != len(data) or len(serialized[1]) != len(data):
                raise ValueError(f"{field}: the serialized size changes with its value")
            size = struct.calcsize(fmt)
            patterns = [struct.pack(endian + fmt, value) for value in (first, second)]
            offsets = [
                offset
                for offset in range(len(data) - size + 1)
                if serialized[0][offset : offset + size] == patterns[0]
                and serialized[1][offset : offset + size] == patterns[1]
            ]
            if len(offsets) != 1:  # (padding bytes are not part of the message: they may differ between runs)
                raise ValueError(f"{field}: not found in the serialized {self.message_type.__name__}")
            offset = offsets[0]
            count = len(getattr(_parent(template, path), path[-1])) if sequence else 1
            slots.append((offset, fmt, count, sequence))
        self._writers = self._merge(slots, endian)
        self._check(template)

    @staticmethod
    def _merge(slots, endian: str) -> list:
        """(offset, Struct, first value index, value count) for each run of adjacent scalar fields, and
        (offset, numpy dtype, value index, length) for each sequence."""
        writers, index = [], 0
        for offset, fmt, count, sequence in slots:
            if sequence:
                writers.append((offset, np.dtype(endian + fmt), index, count))
            elif (
                writers
                and isinstance(writers[-1][1], str)
                and writers[-1][0] + struct.calcsize(endian + writers[-1][1]) == offset
            ):
                start, fmts, first, number = writers[-1]
                writers[-1] = (start, fmts + fmt, first, number + 1)
            else:
                writers.append((offset, fmt, index, 1))
            index += 1
        return [
            (offset, struct.Struct(endian + kind) if isinstance(kind, str) else kind, first, number)
            for offset, kind, first, number in writers
        ]

    def _check(self, template) -> None:
        """Every field rewritten at once must give the serialization of the message with those values."""
        probe, values = copy.deepcopy(template), []
        for field in self.fields:
            path = field.split(".")
            fmt, sequence = _kind(template, path)
            value = _probes(fmt)[1]
            if sequence:
                length = len(getattr(_parent(template, path), path[-1]))
                setattr(_parent(probe, path), path[-1], [value] * length)
                values.append(np.full(length, value))
            else:
                _set(probe, path, value, False)
                values.append(value)
        saved = bytes(self._buffer)
        if deserialize_message(self.fill(*values), self.message_type) != deserialize_message(
            serialize_message(probe), self.message_type
        ):
            raise ValueError(f"{self.message_type.__name__}: the fields {self.fields} do not rewrite in place")
        self._buffer[:] = saved

    def fill(self, *values) -> bytes:
        """The serialized message with `values` in `fields` (in their order)."""
        buffer = self._buffer
        for offset, writer, first, number in self._writers:
            if isinstance(writer, struct.Struct):
                writer.pack_into(buffer, offset, *values[first : first + number])
            else:
                array = np.asarray(values[first], dtype=writer)
                if array.shape != (number,):
                    raise ValueError(f"{self.fields[first]}: {array.size} values for a sequence of {number}")
                buffer[offset : offset + array.nbytes] = array.tobytes()
        return bytes(buffer)
