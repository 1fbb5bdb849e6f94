"""Training: what a policy trains on beyond the export (a pose encoder and the dataset of its
estimates) and ``trossen-mujoco train``, the whole loop over several training seeds (one
module per part: ``command``, ``workspace``, ``recipes``, ``flags``, ``recording``,
``encoding``, ``training``, ``scoring``, ``report``).

Docs: docs/cli/train.md, docs/train-eval.md.
"""

__all__: list[str] = []
