#!/usr/bin/env python3
"""Recomputes the ROS 2 type hashes of src/ros2/ros2_typehash.h from the message definitions.

REP 2011 (RIHS version 01) as ROS's rosidl_generator_type_description computes it:
  * each type is described as {"type_name": "pkg/msg/Name", "fields": [...]}, fields in their
    .msg order, each {"name", "type": {"type_id", "capacity", "string_capacity",
    "nested_type_name"}} (the field's "default_value" is dropped before hashing; constants are not
    fields and are not hashed);
  * the hashed document is {"type_description": <the type>, "referenced_type_descriptions":
    [every type it reaches through nested fields, sorted by type_name]};
  * it is serialised by Python's json.dumps with separators (", ", ": "), keys in that order, no
    indent, ASCII; the hash is "RIHS01_" + the SHA-256 of its UTF-8 bytes in lower-case hex.

PUBLISHED holds each hash as ROS's own generator emitted it, found in rosidl-generated C sources
(the TYPE_HASH of <type>__struct.h, get_type_hash() of <type>__description.c, and the
EXPECTED_HASH tables of packages that reference the type) in public build trees of ROS 2 packages.
Every one of the ten types below was matched against such a value; none is only recomputed.

Run by `make check` (tests/run-tests.sh); prints cmocka's summary lines. Needs only Python 3.
"""

import copy
import hashlib
import json
import os
import re
import sys
import unittest

import summary

HERE = os.path.dirname(os.path.abspath(__file__))
HEADER = os.path.join(HERE, "..", "..", "src", "ros2", "ros2_typehash.h")
SOURCE = os.path.join(HERE, "..", "..", "src", "ros2", "ros2_typehash.c")

# type_description_interfaces/msg/FieldType.msg: the ids of the field types used here.
FIELD_NESTED = 1
FIELD_IDS = {"int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7,
             "int64": 8, "uint64": 9, "float32": 10, "float64": 11, "byte": 16, "string": 17}
# A fixed array adds 48 to the element's id, an unbounded sequence 144 (FieldType.msg).
ARRAY_OFFSET = 48
SEQUENCE_OFFSET = 144

# The .msg definitions (fields only, in order), as shipped by ROS 2 Iron and later.
MSGS = {
    "builtin_interfaces/msg/Time": "int32 sec; uint32 nanosec",
    "std_msgs/msg/Header": "builtin_interfaces/msg/Time stamp; string frame_id",
    "std_msgs/msg/Int64": "int64 data",
    "std_msgs/msg/Float64": "float64 data",
    "std_msgs/msg/String": "string data",
    "diagnostic_msgs/msg/KeyValue": "string key; string value",
    "diagnostic_msgs/msg/DiagnosticStatus":
        "byte level; string name; string message; string hardware_id; "
        "diagnostic_msgs/msg/KeyValue[] values",
    "diagnostic_msgs/msg/DiagnosticArray":
        "std_msgs/msg/Header header; diagnostic_msgs/msg/DiagnosticStatus[] status",
    "sensor_msgs/msg/NavSatStatus": "int8 status; uint16 service",
    "sensor_msgs/msg/NavSatFix":
        "std_msgs/msg/Header header; sensor_msgs/msg/NavSatStatus status; float64 latitude; "
        "float64 longitude; float64 altitude; float64[9] position_covariance; "
        "uint8 position_covariance_type",
}

# The hashes ROS's generator emitted (see the module comment), and the C macro that must hold each.
PUBLISHED = {
    "std_msgs/msg/Int64": ("ROS2_TYPEHASH_INT64",
        "RIHS01_8cd1048c2f186b6bd9a92472dc1ce51723c0833a221e2b7aecfff111774f4b49"),
    "std_msgs/msg/Float64": ("ROS2_TYPEHASH_FLOAT64",
        "RIHS01_705ba9c3d1a09df43737eb67095534de36fd426c0587779bda2bc51fe790182a"),
    "std_msgs/msg/String": ("ROS2_TYPEHASH_STRING",
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"),
    "std_msgs/msg/Header": ("ROS2_TYPEHASH_HEADER",
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01"),
    "builtin_interfaces/msg/Time": ("ROS2_TYPEHASH_TIME",
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197"),
    "diagnostic_msgs/msg/KeyValue": ("ROS2_TYPEHASH_KEY_VALUE",
        "RIHS01_d68081eaa540288c5440753baecef0c4e16e81a5f78ad68902ded5100413bb42"),
    "diagnostic_msgs/msg/DiagnosticStatus": ("ROS2_TYPEHASH_DIAGNOSTIC_STATUS",
        "RIHS01_b0e3e692ea2d54a8af2f4ef1930e81556a2db55216b771f8a7d2724ed47bf0e4"),
    "diagnostic_msgs/msg/DiagnosticArray": ("ROS2_TYPEHASH_DIAGNOSTIC_ARRAY",
        "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e"),
    "sensor_msgs/msg/NavSatStatus": ("ROS2_TYPEHASH_NAVSATSTATUS",
        "RIHS01_d1ed3befa628e09571bd273b888ba1c1fd187c9a5e0006b385d7e5e9095a3204"),
    "sensor_msgs/msg/NavSatFix": ("ROS2_TYPEHASH_NAVSATFIX",
        "RIHS01_62223ab3fe210a15976021da7afddc9e200dc9ec75231c1b6a557fc598a65404"),
}


def field(decl):
    """One "type name" declaration of MSGS -> its field description (with default_value)."""
    ftype, name = decl.split()
    m = re.fullmatch(r"([\w/]+)(?:\[(\d*)\])?", ftype)
    base, bound = m.group(1), m.group(2)
    nested = base if "/" in base else ""
    type_id = FIELD_NESTED if nested else FIELD_IDS[base]
    capacity = 0
    if bound == "":
        type_id += SEQUENCE_OFFSET
    elif bound is not None:
        type_id += ARRAY_OFFSET
        capacity = int(bound)
    return {"name": name,
            "type": {"type_id": type_id, "capacity": capacity, "string_capacity": 0,
                     "nested_type_name": nested},
            "default_value": ""}


def individual(type_name, msgs):
    return {"type_name": type_name,
            "fields": [field(d.strip()) for d in msgs[type_name].split(";")]}


def full_description(type_name, msgs):
    """The type and every type it reaches, sorted by name (extract_full_type_description)."""
    seen, queue = set(), [type_name]
    while queue:
        for f in individual(queue.pop(), msgs)["fields"]:
            n = f["type"]["nested_type_name"]
            if n and n not in seen:
                seen.add(n)
                queue.append(n)
    return {"type_description": individual(type_name, msgs),
            "referenced_type_descriptions": [individual(n, msgs) for n in sorted(seen)]}


def hashable_json(desc):
    d = copy.deepcopy(desc)
    for t in [d["type_description"]] + d["referenced_type_descriptions"]:
        for f in t["fields"]:
            del f["default_value"]
    return json.dumps(d, ensure_ascii=True, indent=None, separators=(", ", ": "),
                      sort_keys=False)


def type_hash(type_name, msgs=MSGS):
    digest = hashlib.sha256(hashable_json(full_description(type_name, msgs)).encode("utf-8"))
    return "RIHS01_" + digest.hexdigest()


def header_macros():
    """ROS2_TYPEHASH_* "RIHS01_..." macros of the header -> {macro: value}."""
    with open(HEADER, encoding="utf-8") as f:
        text = f.read()
    return dict(re.findall(r'#define\s+(ROS2_TYPEHASH_\w+)\s*\\?\s*"(RIHS01_[0-9a-f]+)"', text))


class TypeHash(unittest.TestCase):
    def test_recomputed_equals_published(self):
        for type_name, (_, published) in PUBLISHED.items():
            with self.subTest(type_name):
                self.assertEqual(type_hash(type_name), published)

    def test_header_holds_the_recomputed_hashes(self):
        macros = header_macros()
        self.assertEqual(set(macros), {m for m, _ in PUBLISHED.values()})
        for type_name, (macro, _) in PUBLISHED.items():
            with self.subTest(macro):
                self.assertEqual(macros[macro], type_hash(type_name))

    def test_source_names_each_type_with_its_macro(self):
        # TYPE("pkg", "Name", MACRO) rows: the ROS name pkg/msg/Name must carry its own hash.
        with open(SOURCE, encoding="utf-8") as f:
            rows = re.findall(r'TYPE\("(\w+)", "(\w+)", (ROS2_TYPEHASH_\w+)\)', f.read())
        self.assertEqual({"%s/msg/%s" % (p, n): m for p, n, m in rows},
                         {t: m for t, (m, _) in PUBLISHED.items()})

    def test_json_form_is_byte_exact(self):
        # Pins the form itself (key order, separators, the dropped default_value), so a change
        # that altered every hash alike would still fail here.
        self.assertEqual(
            hashable_json(full_description("std_msgs/msg/Header", MSGS)),
            '{"type_description": {"type_name": "std_msgs/msg/Header", "fields": [{"name": '
            '"stamp", "type": {"type_id": 1, "capacity": 0, "string_capacity": 0, '
            '"nested_type_name": "builtin_interfaces/msg/Time"}}, {"name": "frame_id", "type": '
            '{"type_id": 17, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}]}, '
            '"referenced_type_descriptions": [{"type_name": "builtin_interfaces/msg/Time", '
            '"fields": [{"name": "sec", "type": {"type_id": 6, "capacity": 0, '
            '"string_capacity": 0, "nested_type_name": ""}}, {"name": "nanosec", "type": '
            '{"type_id": 7, "capacity": 0, "string_capacity": 0, "nested_type_name": ""}}]}]}')

    def test_a_changed_definition_changes_the_hash(self):
        # The check can fail: a field's type, name, order or a referenced type each move the hash.
        changes = {
            "std_msgs/msg/Int64": "int32 data",
            "std_msgs/msg/String": "string value",
            "diagnostic_msgs/msg/KeyValue": "string value; string key",
            "builtin_interfaces/msg/Time": "int32 sec; int32 nanosec",
        }
        for type_name, definition in changes.items():
            with self.subTest(type_name):
                msgs = dict(MSGS, **{type_name: definition})
                self.assertNotEqual(type_hash(type_name, msgs), type_hash(type_name))
        # A change deep in a referenced type reaches the top-level hash.
        msgs = dict(MSGS, **{"builtin_interfaces/msg/Time": "int32 sec; int32 nanosec"})
        self.assertNotEqual(type_hash("sensor_msgs/msg/NavSatFix", msgs),
                            type_hash("sensor_msgs/msg/NavSatFix"))


if __name__ == "__main__":
    sys.exit(summary.run(__name__))
