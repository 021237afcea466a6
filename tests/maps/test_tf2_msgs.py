"""tf2_msgs/msg/TFMessage: Jazzy's definition and type hash, so rviz2 and `ros2 topic echo /tf` interoperate."""

import copy
import hashlib
import json
import os
import sys
from pathlib import Path

from geometry_msgs.msg import TransformStamped
from rclpy.type_support import check_for_type_support
from tf2_msgs.msg import TFMessage

# Obtained by building upstream ros2/geometry2 branch jazzy (tf2_msgs 0.36.4, all four interfaces) with
# rosidl 4.6 from the ros-jazzy-* wheels into a scratch prefix and reading share/tf2_msgs/msg/TFMessage.json.
JAZZY_TF_MESSAGE_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


def type_description_file() -> Path:
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p] + [sys.prefix]
    for prefix in prefixes:
        path = Path(prefix) / "share" / "tf2_msgs" / "msg" / "TFMessage.json"
        if path.is_file():
            return path
    raise AssertionError(f"no tf2_msgs/msg/TFMessage.json under {prefixes}")


def rihs01(type_description_msg: dict) -> str:
    """REP 2011's type hash: SHA-256 of the description's compact JSON without default values."""
    hashable = copy.deepcopy(type_description_msg)
    for description in [hashable["type_description"], *hashable["referenced_type_descriptions"]]:
        for field in description["fields"]:
            del field["default_value"]
    text = json.dumps(
        hashable, ensure_ascii=True, allow_nan=False, indent=None, separators=(", ", ": "), sort_keys=False
    )
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def test_the_installed_tf_message_hashes_as_jazzy_does():
    data = json.loads(type_description_file().read_text())
    recorded = {entry["type_name"]: entry["hash_string"] for entry in data["type_hashes"]}
    assert rihs01(data["type_description_msg"]) == recorded["tf2_msgs/msg/TFMessage"] == JAZZY_TF_MESSAGE_HASH
    fields = data["type_description_msg"]["type_description"]["fields"]
    assert [(f["name"], f["type"]["nested_type_name"]) for f in fields] == [
        ("transforms", "geometry_msgs/msg/TransformStamped")
    ]


def test_the_message_carries_transforms_and_has_type_support():
    check_for_type_support(TFMessage)
    message = TFMessage(transforms=[TransformStamped(child_frame_id="base_footprint")])
    message.transforms[0].header.frame_id = "odom"
    assert message.transforms[0].header.frame_id == "odom"
    assert list(TFMessage.get_fields_and_field_types()) == ["transforms"]
