"""Training helpers that run before a policy is trained: the pose encoder and its dataset."""
