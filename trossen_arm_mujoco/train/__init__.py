"""Training helpers that run before a policy is trained: the pose encoder and its dataset."""

__all__: list[str] = []
