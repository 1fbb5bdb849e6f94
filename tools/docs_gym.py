"""One documentation page per registered gymnasium id, and its picture.

For each id of ``gym.registration.ENV_IDS`` of a shipped task this builds the real env and
writes ``docs/gym/<id>.md``: its observation and action spaces (printed from the env),
reward, success and termination (the task code's docstrings and config), the config keys
with their values and valid ranges (``tasks.config_schema.KEYS`` and the task's own
``TaskEntry.keys``), and ``docs/images/gym/<id>.png``, a small ``rgb_array`` render after
``reset(seed=0)``. The pages and pictures are committed;
``tests/docs/test_gym_pages.py`` checks the pages match the envs (rerun this after changing
a task, its config or the spaces).

    MUJOCO_GL=egl python tools/docs_gym.py            # every id (about 10 s)
    MUJOCO_GL=egl python tools/docs_gym.py --check    # exit 1 naming a page that is stale
"""

from __future__ import annotations

import argparse
import inspect
import os
import sys
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

ROOT = Path(__file__).resolve().parent.parent
PAGES = ROOT / "docs" / "gym"
IMAGES = ROOT / "docs" / "images" / "gym"
#: the picture's size (pixels): small, the pages are committed
WIDTH, HEIGHT = 320, 240


def page_name(env_id: str) -> str:
    """``TrossenMujoco/WXAIReach-v0`` -> ``WXAIReach-v0`` (file name of its page and PNG)."""
    return env_id.split("/", 1)[1]


def _doc(cls: type, method: str) -> str:
    """The docstring of ``cls.method`` (inherited ones included), one paragraph."""
    found = getattr(cls, method, None)
    return " ".join((inspect.getdoc(found) or "").split()) if found else ""


def _config_rows(config: dict[str, Any], own: dict[str, Any]) -> list[str]:
    """Table rows ``| key | value | valid |`` of a task config (``randomization`` aside);
    ``own``: the task's own keys (its ``TaskEntry.keys``), beside the shared ``KEYS``."""
    from trossen_arm_mujoco.tasks.config_schema import KEYS

    KEYS = {**KEYS, **own}
    rows = ["| Key | This task | Valid |", "|---|---|---|"]
    for key, value in config.items():
        if key == "randomization":
            continue
        valid = KEYS[key].describe() if key in KEYS else ""
        rows.append(f"| `{key}` | `{value}` | {valid.replace('|', '/')} |")
    return rows


def space_text(space: Any, indent: str = "") -> str:
    """A space as the page prints it: a ``Box`` as its shape, dtype and bounds (one
    ``low`` and one ``high`` array, wrapped at 88 columns), a ``Dict`` key by key."""
    import numpy as np

    if hasattr(space, "spaces"):
        inner = indent + "    "
        parts = [f"{inner}{key}: {space_text(sub, inner)}" for key, sub in space.spaces.items()]
        return "Dict(\n" + "\n".join(parts) + f"\n{indent})"
    if hasattr(space, "low") and np.ndim(space.low) == 1:
        if np.all(space.low == space.low[0]) and np.all(space.high == space.high[0]):
            return str(space)

        def arr(a: Any, label: str) -> str:
            pad = indent + "    " + " " * len(label)
            text = np.array2string(np.asarray(a), precision=4, max_line_width=88 - len(pad))
            return label + text.replace("\n", "\n" + pad)

        return (
            f"Box(shape={space.shape}, dtype={space.dtype},\n"
            f"{indent}    {arr(space.low, 'low=')},\n{indent}    {arr(space.high, 'high=')})"
        )
    return str(space)


def spaces_text(env: Any) -> tuple[str, str]:
    """(observation space, action space) of a made env, as the page prints them."""
    return space_text(env.observation_space), space_text(env.action_space)


def page_markdown(env_id: str, env: Any) -> str:
    """The Markdown page of ``env_id`` (``env``: ``gymnasium.make(env_id)``, unwrapped below)."""
    from trossen_arm_mujoco.gym.registration import ENV_IDS
    from trossen_arm_mujoco.tasks import registry

    entry_point, task_name, _ = ENV_IDS[env_id]
    entry = registry.load(task_name)
    task_cls = entry.task_class()
    config = entry.load_config()
    goal = "goal_env" in entry_point
    obs_text, act_text = spaces_text(env)
    reward_doc = _doc(task_cls, "reward_at") or _doc(task_cls, "get_reward")
    module = sys.modules[task_cls.__module__]
    for word in reward_doc.replace("`", " ").replace(")", " ").split():
        helper = getattr(module, word, None)
        if isinstance(helper, type) and inspect.getdoc(helper):  # "see ``SomeReward``"
            reward_doc += " " + " ".join(inspect.getdoc(helper).split())
    success_doc = _doc(task_cls, "judge_success")
    terminate = config.get("terminate_on_success", False)
    name = page_name(env_id)
    lines = [
        f"# {env_id}",
        "",
        f"Task `{task_name}` ({entry.description or inspect.getdoc(task_cls)})"
        + (", goal-conditioned (`gymnasium_robotics`-style `GoalEnv`)." if goal else "."),
        "",
        f"![{env_id} after reset(seed=0)](../images/gym/{name}.png)",
        "",
        "```python",
        "import gymnasium as gym",
        "import trossen_arm_mujoco  # registers the ids",
        "",
        f'env = gym.make("{env_id}")',
        "obs, info = env.reset(seed=0)",
        "obs, reward, terminated, truncated, info = env.step(env.action_space.sample())",
        "env.close()",
        "```",
        "",
        "## Spaces",
        "",
        'Printed from the env made with the defaults (`obs_type="state"`, '
        '`action_mode="joint_position"`); see [the overview](index.md) for the other '
        "observation types and action modes.",
        "",
        "```text",
        f"observation_space = {obs_text}",
        f"action_space = {act_text}",
        "```",
        "",
        "## Reward",
        "",
        reward_doc or "See the task's `get_reward`.",
    ]
    if goal:
        lines += [
            "",
            f"As a goal env: `goal_reward_type` = `{config.get('goal_reward_type')}` "
            "(`sparse`: -1 until within tolerance, then 0; `dense`: minus the distance); "
            "`compute_reward(achieved_goal, desired_goal, info)` is vectorized.",
        ]
    lines += [
        "",
        "## Success",
        "",
        (success_doc or "See the task's `judge_success`.")
        + ' `info["is_success"]` reports it every step.',
        "",
        "## Termination",
        "",
        f"Truncated after `max_episode_steps` = {config['max_episode_steps']} steps "
        f"(gymnasium's `TimeLimit`, from the task config). Terminated on success only when "
        f"`terminate_on_success` is true (default here: `{terminate}`).",
        "",
        "## Config keys",
        "",
        f"From `trossen_arm_mujoco/config/{entry.config}.yaml`; every key is also a keyword "
        "argument of `gym.make` that overrides the file (checked once, at construction). "
        "The `randomization` section is described in "
        "[Domain randomization](../concepts/randomization.md).",
        "",
        *_config_rows(config, dict(entry.keys)),
        "",
    ]
    return "\n".join(lines)


def write_all(check: bool = False) -> list[str]:
    """Write (or with ``check``, compare) every page and picture; returns the stale pages."""
    import gymnasium as gym
    import numpy as np

    import trossen_arm_mujoco  # noqa: F401  (registers the ids)
    from trossen_arm_mujoco.fileio import write_text
    from trossen_arm_mujoco.gym.registration import ENV_IDS

    stale = []
    PAGES.mkdir(parents=True, exist_ok=True)
    IMAGES.mkdir(parents=True, exist_ok=True)
    from trossen_arm_mujoco.tasks import registry

    for env_id, (_, task, _) in ENV_IDS.items():
        if registry.load(task).package != "trossen_arm_mujoco":
            continue  # an installed package's env (examples/my_trossen_task): its own docs
        env = gym.make(env_id, render_mode="rgb_array", width=WIDTH, height=HEIGHT)
        try:
            env.reset(seed=0)
            text = page_markdown(env_id, env.unwrapped)
            path = PAGES / f"{page_name(env_id)}.md"
            if check:
                if not path.exists() or path.read_text() != text:
                    stale.append(str(path.relative_to(ROOT)))
                continue
            write_text(path, text)
            frame = np.asarray(env.render())
            _write_png(IMAGES / f"{page_name(env_id)}.png", frame)
        finally:
            env.close()
    return stale


def _write_png(path: Path, frame: Any) -> None:
    """An RGB uint8 frame (H, W, 3) as a PNG, written atomically."""
    from PIL import Image

    from trossen_arm_mujoco.fileio import atomic_path

    with atomic_path(path) as tmp:
        Image.fromarray(frame).save(tmp, format="PNG", optimize=True)


def main(argv: list[str] | None = None) -> int:
    """Write the gym pages, or with ``--check`` exit 1 listing the stale ones."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare, write nothing")
    args = parser.parse_args(argv)
    stale = write_all(check=args.check)
    for path in stale:
        print(f"stale: {path} (run: MUJOCO_GL=egl python tools/docs_gym.py)")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
