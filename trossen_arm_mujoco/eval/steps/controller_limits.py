"""The arm controller's limits as a pair of processor steps (the JSON side, the limits and
their reasons: ``eval.controller_limits_step``).

:class:`MeasuredJointsStep` (preprocessor) notes each observation's measured joints;
:class:`ControllerLimitsStep` (postprocessor) keeps each action within what the controller
accepts, near those joints. The two steps of one loaded policy are paired when LeRobot
builds them: each step waits for the first unpaired step of the other kind with the same
``link`` (the checkpoint's token), so two policies loaded from one checkpoint in one process
(pre, post, pre, post, or both pre first) keep their own measured joints.

Docs: docs/cli/prepare.md.
"""

from __future__ import annotations

import threading
import weakref
from collections import defaultdict, deque
from dataclasses import dataclass, field
from typing import Any

import torch
from lerobot.processor import ProcessorStepRegistry
from lerobot.processor.pipeline import ActionProcessorStep, ObservationProcessorStep

from trossen_arm_mujoco.eval.step_names import LIMITS as REGISTRY_NAME
from trossen_arm_mujoco.eval.step_names import MEASURED as MEASURED_NAME
from trossen_arm_mujoco.robot.lerobot_keys import STATE_KEY

__all__ = ["ControllerLimitsStep", "MeasuredJointsStep"]

_lock = threading.Lock()
# unpaired steps (weak references), by link and kind ("measured" / "limits"), oldest first
_waiting: dict[tuple[str, str], deque] = defaultdict(deque)


def _pair(step: Any, kind: str, other: str) -> None:
    """Pair ``step`` with the oldest unpaired live step of kind ``other`` and its link, or
    let it wait for one."""
    if not step.link:
        return
    with _lock:
        queue = _waiting[(step.link, other)]
        while queue:
            partner = queue.popleft()()
            if partner is not None:
                step._partner, partner._partner = partner, step
                return
        _waiting[(step.link, kind)].append(weakref.ref(step))


@ProcessorStepRegistry.register(MEASURED_NAME)
@dataclass
class MeasuredJointsStep(ObservationProcessorStep):
    """Note the observation's measured joints (``observation.state``) for the paired
    :class:`ControllerLimitsStep`; the observation is left as it is.

    Args:
        link: the checkpoint's token shared with its limits step.
    """

    link: str = ""
    measured: Any = field(default=None, init=False, repr=False)
    _partner: Any = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        _pair(self, "measured", "limits")

    def observation(self, observation: dict[str, Any]) -> dict[str, Any]:
        state = observation.get(STATE_KEY)
        if state is not None:
            self.measured = torch.as_tensor(state).detach().clone()
        return observation

    def get_config(self) -> dict[str, Any]:
        return {"link": self.link}

    def transform_features(self, features):
        return features


@ProcessorStepRegistry.register(REGISTRY_NAME)
@dataclass
class ControllerLimitsStep(ActionProcessorStep):
    """Clip each action value into [low, high] (the arm controller's accepted range); where
    ``max_step`` is positive and the paired step has measured joints, into measured +-
    ``max_step``; where ``max_rate`` is positive (the grippers), within ``max_rate`` of the
    value this step gave last (of the measured value at an episode's start: after
    :meth:`reset`, or when the measured joints jump further than an arm can move in a period,
    as at an env's reset).

    Args:
        low, high: per action value, the controller's accepted range (rad; m).
        max_step: per value, the largest distance from the measured joints (0: none).
        max_rate: per value, the largest change from the last action (0: none).
        link: the checkpoint's token shared with its :class:`MeasuredJointsStep`.
    """

    low: list[float] = field(default_factory=list)
    high: list[float] = field(default_factory=list)
    max_step: list[float] = field(default_factory=list)
    max_rate: list[float] = field(default_factory=list)
    link: str = ""
    _partner: Any = field(default=None, init=False, repr=False)
    _last: Any = field(default=None, init=False, repr=False)
    _seen: Any = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        _pair(self, "limits", "measured")

    def reset(self) -> None:
        self._last = self._seen = None

    def _measured(self, action: torch.Tensor) -> torch.Tensor | None:
        measured = None if self._partner is None else self._partner.measured
        if not self.max_step or measured is None or measured.shape[-1] != action.shape[-1]:
            return None
        return measured.to(device=action.device, dtype=action.dtype)

    def action(self, action: torch.Tensor) -> torch.Tensor:
        def tensor(values):
            return torch.as_tensor(values, dtype=action.dtype, device=action.device)

        low, high = tensor(self.low), tensor(self.high)
        action = torch.clamp(action, low, high)
        near = self._measured(action)
        if near is None:
            return action
        step = tensor(self.max_step)
        action = torch.where(step > 0, torch.clamp(action, near - step, near + step), action)
        if self.max_rate:
            last = self._last
            if last is None or last.shape != action.shape:
                last = near
            elif self._seen is not None and self._seen.shape == near.shape:
                # an arm cannot move 1.5 x max_step (3.4 periods at its top speed), nor a
                # gripper 3 x max_rate (2.7 periods), between two observations: a new
                # episode started (LeRobot's runners do not reset the processors)
                rate = tensor(self.max_rate)
                moved = (near - self._seen).abs()
                jumped = ((moved > 1.5 * step) & (step > 0)) | ((moved > 3 * rate) & (rate > 0))
                last = torch.where(jumped.any(dim=-1, keepdim=True), near, last)
            rate = tensor(self.max_rate)
            action = torch.where(rate > 0, torch.clamp(action, last - rate, last + rate), action)
            action = torch.clamp(action, low, high)
        self._seen = near.clone()
        self._last = action.detach().clone()
        return action

    def get_config(self) -> dict[str, Any]:
        config: dict[str, Any] = {"low": list(self.low), "high": list(self.high)}
        if self.max_step:
            config.update(max_step=list(self.max_step), link=self.link)
        if self.max_rate:
            config.update(max_rate=list(self.max_rate))
        return config

    def transform_features(self, features):
        return features
