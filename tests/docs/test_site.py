"""The built site: a page per CLI listing every flag, a page per gym id matching the env, an
API reference of the public names only, nothing fetched from the network."""

from __future__ import annotations

import html as html_lib
import re
from pathlib import Path

import docs_cli
import pytest


def page_text(path: Path) -> str:
    """A built page's visible text (tags removed, entities decoded)."""
    return html_lib.unescape(re.sub(r"<[^>]+>", "", path.read_text(encoding="utf-8")))


@pytest.mark.parametrize("command", list(docs_cli.PARSER_MODULES))
def test_cli_page_lists_every_flag(site: Path, command: str):
    text = page_text(site / "cli" / f"{command}.html")
    actions = docs_cli.documented_actions(docs_cli.build_parser(command))
    assert actions
    missing = [
        name
        for action in actions
        for name in (action.option_strings or [action.dest])
        if name not in text
    ]
    assert not missing, f"flags of {command} missing from its page: {missing}"
    assert "All flags" in text


def test_flag_table_marks_an_unknown_command():
    with pytest.raises(KeyError, match="valid: record, visualize"):
        docs_cli.flags_markdown("recrod")


_ASSET = re.compile(
    r"""<(?:script|link|img|iframe|source|video|audio)\b[^>]*?\b(?:src|href)=["']((?:https?:)?//[^"']+)""",
    re.IGNORECASE,
)
_CSS_URL = re.compile(r"""(?:url\(\s*["']?|@import\s+["'])((?:https?:)?//[^"')]+)""")


def test_site_fetches_nothing_from_the_network(site: Path):
    """No fonts, scripts, styles or pictures from a CDN: the site works offline."""
    remote = []
    for page in site.rglob("*.html"):
        remote += [f"{page.relative_to(site)}: {u}" for u in _ASSET.findall(page.read_text())]
    for sheet in site.rglob("*.css"):
        remote += [f"{sheet.relative_to(site)}: {u}" for u in _CSS_URL.findall(sheet.read_text())]
    assert not remote, remote[:10]
    assert len(list(site.rglob("*.html"))) >= 30


def test_api_reference_shows_the_public_names_only(site: Path):
    from trossen_arm_mujoco.tasks import registry, sampler

    text = page_text(site / "reference" / "tasks.html")
    for name in [*registry.__all__, *sampler.__all__]:
        assert name in text, name
    private = [n for n in vars(registry) if n.startswith("_") and not n.startswith("__")]
    assert "_shipped" in private and "_shipped" not in text


def test_gym_pages_match_the_envs():
    """Each gym id's committed page prints the spaces of the env as it is now (rerun
    ``tools/docs_gym.py`` after changing a task)."""
    import docs_gym
    import gymnasium as gym

    import trossen_arm_mujoco  # noqa: F401
    from trossen_arm_mujoco.gym.registration import ENV_IDS
    from trossen_arm_mujoco.tasks import registry

    for env_id, (_, task, _) in ENV_IDS.items():
        if registry.load(task).package != "trossen_arm_mujoco":
            continue  # an installed package's env (examples/my_trossen_task): its own docs
        page = (docs_gym.PAGES / f"{docs_gym.page_name(env_id)}.md").read_text()
        env = gym.make(env_id)
        try:
            obs_text, act_text = docs_gym.spaces_text(env.unwrapped)
        finally:
            env.close()
        stale = "stale: MUJOCO_GL=egl python tools/docs_gym.py"
        assert f"observation_space = {obs_text}\n" in page, f"{env_id}: {stale}"
        assert f"action_space = {act_text}\n" in page, f"{env_id}: {stale}"
        assert (docs_gym.IMAGES / f"{docs_gym.page_name(env_id)}.png").stat().st_size > 5000
