"""The Stationary AI kit behind the arm controller's wire protocol, and teleoperation.

Serving a simulated arm (both kinds below build on it):

- :mod:`.serving`: the optional protocol package, loopback addresses, and
  ``LoopbackArmServer``: ``trossen_arm_sim``'s protocol server on a loopback address only,
  with a stop that ends its threads and robust request handling.

The served kit (``trossen-mujoco serve``, ``replay-real --backend wire``):

- :mod:`.kit_world`: one world of both arms and a task's objects, stepping in real time;
- :mod:`.pacer`: pacing that world to wall-clock time;
- :mod:`.commands`: what the clients of one served arm command now (modes and targets);
- :mod:`.arm_adapter`: one arm of that world as the protocol server drives it (modes);
- :mod:`.faults`: a served arm's joint limits and the checks that put it in an error state;
- :mod:`.arm_server`: the protocol server of one follower arm (faults, every mode,
  joint limits, session events);
- :mod:`.served_kit`: both arms served on their own loopback addresses, started and
  stopped together;
- :mod:`.frame`: one frame of the served world, as a recorder stores it;
- :mod:`.session_recorder`: client sessions recorded as episodes;
- :mod:`.episode_spool`: an episode's steps kept on disk until it ends, then published as
  an episode file (served sessions and teleoperation);
- :mod:`.spool_recovery`: a dead process's spool, published by the next run;
- :mod:`.stop_signals`: stop signals as requests, so that any number of them end serving
  cleanly;
- :mod:`.camera_stream`: the kit's cameras over ZeroMQ in LeRobot's ZMQ camera protocol
  (``serve --cameras``);
- :mod:`.episode_control`: the episode control channel (``serve --control_port``: start
  with a seed, end, status).

Teleoperation:

- :mod:`.leader_server`: the protocol server of one simulated leader arm;
- :mod:`.leader_trajectory`: what served leaders play: an episode's joint values per arm;
- :mod:`.replay_clock`: when their replay runs (trigger, lead-in, approach, speed);
- :mod:`.leaders`: a pair of leader arms replaying a recorded episode (``serve_leaders``);
- :mod:`.leader_arms`: leader arms (real or served) read through the ``trossen_arm`` driver;
- :mod:`.teleop`: leader arms drive the simulated followers, recording episodes
  (``trossen-mujoco teleop``).

Serving needs the optional ``trossen_arm_sim`` package, reading leader arms ``trossen_arm``.
"""

__all__: list[str] = []  # submodules only: import them by name
