"""What an episode is: tasks (reward, success, timing) and samplers (randomization)."""
