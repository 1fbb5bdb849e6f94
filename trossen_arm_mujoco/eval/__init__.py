"""Policy evaluation in the sim: the policy's env (``env``), scores (``scores``), the runner
(``runner``) behind ``trossen-mujoco eval``."""
