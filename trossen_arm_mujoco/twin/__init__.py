"""The Stationary AI kit behind the arm controller's wire protocol, and teleoperation.

Serving a simulated arm: :mod:`.serving`. The served kit (``trossen-mujoco serve``,
``replay-real --backend wire``): :mod:`.kit_world`, :mod:`.arm_world`, :mod:`.pacer`,
:mod:`.commands`, :mod:`.arm_adapter`, :mod:`.faults`, :mod:`.arm_server`,
:mod:`.served_kit`, :mod:`.frame`, :mod:`.session_recorder`, :mod:`.episode_spool`,
:mod:`.spool_recovery`, :mod:`.camera_stream`,
:mod:`.episode_control`. Teleoperation: :mod:`.leader_server`, :mod:`.leader_trajectory`,
:mod:`.replay_clock`, :mod:`.leaders`, :mod:`.leader_arms`, :mod:`.teleop`. Serving needs the
optional ``trossen_arm_sim`` package, reading leader arms ``trossen_arm``.

Docs: docs/cli/serve.md, docs/cli/teleop.md, docs/rehearsal.md; what each module owns:
docs/concepts/design-notes.md.
"""

__all__: list[str] = []  # submodules only: import them by name
