"""The dataset features Trossen's LeRobot plugin robots give ``lerobot-record``.

Run by tests/export/test_plugin_features.py with the Python that has LeRobot (and maybe the
plugin, ``lerobot_robot_trossen``) installed, never imported by the test suite itself::

    python plugin_features_check.py

For each robot (``widowxai_follower_robot``, ``bi_widowxai_follower_robot``,
``mobileai_robot``) and each set of its ``include_velocity`` / ``include_effort`` /
``include_external_effort`` flags, builds the robot without connecting it (the drivers it
would talk to, ``trossen_arm`` and ``trossen_slate``, are stood in for when missing: only
their constructors run) and prints LeRobot's dataset features of its action and observation
(``hw_to_dataset_features``, as ``lerobot-record`` makes them) as one line
``RESULT <json>``; ``{"unavailable": why}`` when the plugin cannot be imported.
"""

from __future__ import annotations

import importlib
import itertools
import json
import sys
import types

FLAGS = ("include_velocity", "include_effort", "include_external_effort")


def _stand_in(name: str, **classes: type) -> None:
    """A module ``name`` holding ``classes``, unless the real one imports."""
    try:
        importlib.import_module(name)
    except ImportError:
        module = types.ModuleType(name)
        for key, cls in classes.items():
            setattr(module, key, cls)
        sys.modules[name] = module


class _Inert:
    def __init__(self, *args: object, **kwargs: object) -> None:
        pass


def _features_function():
    for where in ("lerobot.utils.feature_utils", "lerobot.datasets.utils"):
        try:
            return importlib.import_module(where).hw_to_dataset_features
        except (ImportError, AttributeError):
            continue
    raise ImportError("no hw_to_dataset_features in this LeRobot")


def main() -> None:
    _stand_in("trossen_arm", TrossenArmDriver=_Inert)
    _stand_in("trossen_slate", TrossenSlate=_Inert)
    try:
        plugin = importlib.import_module("lerobot_robot_trossen")
        to_features = _features_function()
    except Exception as exc:  # not installed, or another LeRobot API
        print("RESULT " + json.dumps({"unavailable": " ".join(str(exc).split())[:300]}))
        return
    robots = {
        "widowxai_follower_robot": (
            plugin.WidowXAIFollower,
            plugin.WidowXAIFollowerConfig,
            {"ip_address": "127.0.0.1"},
        ),
        "bi_widowxai_follower_robot": (
            plugin.BiWidowXAIFollowerRobot,
            plugin.BiWidowXAIFollowerRobotConfig,
            {"left_arm_ip_address": "127.0.0.1", "right_arm_ip_address": "127.0.0.2"},
        ),
        "mobileai_robot": (
            plugin.MobileAIRobot,
            plugin.MobileAIRobotConfig,
            {"left_arm_ip_address": "127.0.0.1", "right_arm_ip_address": "127.0.0.2"},
        ),
    }
    out = {}
    for name, (robot_cls, config_cls, address) in robots.items():
        for bits in itertools.product((False, True), repeat=len(FLAGS)):
            flags = dict(zip(FLAGS, bits))
            robot = robot_cls(config_cls(**address, **flags))
            features = {
                **to_features(robot.action_features, "action"),
                **to_features(robot.observation_features, "observation"),
            }
            entry = {
                key: {"names": list(ft["names"]), "shape": list(ft["shape"])}
                for key, ft in features.items()
            }
            entry["name"] = robot.name
            entry["loop_rate"] = robot.config.loop_rate
            out[f"{name}:{','.join(f for f in FLAGS if flags[f])}"] = entry
    print("RESULT " + json.dumps({"features": out}))


if __name__ == "__main__":
    main()
