"""Policy evaluation in the sim: the policy's env (``env``), scores (``scores``), the runner
(``runner``) behind ``trossen-mujoco eval``; through the served kit in wall-clock time
(``wire_backend``, ``wire_env``, ``wire_link``: ``eval --backend wire``).

Docs: docs/cli/eval.md, docs/train-eval.md, docs/rehearsal.md.
"""

__all__: list[str] = []  # submodules only: import them by name
